#!/usr/bin/python3
"""A fast and a very slow OpenCL device in one run: the same fitting sweep on PoCL alone and
on PoCL beside oclgrind (an OpenCL simulator about a thousand times slower), listed together
through a folder of .icd files (OCL_ICD_VENDORS). The runs alternate, each row keeps its
best wall time; the fits are compared slice by slice (K and relative L1), and the log of
device/batch_pool.cpp (BSDFMIX_POOL_LOG) counts the batches each device ran and kept.

    /usr/bin/python3 bench/mixed_devices.py [--slices 180] [--grid 90x180] [--runs 3] [--quick]
                                            [--csv bench/results/mixed_devices.csv]
"""
import argparse
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from machine import cpu_model  # noqa: E402  (bench/machine.py)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bsdfmix")
OCLGRIND = "/usr/lib/oclgrind/liboclgrind-rt-icd.so"


def fit(env, device, cfg_text, out):
    os.makedirs(out, exist_ok=True)
    cfg = os.path.join(out, "fit.yaml")
    with open(cfg, "w") as f:
        f.write(cfg_text.format(out=out))
    t0 = time.monotonic()
    r = subprocess.run([BIN, "fit", cfg, "--device", device, "-q"], env=env, capture_output=True, text=True)
    seconds = time.monotonic() - t0
    if r.returncode != 0:
        sys.exit("failed (%s):\n%s%s" % (device, r.stdout, r.stderr[-3000:]))
    rows = {int(x["slice"]): (int(x["k"]), float(x["l1_rel"])) for x in csv.DictReader(open(os.path.join(out, "fit.csv")))}
    runs = re.findall(r"^pool (\S+) batch \S+ dev \d+ \[(.*?)\] .*?took ([0-9.]+) s(.*)$", r.stderr, re.M)
    return seconds, rows, runs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--slices", type=int, default=180)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--grid", default="90x180", help="theta_i x phi_i cells of a slice")
    ap.add_argument("--quick", action="store_true", help="8 slices, 1 run (a check, not a measurement)")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "mixed_devices.csv"))
    a = ap.parse_args()
    if a.quick:
        a.slices, a.runs, a.grid = 8, 1, "45x90"
    if not os.path.exists(OCLGRIND):
        sys.exit("oclgrind is not installed (scripts/setup installs it)")
    tmp = tempfile.mkdtemp(prefix="mixed_devices_")
    icd = os.path.join(tmp, "icd")
    os.makedirs(icd)
    for f in os.listdir("/etc/OpenCL/vendors"):
        if "pocl" in f:
            shutil.copy(os.path.join("/etc/OpenCL/vendors", f), icd)
    with open(os.path.join(icd, "oclgrind.icd"), "w") as f:
        f.write(OCLGRIND + "\n")
    env = dict(os.environ, OCL_ICD_VENDORS=icd, BSDFMIX_POOL_LOG="1")
    env.pop("BSDFMIX_DEVICE", None)
    table = os.path.join(tmp, "silk.h5")
    subprocess.run([BIN, "generate", "fiber", "--preset", "silk", "--theta-o", str(a.slices), "--theta-i", a.grid.split("x")[0],
                    "--phi-i", a.grid.split("x")[1], "-o", table, "--device", "pthread", "-q"], env=env, check=True)
    cfg = "table: " + table + "\nfit:\n  output: {out}/mixture.h5\n  report: {out}/fit.csv\n  search_report: {out}/search.csv\n  k_max: 16\n"
    setups = [("pocl", "pthread"), ("pocl+oclgrind", "pthread,oclgrind")]
    best, fits, logs = {}, {}, {}
    for r in range(a.runs):
        for name, device in (setups if r % 2 == 0 else setups[::-1]):
            s, rows, runs = fit(env, device, cfg, os.path.join(tmp, "%s_%d" % (name, r)))
            print("run %d %-14s %.2f s" % (r, name, s), flush=True)
            if s < best.get(name, 1e300):
                best[name], fits[name], logs[name] = s, rows, runs
    base = fits["pocl"]
    k_diff = sum(1 for s in base if fits["pocl+oclgrind"][s][0] != base[s][0])
    l1_diff = max(abs(fits["pocl+oclgrind"][s][1] - base[s][1]) for s in base)
    out = []
    for name, device in setups:
        # oclgrind's runs: its calibration fits (routine "em" of a one-device engine, before
        # the sweep's batches) and any batch of the sweep it started
        slow = [x for x in logs[name] if "Oclgrind" in x[1]] if name != "pocl" else []
        out.append(dict(setup=name, device=device, slices=a.slices, grid=a.grid, runs=a.runs, best_seconds=round(best[name], 3),
                        over_pocl=round(best[name] / best["pocl"], 3),
                        oclgrind_runs=len(slow), oclgrind_runs_kept=sum("lost" not in x[3] for x in slow),
                        oclgrind_seconds=round(sum(float(x[2]) for x in slow), 3),
                        mean_k=round(sum(v[0] for v in fits[name].values()) / len(fits[name]), 3),
                        slices_k_differ=k_diff if name != "pocl" else 0,
                        max_l1_difference=l1_diff if name != "pocl" else 0.0,
                        cpu_model=cpu_model(), logical_cpus=os.cpu_count()))
    with open(a.csv + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(out[0]))
        w.writeheader()
        w.writerows(out)
    os.replace(a.csv + ".tmp", a.csv)
    for row in out:
        print(row)
    shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
