#!/usr/bin/python3
"""The Gaussian-count search of two builds side by side, in one run (CHANGELOG.md,
"A walk that does not give up"): for each table, each build fits it with the default
settings and the script reads the fit report: slices, mean K, median, p90 and max
relative L1 error, and the wall time (the best of --runs runs; the fits are the same every
run). Rows alternate between the builds table by table and run by run, so that the
machine's load falls on both alike; an untimed one-slice fit by each build first compiles
their kernels. With --walk-only a third row per table, `after_walk`, fits with the after
build's colour work off (`refine_rgb: 0`, `rgb_copies: ~`: the luminance alone in the L1
refinement and no colour copies, as the before build fits), so that its K, error and time
are the walk's alone.

    /usr/bin/python3 bench/search_before_after.py --before B/bsdfmix --after build/bsdfmix \\
        --tables satin=out/bench_rgb/satin.h5,... [--runs 3] [--walk-only] \\
        [--csv bench/results/search_before_after.csv]

The tables are made by bench/rgb_stand_in.py (the RGL materials at 90 theta_o, the fiber
presets at 45) and by bench/hard_table.py (a sharp peak on a broad base with fringes).
"""
import argparse
import csv
import os
import statistics
import subprocess
import time
from machine import cpu_model  # noqa: E402  (bench/machine.py)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


WALK_ONLY = "  refine_rgb: 0\n  rgb_copies: ~\n"


def fit(binary, table, stem, extra=""):
    """Fits `table` with the default settings (and the fit: lines `extra`) into stem_*."""
    cfg = stem + ".yaml"
    with open(cfg, "w") as f:
        f.write(f"table: {table}\nfit:\n  output: {stem}_mixture.h5\n  report: {stem}_fit.csv\n"
                f"  search_report: {stem}_search.csv\n{extra}")
    if os.path.exists(stem + "_mixture.h5"):
        os.remove(stem + "_mixture.h5")
    start = time.monotonic()
    subprocess.run([binary, "fit", "-q", cfg], check=True, stdout=subprocess.DEVNULL)
    seconds = time.monotonic() - start
    rows = list(csv.DictReader(open(stem + "_fit.csv")))
    l1 = sorted(float(r["l1_rel"]) for r in rows)
    return dict(slices=len(rows), mean_k=statistics.mean(int(r["k"]) for r in rows),
                l1_median=statistics.median(l1), l1_p90=l1[min(len(l1) - 1, int(0.9 * len(l1)))],
                l1_max=l1[-1], seconds=seconds)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True)
    ap.add_argument("--after", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--tables", required=True, help="name=path,...")
    ap.add_argument("--runs", type=int, default=1, help="runs per row, alternating; a row's time is the best")
    ap.add_argument("--walk-only", action="store_true", help="a third row per table: the after build, colour work off")
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "search_before_after"))
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "search_before_after.csv"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    out = []
    cpu, cores = cpu_model(), os.cpu_count()
    # Warm-up, untimed: each build fits one slice of the first table at K pinned to every
    # kernel size a fit can use (4 to 64), so that the OpenCL compiler's first build of its
    # kernels (cached after) is in neither's time.
    first = a.tables.split(",")[0].split("=", 1)[1]
    for label, binary in (("before", a.before), ("after", a.after)):
        for k in (4, 8, 16, 32, 64):
            fit(binary, first, os.path.join(a.work, f"warmup_{label}_{k}"), f"  k_min: {k}\n  k_max: {k}\n  theta_o: [0.5]\n")
    builds = [("before", a.before, ""), ("after", a.after, "")]
    if a.walk_only:
        builds.append(("after_walk", a.after, WALK_ONLY))
    for item in a.tables.split(","):
        name, path = item.split("=", 1)
        rows = {}
        for run in range(a.runs):
            for label, binary, extra in builds:
                r = fit(binary, path, os.path.join(a.work, f"{name}_{label}"), extra)
                kept = rows.setdefault(label, r)  # run 1's fit, with the best time so far
                if (r["mean_k"], r["l1_median"], r["l1_max"]) != (kept["mean_k"], kept["l1_median"], kept["l1_max"]):
                    raise SystemExit(f"{name} {label}: run {run + 1} fitted differently from run 1")
                kept["seconds"] = min(kept["seconds"], r["seconds"])
        for label, _, _ in builds:
            r = dict(table=name, build=label, **rows[label], runs=a.runs, cpu=cpu, cores=cores)
            out.append(r)
            print(f"{name:10s} {label:10s} K {r['mean_k']:.2f}  L1 median {100 * r['l1_median']:.2f}% p90 "
                  f"{100 * r['l1_p90']:.2f}% max {100 * r['l1_max']:.2f}%  {r['seconds']:.1f} s", flush=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(out[0].keys()), lineterminator="\n")
        w.writeheader()
        for r in out:
            w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    print("wrote", a.csv)


if __name__ == "__main__":
    main()
