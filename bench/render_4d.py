#!/usr/bin/python3
"""The thesis's speed claim on the cloth (docs/render.md, "A full-4D table"): f from the
full-4D wool table (90 x 180 x 90 x 180, no symmetry, 4.2 GB, memory-mapped) against its
stand-in (K 8 pinned, one final restart, no L1 refinement, every PHI_STRIDE-th phi_o
column and theta_o row), same scene, estimator (mis_light_gmm) and seed; beside them the
same render with the small azimuthal table in memory and its stand-in. Per row: the best ns per vertex of
RUNS renders (the 4D and the azimuthal renders alternate; each render draws its table
image, then its stand-in image), the error against the render's reference (the table's f
at reference_spp), the table and stand-in images' difference, and memory (the table's
bytes, the bytes mapped and resident, each render process's peak RSS, the mixture's
bytes). The tables and the fit stay in WORK (4.2 GB); the fit is timed once.

    bench/render_4d.py [--work out/render_4d] [--runs 5] [--phi-stride 2] [--theta-stride 2]
                       [--csv bench/results/render_4d.csv]
"""
import argparse
import json
import os
import sys

import h5py

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from machine import cpu_model, logical_cpus  # noqa: E402
from study_io import BIN, measured, rows, write_rows  # noqa: E402

GRID = ["--theta-o", "90", "--theta-i", "90", "--phi-i", "180", "--noise", "0.05"]


def run(args, what):
    """Runs `bsdfmix ARGS` (study_io.measured): wall seconds, CPU seconds, peak RSS bytes."""
    return measured("render_4d", [BIN, *args], cwd=ROOT, what=what)


def config(src, work, dst, extra=""):
    """The shipped config with out/render_4d/ replaced by WORK, plus EXTRA lines."""
    with open(os.path.join(ROOT, src)) as f:
        text = f.read().replace("out/render_4d/", work.rstrip("/") + "/")
    with open(dst, "w") as f:
        f.write(text + extra)
    return dst


def tables(work):
    """The full-4D table and the azimuthal one (the sampler's), made when missing."""
    full, az = os.path.join(work, "wool4d.h5"), os.path.join(work, "wool_az.h5")
    if not os.path.exists(full):
        run(["generate", "fiber", "-q", "--preset", "wool", "--no-symmetry", "--phi-o", "180", *GRID, "-o", full],
            "the full-4D table")
    if not os.path.exists(az):
        run(["generate", "fiber", "-q", "--preset", "wool", *GRID, "-o", az], "the azimuthal table")
    return full


def fit(work, stride, theta_stride):
    """The stand-in of the full-4D table, fitted when missing: wall and CPU seconds, slices."""
    out = os.path.join(work, "wool4d_mixture.h5")
    times = os.path.join(work, "wool4d_fit_seconds.json")
    if not (os.path.exists(out) and os.path.exists(times)):
        with h5py.File(os.path.join(work, "wool4d.h5"), "r") as f:  # the grid's own values: one slice each
            theta, phi = f["table/theta_o"][::theta_stride], f["table/phi_o"][::stride]
        extra = "  theta_o: [%s]\n  phi_o: [%s]\n" % (", ".join("%.17g" % t for t in theta),
                                                       ", ".join("%.17g" % p for p in phi))
        cfg = config("configs/render/wool_4d_fit.yaml", work, os.path.join(work, "fit.yaml"), extra)
        wall, cpu, _ = run(["fit", cfg, "-q"], "the stand-in's fit")
        with open(times, "w") as f:
            json.dump({"wall": wall, "cpu": cpu, "phi_stride": stride, "theta_stride": theta_stride}, f)
    with open(times) as f:
        t = json.load(f)
    t["slices"] = len(rows(os.path.join(work, "wool4d_fit.csv")))
    return t


def render(cfg, out):
    """One render: its table and stand-in rows, the image difference, the 4D memory facts."""
    for name in ("render.csv", "render.json", "table_4d.csv"):
        if os.path.exists(os.path.join(out, name)):
            os.remove(os.path.join(out, name))
    _, _, peak = run(["render", cfg, "-q", "--no-figures"], "render " + cfg)
    got = {r["mode"]: r for r in rows(os.path.join(out, "render.csv"))}
    with open(os.path.join(out, "render.json")) as f:
        facts = json.load(f)
    facts["peak_rss"] = peak
    mem = os.path.join(out, "table_4d.csv")
    return got, facts, (rows(mem)[0] if os.path.exists(mem) else None)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "render_4d"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--phi-stride", type=int, default=2)
    ap.add_argument("--theta-stride", type=int, default=2)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "render_4d.csv"))
    a = ap.parse_args()
    work = os.path.abspath(a.work)
    os.makedirs(work, exist_ok=True)
    full = tables(work)
    ft = fit(work, a.phi_stride, a.theta_stride)
    cfgs = {"full_4d": config("configs/render/wool_4d.yaml", work, os.path.join(work, "render_4d.yaml")),
            "azimuthal": config("configs/render/wool_4d.yaml", work, os.path.join(work, "render_az.yaml"))}
    # the azimuthal render: the same config without the full-4D table, its own output
    with open(cfgs["azimuthal"]) as f:
        text = [ln for ln in f if not ln.lstrip().startswith(("table_4d:", "mixture_4d:"))]
    with open(cfgs["azimuthal"], "w") as f:
        f.write("".join(text).replace(work + "/render\n", work + "/render_az\n"))
    ns = {(k, m): [] for k in cfgs for m in ("table", "stand_in")}
    last = {}
    for i in range(a.runs):
        for kind, cfg in cfgs.items():
            out = os.path.join(work, "render" if kind == "full_4d" else "render_az")
            got, facts, mem = render(cfg, out)
            for m in ("table", "stand_in"):
                ns[(kind, m)].append(float(got[m]["ns_per_vertex"]))
            last[kind] = (got, facts, mem)
            print("run %d %-9s ns/vertex table %s, stand-in %s" % (i + 1, kind, got["table"]["ns_per_vertex"],
                                                                   got["stand_in"]["ns_per_vertex"]), flush=True)
    out, cpu = [], cpu_model()
    for kind in cfgs:
        got, facts, mem = last[kind]
        for m in ("table", "stand_in"):
            table_row = m == "table"
            out.append({
                "table": kind, "f": m, "ns_per_vertex_best": "%.0f" % min(ns[(kind, m)]),
                "ns_per_vertex_runs": ";".join("%.0f" % x for x in ns[(kind, m)]),
                "rel_mse_vs_reference": got[m]["rel_mse"], "stand_in_difference": "%.6g" % facts["stand_in_difference"],
                "stand_in_difference_4x4": "%.6g" % facts["stand_in_difference_4x4"],
                "table_noise_4x4": "%.6g" % facts["table_noise_4x4"],
                "stand_in_mean_difference": "%.6g" % facts["stand_in_mean_difference"],
                "table_bytes": (mem["table_bytes"] if mem else facts["table_bytes"]) if table_row else "",
                "mapped_bytes": mem["mapped_bytes"] if mem and table_row else "",
                "resident_bytes": mem["resident_bytes"] if mem and table_row else "",
                "peak_rss_bytes": facts["peak_rss"],
                "mixture_bytes": "" if table_row else (mem["mixture_bytes"] if mem else facts["mixture_bytes"]),
                "mixture_slices": "" if table_row else (mem["mixture_slices"] if mem else facts["slices_needed"]),
                "fit_seconds": "%.1f" % ft["wall"] if kind == "full_4d" and not table_row else "",
                "fit_cpu_seconds": "%.1f" % ft["cpu"] if kind == "full_4d" and not table_row else "",
                "phi_stride": ft["phi_stride"] if kind == "full_4d" and not table_row else "",
                "theta_stride": ft["theta_stride"] if kind == "full_4d" and not table_row else "",
                "width": facts["width"], "height": facts["height"], "runs": a.runs,
                "table_file_bytes": os.path.getsize(full) if kind == "full_4d" else "",
                "cpu_model": cpu, "logical_cpus": logical_cpus()})
    write_rows(a.csv, out)
    b = {(r["table"], r["f"]): r for r in out}
    t, s = b[("full_4d", "table")], b[("full_4d", "stand_in")]
    print("full 4D: table %s ns/vertex, stand-in %s: %.2fx; mapped %s B, resident %s B, mixture %s B; wrote %s"
          % (t["ns_per_vertex_best"], s["ns_per_vertex_best"], float(t["ns_per_vertex_best"]) /
             float(s["ns_per_vertex_best"]), t["mapped_bytes"], t["resident_bytes"], s["mixture_bytes"], a.csv))


if __name__ == "__main__":
    main()
