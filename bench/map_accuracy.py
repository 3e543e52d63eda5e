#!/usr/bin/python3
"""The map against (theta, phi): the stand-in's accuracy when the fit works in the equal-area map.

Fits the same theta_o rows of each table twice, with `fit.map: theta_phi` and `fit.map: equal_area`
(docs/fitting.md, "The map"), K up to --k-max, and scores each fitted slice with `bsdfmix compare`
(relative L1 of the stand-in against the table's cells, energy error). Tables: the shipped RGL files
imported at --rgl-grid, the fiber presets generated at --fiber-grid. Tables and fits already in --work
are reused.

    /usr/bin/python3 bench/map_accuracy.py --bsdfmix build/bsdfmix --work out/map_accuracy \
        [--materials ...] [--presets silk,cotton,polyester,wool] [--rgl-grid 45,90,180] \
        [--fiber-grid 45,90,180] [--k-max 32] [--csv bench/results/map_accuracy.csv]

Writes table,map,theta_o_deg,k,l1_rel,energy,fit_seconds (one row per fitted slice) and prints each
table's median L1 per map.
"""
import argparse
import math
import os
import statistics
import time

import study_io
from study_io import ROOT, rows as csv_rows

RGL_ROWS_DEG = [1, 5, 7, 11, 13, 19, 21, 29, 31, 41, 43, 49, 51, 61, 63, 69, 71, 79, 81]  # hemisphere rows fitted
FIBER_ROWS_DEG = [-81, -61, -41, -21, -1, 21, 41, 61, 81]


def run(*args):
    study_io.bsdfmix("map_accuracy", *args)


def grid(text):
    return study_io.grid("map_accuracy", text)


def fit_and_compare(a, name, table, rows_deg, fit_map, generate=""):
    """The fitted slices' rows of `bsdfmix compare`, each with its K and the fit's seconds."""
    base = os.path.join(a.work, f"{name}_{fit_map}")
    mixture, cmp_csv = base + "_mixture.h5", base + "_compare.csv"
    seconds = 0.0
    if not os.path.exists(mixture):
        rows = [round(math.radians(d), 6) for d in rows_deg]
        with open(base + "_fit.yaml", "w") as f:
            f.write(f"table: {table}\n{generate}fit:\n  output: {mixture}\n  report: {base}_fit.csv\n"
                    f"  search_report: {base}_search.csv\n  k_max: {a.k_max}\n  seed: 1\n  map: {fit_map}\n"
                    f"  theta_o: {rows}\n")
        t0 = time.time()
        run("fit", "-q", base + "_fit.yaml")
        seconds = time.time() - t0
        with open(base + "_seconds.txt", "w") as f:
            f.write(f"{seconds:.1f}\n")
    elif os.path.exists(base + "_seconds.txt"):
        seconds = float(open(base + "_seconds.txt").read())
    run("compare", "-q", mixture, table, "--csv", cmp_csv)
    k = {r["slice"]: r["k"] for r in csv_rows(base + "_fit.csv")}
    out = []
    for r in csv_rows(cmp_csv):
        if r["fitted"] != "1":
            continue
        out.append({"table": name, "map": fit_map, "theta_o_deg": f"{math.degrees(float(r['theta_o'])):.2f}",
                    "k": k.get(r["slice"], ""), "l1_rel": r["l1_rel"], "energy": r["energy"],
                    "fit_seconds": f"{seconds:.1f}"})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bsdfmix", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "map_accuracy"))
    ap.add_argument("--materials", default="", help="RGL names (data/rgl/NAME_rgb.bsdf), comma-separated; default all")
    ap.add_argument("--presets", default="silk,cotton,polyester,wool")
    ap.add_argument("--rgl-grid", default="45,90,180")
    ap.add_argument("--fiber-grid", default="45,90,180")
    ap.add_argument("--k-max", type=int, default=32)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "map_accuracy.csv"))
    a = ap.parse_args()
    study_io.BIN = a.bsdfmix
    os.makedirs(a.work, exist_ok=True)
    materials = study_io.rgl_materials(a.materials)
    rows = []
    for m in materials:
        to, ti, pi = grid(a.rgl_grid)
        table = os.path.join(a.work, m + "_table.h5")
        if not os.path.exists(table):
            run("import", "rgl", "-q", os.path.join(ROOT, "data", "rgl", m + "_rgb.bsdf"),
                "--theta-o", to, "--theta-i", ti, "--phi-i", pi, "-o", table)
        for fit_map in ("theta_phi", "equal_area"):
            rows += fit_and_compare(a, m, table, RGL_ROWS_DEG, fit_map)
    for p in [p for p in a.presets.split(",") if p]:
        to, ti, pi = grid(a.fiber_grid)
        table = os.path.join(a.work, p + "_table.h5")
        generate = f"generate:\n  preset: {p}\n  theta_o: {to}\n  theta_i: {ti}\n  phi_i: {pi}\n"
        for fit_map in ("theta_phi", "equal_area"):
            rows += fit_and_compare(a, p, table, FIBER_ROWS_DEG, fit_map, generate)
    os.makedirs(os.path.dirname(os.path.abspath(a.csv)), exist_ok=True)
    study_io.write_rows(a.csv, rows)
    for name in dict.fromkeys(r["table"] for r in rows):
        med = {m: statistics.median(float(r["l1_rel"]) for r in rows if r["table"] == name and r["map"] == m)
               for m in ("theta_phi", "equal_area")}
        print(f"{name}: median L1 {100 * med['theta_phi']:.2f}% (theta_phi), {100 * med['equal_area']:.2f}% (equal_area)")
    print(a.csv)


if __name__ == "__main__":
    main()
