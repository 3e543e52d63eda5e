#!/usr/bin/python3
"""The fiber table generator's time, size and peak memory (docs/fiber.md):
the default table (180 x 90 x 180, one phi_o by symmetry), best of RUNS runs, and the
full 90 x 180 x 90 x 180 table without symmetry (noise on), once. Peak memory is the
child process's largest resident set (getrusage). The tables are written to a work
folder and removed.

    bench/fiber_generate.py [--work out/bench_generate] [--runs 3] [--csv bench/results/fiber_generate.csv]
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from rgb_stand_in import cpu_model  # noqa: E402

BIN = os.path.join(ROOT, "build", "bsdfmix")
CASES = [("default", "silk", ["--theta-o", "180", "--theta-i", "90", "--phi-i", "180"]),
         ("full_4d", "wool", ["--no-symmetry", "--theta-o", "90", "--phi-o", "180", "--theta-i", "90",
                              "--phi-i", "180", "--noise", "0.05"])]


def run_once(args, path):
    """Wall seconds and peak resident MB of one generation, in a child that only generates."""
    code = ("import resource, subprocess, sys, time\n"
            "t = time.perf_counter(); subprocess.run(sys.argv[1:], check=True)\n"
            "print(time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0)")
    out = subprocess.run([sys.executable, "-c", code, BIN, "generate", "fiber", "-q", *args, "-o", path],
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit("fiber_generate: %s" % (out.stderr.strip().splitlines() or ["generation failed"])[-1])
    seconds, peak = out.stdout.split()
    return float(seconds), float(peak)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "bench_generate"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "fiber_generate.csv"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    rows, cpu = [], cpu_model()
    for name, preset, args in CASES:
        path = os.path.join(a.work, name + ".h5")
        runs = a.runs if name == "default" else 1
        best, peak = None, 0.0
        for _ in range(runs):
            if os.path.exists(path):
                os.remove(path)
            s, m = run_once(["--preset", preset] + args, path)
            best = s if best is None else min(best, s)
            peak = max(peak, m)
        size = os.path.getsize(path)
        os.remove(path)
        print("%-8s %s: %.1f MB in %.2f s (best of %d), peak %.0f MB" % (name, preset, size / 1e6, best, runs, peak))
        rows.append({"table": name, "preset": preset, "args": " ".join(args), "bytes": size, "seconds_best": "%.3f" % best,
                     "runs": runs, "peak_rss_mb": "%.0f" % peak, "cpu_model": cpu, "logical_cpus": os.cpu_count()})
    shutil.rmtree(a.work, ignore_errors=True)
    tmp = a.csv + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, a.csv)
    print("wrote", a.csv)


if __name__ == "__main__":
    main()
