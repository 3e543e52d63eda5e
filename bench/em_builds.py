#!/usr/bin/python3
"""EM throughput of this build beside another (BEFORE), on one device, in one run:
`bsdfmix bench em` at each K, the two builds alternating round by round, each row the best
(lowest) marginal seconds per iteration of its runs (bench/em_row.py).

    /usr/bin/python3 bench/em_builds.py --before OTHER/bsdfmix [--k 8,16,50] [--runs 5]
                                        [--device 0] [--csv bench/results/em_builds.csv]
"""
import argparse
import csv
import os
import tempfile

import em_row

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def one(exe, k, device, path):
    return em_row.bench_em(exe, k, path, extra=("--device", device))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="the other build's bsdfmix")
    ap.add_argument("--after", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--k", default="8,16,50")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--device", default="0")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "em_builds.csv"))
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="em_builds_")
    rows = []
    for k in [int(x) for x in a.k.split(",")]:
        best = {}
        info = {}
        for r in range(a.runs):
            order = [("before", a.before), ("after", a.after)]
            if r % 2:
                order.reverse()
            for name, exe in order:
                row = one(exe, k, a.device, os.path.join(tmp, "%s_%d_%d.csv" % (name, k, r)))
                s = float(row["seconds_per_iteration"])
                best[name] = min(best.get(name, s), s)
                info[name] = row
        rows.append(dict(k=k, slices=info["after"]["slices"], cells=info["after"]["cells"], runs=a.runs,
                         before_s_per_iter=best["before"], after_s_per_iter=best["after"],
                         after_over_before=best["after"] / best["before"],
                         device=info["after"]["opencl_device"], cpu_model=info["after"]["cpu_model"],
                         logical_cpus=info["after"]["logical_cpus"], before=os.path.abspath(a.before)))
        print("K %d: before %.6f s/iteration, after %.6f (%.3fx)" % (k, best["before"], best["after"],
                                                                      best["after"] / best["before"]))
    os.makedirs(os.path.dirname(os.path.abspath(a.csv)), exist_ok=True)
    tmp_csv = a.csv + ".tmp"
    with open(tmp_csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp_csv, a.csv)
    print("wrote", a.csv)


if __name__ == "__main__":
    main()
