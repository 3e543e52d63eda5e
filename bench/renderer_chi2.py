#!/usr/bin/python3
"""A renderer's sampling test on bsdfmix's fits: Mitsuba 3's chi-square test (scripts/mitsuba_chi2.py)
on the shipped RGL files and the fiber presets, each fitted and also packed with displacement.

Each table is made once in --work (`import rgl` at --rgl-grid; `generate fiber` at --fiber-grid),
fitted at --rows theta_o rows spread over its grid (K up to --k-max), and packed with
`--interpolation displace`. Fits already in --work are reused. Each mixture gets 6 views: 3 fitted
rows (the most normal, a middle one, the most grazing) and 3 midpoints between grid rows, at
1,000,000 samples. All views of a run share one Sidak correction.

    /usr/bin/python3 bench/renderer_chi2.py --bsdfmix build/bsdfmix --work out/renderer_chi2
        [--materials paper_white,...] [--presets silk,...] [--rgl-grid 45,90,180] [--fiber-grid 90,90,180]
        [--rows 10] [--k-max 16] [--map equal_area] [--csv bench/results/renderer_chi2.csv]

--map is the fits' `fit.map` (docs/fitting.md, "The map"): equal_area (the default here) or theta_phi.
bench/results/renderer_chi2.csv holds the equal-area fits, renderer_chi2_theta_phi.csv the (theta, phi) ones.

Writes the CSV (table,theta_o_deg,view,p_value,dof,chi2,hist_sum,pdf_sum,passed,worst_row_theta_deg,
worst_ratio,worst_row,p_value_no_pole_rows,p_value_no_pole_rows_ires16,reason) and prints "N of M views
pass". worst_row_theta_deg is the row's center in the table's own theta (hemisphere: from the normal;
fiber: from the normal plane); worst_ratio is that row's expected over observed count. Two diagnoses
lie outside Mitsuba's test: the p-value with the two pole rows of the histogram left out, and the same
with expected counts from 16 x 16 quadrature nodes per cell instead of 4 x 4 (no Sidak correction).
"""
import argparse
import glob
import math
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import bsdfmix_import  # noqa: E402
import mitsuba_chi2  # noqa: E402
import mixture_views  # noqa: E402
import study_io  # noqa: E402

FIELDS = ["table", "theta_o_deg", "view", "p_value", "dof", "chi2", "hist_sum", "pdf_sum", "passed",
          "worst_row_theta_deg", "worst_ratio", "worst_row", "p_value_no_pole_rows", "p_value_no_pole_rows_ires16",
          "reason"]


def run(cli, *args):
    study_io.BIN = cli
    study_io.bsdfmix("renderer_chi2", *args)


def grid(text):
    return study_io.grid("renderer_chi2", text)


def fit_rows(domain, n_theta_o, rows):
    """rows theta_o centers spread over the grid, first and last included."""
    lo, hi = (0.0, math.pi / 2) if domain == "hemisphere" else (-math.pi / 2, math.pi / 2)
    idx = sorted({int(round(i)) for i in np.linspace(0, n_theta_o - 1, min(rows, n_theta_o))})
    return [lo + (i + 0.5) * (hi - lo) / n_theta_o for i in idx]


def make_mixtures(a, name, make_table, domain, n_theta_o):
    """(mixture, displaced copy) of one table in --work, made when missing; seconds spent."""
    t0 = time.time()
    base = os.path.join(a.work, name + ("" if a.map == "equal_area" else "_" + a.map))
    table, mixture, displaced = base + "_table.h5", base + "_mixture.h5", base + "_displace.h5"
    if not os.path.exists(table):
        make_table(table)
    if not os.path.exists(mixture):
        with open(base + "_fit.yaml", "w") as f:
            f.write(f"table: {table}\nfit:\n  output: {mixture}\n  report: {base}_fit.csv\n"
                    f"  search_report: {base}_search.csv\n  k_max: {a.k_max}\n  seed: 1\n  map: {a.map}\n"
                    f"  theta_o: {fit_rows(domain, n_theta_o, a.rows)}\n")
        run(a.bsdfmix, "fit", "-q", base + "_fit.yaml")
    if not os.path.exists(displaced):
        run(a.bsdfmix, "pack", "-q", mixture, "--storage", "padded", "--interpolation", "displace", "-o", displaced)
    return [(name, mixture), (name + "_displace", displaced)], time.time() - t0


def row_theta_deg(domain, row):
    return row.theta_deg if domain == "hemisphere" else 90.0 - row.theta_deg


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bsdfmix", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "renderer_chi2"))
    ap.add_argument("--materials", default="", help="RGL names (data/rgl/NAME_rgb.bsdf), comma-separated; default all")
    ap.add_argument("--presets", default="silk,cotton,polyester,wool")
    ap.add_argument("--rgl-grid", default="45,90,180")
    ap.add_argument("--fiber-grid", default="90,90,180")
    ap.add_argument("--rows", type=int, default=10)
    ap.add_argument("--k-max", type=int, default=16)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--map", default="equal_area", choices=["equal_area", "theta_phi"])
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "renderer_chi2.csv"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    bsdfmix = bsdfmix_import.load()
    rg, fg = grid(a.rgl_grid), grid(a.fiber_grid)
    want = set(filter(None, a.materials.split(",")))
    files = []
    for rgl in sorted(glob.glob(os.path.join(ROOT, "data", "rgl", "*_rgb.bsdf"))):
        name = os.path.basename(rgl).replace("_rgb.bsdf", "")
        if want and name not in want:
            continue
        make = (lambda out, rgl=rgl: run(a.bsdfmix, "import", "rgl", "-q", rgl, "--theta-o", rg[0], "--theta-i", rg[1],
                                         "--phi-i", rg[2], "-o", out))
        made, s = make_mixtures(a, name, make, "hemisphere", rg[0])
        print(f"{name}: table and fits in {s:.1f} s", flush=True)
        files += made
    for preset in filter(None, a.presets.split(",")):
        make = (lambda out, p=preset: run(a.bsdfmix, "generate", "fiber", "-q", "--preset", p, "--theta-o", fg[0],
                                          "--theta-i", fg[1], "--phi-i", fg[2], "-o", out))
        made, s = make_mixtures(a, preset, make, "fiber", fg[0])
        print(f"{preset}: table and fits in {s:.1f} s", flush=True)
        files += made
    if not files:
        sys.exit("renderer_chi2: no table selected")
    loaded = [(name, bsdfmix.load_mixture(path)) for name, path in files]
    plan = [(name, m, v) for name, m in loaded for v in mixture_views.views(m)]
    out = []
    for name, m, (theta_o, phi_o, kind) in plan:
        t0 = time.time()
        pdf = mixture_views.density(m, theta_o, phi_o)
        r = mitsuba_chi2.chi2_test(mixture_views.sampler(m, theta_o, phi_o), pdf, a.samples, test_count=len(plan))
        w, poles = r.worst_row(), [0, len(r.rows) - 1]
        fine = mitsuba_chi2.expected_counts(pdf, a.samples, ires=16)
        out.append({"table": name, "theta_o_deg": f"{round(math.degrees(theta_o), 2) + 0.0:.2f}", "view": kind,
                    "p_value": f"{r.p_value:.4g}", "dof": r.dof, "chi2": f"{r.chi2:.1f}",
                    "hist_sum": f"{r.hist_sum:.5f}", "pdf_sum": f"{r.pdf_sum:.5f}", "passed": int(r.passed),
                    "worst_row_theta_deg": f"{row_theta_deg(mixture_views.domain_name(m), w):.2f}",
                    "worst_ratio": f"{w.ratio:.4g}", "worst_row": w.row,
                    "p_value_no_pole_rows": f"{mitsuba_chi2.p_value_without_rows(r, poles):.4g}",
                    "p_value_no_pole_rows_ires16": f"{mitsuba_chi2.p_value_without_rows(r, poles, fine):.4g}",
                    "reason": r.reason})
        deg = round(math.degrees(theta_o), 1) + 0.0
        print(f"{name} theta_o {deg:6.1f} ({kind}, {time.time() - t0:.1f} s): {r.summary()}", flush=True)
    os.makedirs(os.path.dirname(os.path.abspath(a.csv)), exist_ok=True)
    tmp = a.csv + ".tmp"
    with open(tmp, "w") as f:
        f.write(",".join(FIELDS) + "\n")
        for row in out:
            f.write(",".join(str(row[k]).replace(",", ";") for k in FIELDS) + "\n")
    os.replace(tmp, a.csv)
    passed = sum(r["passed"] for r in out)
    print(f"{passed} of {len(out)} views pass (Mitsuba 3's chi-square test, Sidak over {len(out)}); {a.csv}")


if __name__ == "__main__":
    main()
