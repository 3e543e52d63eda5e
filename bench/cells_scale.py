#!/usr/bin/python3
"""Fit cost and peak memory against table size: wool fiber tables without symmetry of about
10^7, 10^8, 2.6 x 10^8 (the full 90 x 180 x 90 x 180 table) and 10^9 cells, each slice
90 x 180 cells, fitted with K pinned at 8, one restart, a fixed 50 EM iterations
(tolerance 0) and no L1 refinement, so that the work per cell is the same at every size.
Each row: the cells, the slices, the wall seconds (best of RUNS for 10^7 cells; the
larger tables once, as the `runs` column says), ns per cell, the CPU time and the share of the cores it kept
busy, and the peak resident memory of the fit (the child's ru_maxrss) and of the
generator that wrote the table. With --before, each row is fitted by that build too,
the two builds alternating. Tables are written under --work once and kept (16 bytes a
cell: 16 GB for the largest); --sizes picks rows by name. --partial NAME:BATCHES stops
that row's fits after BATCHES batches (`fit --max-batches`): its time per cell is over
the cells fitted (`cells_fitted`), and its peak memory leaves out the final assembly.

    /usr/bin/python3 bench/cells_scale.py [--work out/cells_scale] [--runs 3] [--before /work/baseline/bsdfmix] \\
        [--before-sizes 1e7,1e8] [--sizes 1e7,1e8,full_4d,1e9] [--partial 1e9:40] \\
        [--csv bench/results/cells_scale.csv] [--png docs/images/cells_scale.png]
    /usr/bin/python3 bench/cells_scale.py --chart-only   # redraw the PNG from the CSV
"""
import argparse
import csv
import json
import os
import shutil

from machine import cpu_model, logical_cpus
import study_io
from study_io import BIN, ROOT, write_rows

GRID = ["--theta-i", "90", "--phi-i", "180"]
# name, theta_o slices, phi_o slices, runs at most
SIZES = [("1e7", 30, 20, 3), ("1e8", 60, 102, 1), ("full_4d", 90, 180, 1), ("1e9", 180, 360, 1)]
FIT = """table: {table}
fit:
  output: {out}/{name}_{build}_mixture.h5
  report: {out}/{name}_{build}_fit.csv
  search_report: {out}/{name}_{build}_search.csv
  k_min: 8
  k_max: 8
  final_restarts: 1
  final_iterations: 50
  tolerance: 0
  refine: none
"""


def measured(cmd):
    """Wall seconds, CPU seconds and peak resident MiB of one child process."""
    wall, cpu, peak = study_io.measured("cells_scale", cmd)
    return wall, cpu, peak / 2**20


def table(work, name, n_theta, n_phi):
    """The table of one size, generated once (its generation's seconds and peak memory kept beside it)."""
    path = os.path.join(work, name + ".h5")
    info = path + ".json"
    if not (os.path.exists(path) and os.path.exists(info)):
        args = ["--preset", "wool", "--no-symmetry", "--theta-o", str(n_theta), "--phi-o", str(n_phi), *GRID]
        wall, _, peak = measured(["nice", "-n", "5", BIN, "generate", "fiber", "-q", *args, "-o", path])
        with open(info, "w") as f:
            json.dump({"seconds": wall, "peak_mib": peak}, f)
    with open(info) as f:
        return path, json.load(f)


def fit(build, binary, work, name, path, batches):
    """One fit from scratch (no checkpoint left from an earlier run): wall, CPU, peak MiB."""
    config = os.path.join(work, "%s_%s.yaml" % (name, build))
    with open(config, "w") as f:
        f.write(FIT.format(table=os.path.abspath(path), out=os.path.abspath(work), name=name, build=build))
    shutil.rmtree(os.path.join(work, "%s_%s_mixture.h5.parts" % (name, build)), ignore_errors=True)
    stop = ["--max-batches", str(batches)] if batches else []
    return measured(["nice", "-n", "5", binary, "fit", "-q", *stop, config])


def fitted_slices(slices, batches):
    """The slices a fit stopped after `batches` batches has fitted (the sweep's batch_size)."""
    return min(slices, batches * min(max(slices // 32, 4), 64)) if batches else slices


def chart(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.4))
    colour = {"this": "tab:blue", "before": "tab:orange"}  # one colour a build, in both panels
    for build in sorted({r["build"] for r in rows}, reverse=True):
        rs = [r for r in rows if r["build"] == build]
        x = [int(r["cells"]) for r in rs]
        c = colour.get(build)
        # the other build's points hollow and larger: they stay visible where they fall on this build's
        style = dict(color=c) if build == "this" else dict(color=c, markerfacecolor="none", markersize=9, zorder=3)
        a.plot(x, [float(r["ns_per_cell"]) for r in rs], "o-", label=build + ": wall", **style)
        a.plot(x, [float(r["cpu_ns_per_cell"]) for r in rs], "s--", label=build + ": CPU", **style)
        b.plot(x, [float(r["peak_rss_mib"]) / 1024 for r in rs], "o-", label=build, **style)
    a.set_ylabel("fit time per cell (ns)")
    a.set_title("wall and CPU time per cell", fontsize=9)
    b.set_ylabel("peak resident memory (GiB)")
    for ax in (a, b):
        ax.set_xscale("log")
        ax.set_xlabel("table cells")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    a.set_ylim(top=1.12 * max(float(r[k]) for r in rows for k in ("ns_per_cell", "cpu_ns_per_cell")))  # no marker cut
    b.axhline(3, color="grey", ls=":", lw=1, label="3 GiB")
    b.set_ylim(top=3.3)
    a.legend(fontsize=8)
    b.legend(fontsize=8)
    fig.suptitle("Fits of K 8, 50 EM iterations, by table size", fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "cells_scale"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--before", help="another build's bsdfmix, fitted alternating with this one")
    ap.add_argument("--sizes", default=",".join(s[0] for s in SIZES))
    ap.add_argument("--before-sizes", help="the rows --before fits too (default: every row)")
    ap.add_argument("--partial", default="", help="NAME:BATCHES,...: rows fitted part way")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "cells_scale.csv"))
    ap.add_argument("--png", default=os.path.join(ROOT, "docs", "images", "cells_scale.png"))
    ap.add_argument("--chart-only", action="store_true", help="redraw --png from the rows in --csv, fitting nothing")
    a = ap.parse_args()
    if a.chart_only:
        with open(a.csv) as f:
            chart(list(csv.DictReader(f)), a.png)
        print("wrote", a.png)
        return
    os.makedirs(a.work, exist_ok=True)
    builds = [("this", BIN)] + ([("before", a.before)] if a.before else [])
    partial = {p.split(":")[0]: int(p.split(":")[1]) for p in a.partial.split(",") if p}
    rows = []
    for name, n_theta, n_phi, most in SIZES:
        if name not in a.sizes.split(","):
            continue
        path, gen = table(a.work, name, n_theta, n_phi)
        runs = min(a.runs, most)
        here = [(b, x) for b, x in builds if b == "this" or a.before_sizes is None or name in a.before_sizes.split(",")]
        best = {b: None for b, _ in here}
        for _ in range(runs):
            for build, binary in here:
                m = fit(build, binary, a.work, name, path, partial.get(name))
                best[build] = m if best[build] is None or m[0] < best[build][0] else best[build]
        slices, cells = n_theta * n_phi, n_theta * n_phi * 90 * 180
        fitted = fitted_slices(slices, partial.get(name)) * 90 * 180
        for build, _ in here:
            wall, cpu, peak = best[build]
            rows.append({"table": name, "build": build, "cells": cells, "slices": slices, "cells_per_slice": 90 * 180,
                         "table_bytes": os.path.getsize(path), "cells_fitted": fitted, "runs": runs,
                         "wall_s": "%.2f" % wall, "ns_per_cell": "%.2f" % (1e9 * wall / fitted),
                         "cpu_ns_per_cell": "%.2f" % (1e9 * cpu / fitted), "cpu_s": "%.2f" % cpu,
                         "cpu_utilization": "%.3f" % (cpu / wall / logical_cpus()), "peak_rss_mib": "%.0f" % peak,
                         "generate_s": "%.1f" % gen["seconds"], "generate_peak_rss_mib": "%.0f" % gen["peak_mib"],
                         "cpu_model": cpu_model(), "logical_cpus": logical_cpus()})
            print("%-8s %-6s %.3g of %.3g cells: %.1f s (best of %d), %.2f ns/cell, cpu %.0f%%, peak %.0f MiB"
                  % (name, build, fitted, cells, wall, runs, 1e9 * wall / fitted, 100 * cpu / wall / logical_cpus(),
                     peak), flush=True)
        write_rows(a.csv, rows)  # after each size: a stopped study keeps the rows it measured
    chart(rows, a.png)
    print("wrote", a.csv, a.png)


if __name__ == "__main__":
    main()
