#!/usr/bin/python3
"""Two builds of bsdfmix fitting the shipped RGL files at the default settings, rounds
alternating old and new: wall time, CPU time and CPU utilization (CPU time over wall time
times logical CPUs), each build's best round, with the fit's relative L1 error (median and
p90 over the slices), its mean K, and whether the two mixture files hold the same numbers.

    /usr/bin/python3 bench/fit_speed.py --old OLD/bsdfmix [--new build/bsdfmix] [--rounds 3]
        [--materials satin_rosaline,...] [--csv bench/results/fit_speed.csv]

Each table is imported once at the default grid (90 x 90 x 180) under out/fit_speed/. A row
per material: old and new seconds, speedup (old / new), both utilizations and errors,
`same` (every dataset of /mixture equal, bit for bit), the datasets that differ and their
largest difference relative to the dataset's largest value; and where the new build's best
round spent its batches' time (its summary's "time by phase": the shares of the search, the
final EM, the fits past a stalled walk, the L1 refinement and the rest, 0 to 1).
"""
import argparse
import glob
import os
import re
import shutil
import subprocess

import h5py
import numpy as np
from machine import cpu_model  # noqa: E402  (bench/machine.py)
from study_io import ROOT, measured, rows, write_rows  # noqa: E402  (bench/study_io.py)


PHASES = ("search", "final_em", "beyond", "refine", "rest")
PHASE_LINE = re.compile(r"time by phase +search (\d+)%, final EM (\d+)%, past a stalled walk (\d+)%, "
                        r"L1 refinement (\d+)%, the rest (\d+)%")


def timed_fit(binary, config, summary):
    """Runs `binary fit -q config`, its summary to the file `summary`: (wall seconds, CPU
    seconds of the child)."""
    return measured("fit_speed", [binary, "fit", "-q", config], stdout=summary)[:2]


def phase_columns(summary):
    """new_<phase> shares from a fit summary's "time by phase" line ("" for a build without it)."""
    with open(summary) as f:
        m = PHASE_LINE.search(f.read())
    return {"new_" + p: ("%.2f" % (int(m.group(i + 1)) / 100) if m else "") for i, p in enumerate(PHASES)}


def errors(report):
    l1 = np.array([float(r["l1_rel"]) for r in rows(report)])
    k = np.array([float(r["k"]) for r in rows(report)])
    return float(np.median(l1)), float(np.percentile(l1, 90)), float(k.mean())


def differences(a, b):
    """The /mixture datasets of the two files that differ, each with its largest difference
    relative to the dataset's largest magnitude: [(name, relative difference)]."""
    out = []
    with h5py.File(a) as fa, h5py.File(b) as fb:
        names = []
        fa["mixture"].visit(names.append)
        for n in names:
            x = fa["mixture"][n]
            if not isinstance(x, h5py.Dataset):
                continue
            u, v = x[()], fb["mixture"][n][()]
            if np.array_equal(u, v, equal_nan=True):
                continue
            if u.shape != v.shape or u.dtype.kind not in "fiu":
                out.append((n, float("inf")))
                continue
            u, v = np.asarray(u, float), np.asarray(v, float)
            scale = np.nanmax(np.abs(u)) if u.size else 0.0
            out.append((n, float(np.nanmax(np.abs(u - v)) / scale) if scale > 0 else float("inf")))
    return out


def difference_columns(a, b):
    """`same` (every dataset of /mixture equal, bit for bit), `differing` (the datasets that
    are not, ';'-separated) and `largest_difference` (the largest of their relative
    differences, 0 when same)."""
    d = differences(a, b)
    return {"same": int(not d), "differing": ";".join(n for n, _ in d),
            "largest_difference": "%.3g" % max((r for _, r in d), default=0.0)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", required=True)
    ap.add_argument("--new", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--materials", default="")
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "fit_speed"))
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "fit_speed.csv"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    want = set(filter(None, a.materials.split(",")))
    cores = os.cpu_count() or 1
    out = []
    for rgl in sorted(glob.glob(os.path.join(ROOT, "data", "rgl", "*_rgb.bsdf"))):
        name = os.path.basename(rgl).replace("_rgb.bsdf", "")
        if want and name not in want:
            continue
        table = os.path.join(a.work, name + ".h5")
        if not os.path.exists(table):
            subprocess.run([a.new, "import", "rgl", "-q", rgl, "-o", table], check=True, capture_output=True)
        best = {}
        for rnd in range(a.rounds):
            for build, binary in (("old", a.old), ("new", a.new)):
                stem = os.path.join(a.work, f"{name}_{build}")
                cfg = stem + ".yaml"
                with open(cfg, "w") as f:
                    f.write(f"table: {table}\nfit:\n  output: {stem}_mixture.h5\n  report: {stem}_fit.csv\n"
                            f"  search_report: {stem}_search.csv\n")
                for p in glob.glob(stem + "_mixture.h5*"):  # a fresh fit, not a resumed one
                    shutil.rmtree(p) if os.path.isdir(p) else os.remove(p)
                wall, cpu = timed_fit(binary, cfg, stem + "_summary.txt")
                print(f"fit_speed: {name} round {rnd + 1} {build}: {wall:.1f} s wall, {cpu:.1f} s CPU", flush=True)
                if build not in best or wall < best[build][0]:
                    best[build] = (wall, cpu, phase_columns(stem + "_summary.txt"))
        (wo, co, _), (wn, cn, phases) = best["old"], best["new"]
        eo, en = errors(os.path.join(a.work, f"{name}_old_fit.csv")), errors(os.path.join(a.work, f"{name}_new_fit.csv"))
        out.append({"material": name, "grid": "90x90x180", "rounds": a.rounds,
                    "old_seconds": f"{wo:.2f}", "new_seconds": f"{wn:.2f}", "speedup": f"{wo / wn:.3f}",
                    "old_cpu_seconds": f"{co:.2f}", "new_cpu_seconds": f"{cn:.2f}",
                    "old_utilization": f"{co / wo / cores:.3f}", "new_utilization": f"{cn / wn / cores:.3f}",
                    "old_l1_median": f"{eo[0]:.5f}", "new_l1_median": f"{en[0]:.5f}",
                    "old_l1_p90": f"{eo[1]:.5f}", "new_l1_p90": f"{en[1]:.5f}",
                    "old_mean_k": f"{eo[2]:.2f}", "new_mean_k": f"{en[2]:.2f}",
                    **difference_columns(os.path.join(a.work, f"{name}_old_mixture.h5"),
                                         os.path.join(a.work, f"{name}_new_mixture.h5")),
                    **phases, "logical_cpus": cores, "cpu": cpu_model()})
        print(", ".join(f"{k} {v}" for k, v in out[-1].items() if k != "cpu"), flush=True)
    write_rows(a.csv, out)


if __name__ == "__main__":
    main()
