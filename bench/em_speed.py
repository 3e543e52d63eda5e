#!/usr/bin/python3
"""The EM and L1 refinement kernels of two builds in one run, rounds alternating OLD and NEW
(the order flipped every other round), every row the best of its runs:

    /usr/bin/python3 bench/em_speed.py --old OLD/bsdfmix [--new build/bsdfmix] [--k 8,16,50]
                                       [--rounds 5] [--csv bench/results/em_speed.csv]

EM: `bsdfmix bench em` at each K (64 slices of 90 x 180, 20 iterations, no peers, no
reference): the marginal seconds per iteration (bench/em_row.py), and the percentage of the measured FMA peak: each
build's best GFLOP/s (each counts the flops per update of its own kernel) over the best
peak of its rounds. L1: `bsdfmix fit`
of the 90 slices of data/silk_small.h5 (K up to 16, rgb) with `refine: l1` and with
`refine: none`: the CPU seconds of each run (user + system), and the refinement's, the
difference of the two bests. CPU time, not wall time: other jobs on the machine lengthen
a fit's wall time, far less its CPU time. The CSV has one row a measurement: what, K, old,
new, new / old, the rounds and the machine.
"""
import argparse
import os
import sys
import tempfile

import em_row
import machine
import study_io

FIT = """table: {table}
fit:
  output: mixture.h5
  report: fit.csv
  search_report: search.csv
  k_min: 1
  k_max: 16
  seed: 1
  refine: {refine}
"""


def run(cmd, cwd=None):
    """Runs cmd; its CPU seconds (user + system). A failure ends the study naming the command."""
    return study_io.measured("em_speed", cmd, cwd=cwd)[1]


def bench_em(exe, k, path):
    row = em_row.bench_em(exe, k, path)
    return (float(row["seconds_per_iteration"]), float(row["gflops"] or "nan"),
            float(row["fma_peak_gflops"] or "nan"))


def fit_cpu(exe, where, refine):
    os.makedirs(where, exist_ok=True)
    table = os.path.join(study_io.ROOT, "data", "silk_small.h5")
    with open(os.path.join(where, "fit.yaml"), "w") as f:
        f.write(FIT.format(table=table, refine=refine))
    return run([exe, "fit", "fit.yaml", "-q"], cwd=where)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old", required=True, help="the other build's bsdfmix")
    ap.add_argument("--new", default=os.path.join(study_io.ROOT, "build", "bsdfmix"))
    ap.add_argument("--k", default="8,16,50")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--csv", default=os.path.join(study_io.ROOT, "bench", "results", "em_speed.csv"))
    a = ap.parse_args()
    builds = [("old", os.path.abspath(a.old)), ("new", os.path.abspath(a.new))]
    ks = [int(x) for x in a.k.split(",")]
    best = {}  # (what, k, build) -> best value (lowest time, highest percentage)

    def keep(key, value, low=True):
        old = best.get(key)
        best[key] = value if old is None else (min(old, value) if low else max(old, value))

    tmp = tempfile.mkdtemp(prefix="em_speed_")
    for r in range(a.rounds):
        for name, exe in (builds if r % 2 == 0 else builds[::-1]):
            for k in ks:
                spi, gflops, peak = bench_em(exe, k, os.path.join(tmp, f"{name}_k{k}.csv"))
                keep(("em_seconds_per_iteration", k, name), spi)
                keep(("gflops", k, name), gflops, low=False)
                keep(("peak", k, name), peak, low=False)
            for refine in ("l1", "none"):
                keep((f"fit_refine_{refine}_cpu_s", 16, name), fit_cpu(exe, os.path.join(tmp, name, refine), refine))
        print(f"em_speed: round {r + 1} of {a.rounds}", file=sys.stderr)
    for name, _ in builds:
        # each build's best GFLOP/s (its own flop count) over the best FMA peak of its rounds: a
        # peak measured low in one noisy round does not inflate the percentage
        for k in ks:
            best[("em_pct_of_fma_peak", k, name)] = 100 * best.pop(("gflops", k, name)) / best.pop(("peak", k, name))
        best[("l1_refinement_cpu_s", 16, name)] = (best[("fit_refine_l1_cpu_s", 16, name)] -
                                                    best[("fit_refine_none_cpu_s", 16, name)])
    out = []
    for what, k in sorted({(w, k) for w, k, _ in best}):
        old, new = best[(what, k, "old")], best[(what, k, "new")]
        out.append(dict(what=what, k=k, old=f"{old:.6g}", new=f"{new:.6g}", new_over_old=f"{new / old:.4f}",
                        rounds=a.rounds, cpu_model=machine.cpu_model(), logical_cpus=machine.logical_cpus()))
        print(f"{what:28s} K {k:3d} old {old:10.6g} new {new:10.6g} new/old {new / old:.3f}")
    study_io.write_rows(a.csv, out)
    print("em_speed: wrote", a.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
