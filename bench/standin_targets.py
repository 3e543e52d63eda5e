#!/usr/bin/python3
"""Does `bsdfmix standin` reach its target, and in how few bytes? On the four shipped RGL files and
the four fiber presets.

For each material: the table (an RGL file imported with `bsdfmix import rgl`, a preset tabulated with
`bsdfmix generate fiber`, both at --rows theta_o x 90 x 180), then `bsdfmix standin TABLE --target T`
with its default K caps and strides. One CSV row per material: the chosen candidate (or the closest,
`met` 0), the candidates measured, the fit seconds of its K caps (`fit_seconds`, as first fitted) and
this run's wall time (`seconds`: a rerun reuses the fits), and beside it the fewest bytes of the
hand-made stand-ins of bench/results/stand_in_bytes.csv that meet the same target (ragged_f32, on
30 theta_o rows; empty where that study has no such stand-in). Writes
bench/results/standin_targets.csv with the machine (bench/machine.py).

    /usr/bin/python3 bench/standin_targets.py [--only satin_rosaline,cotton] [--rows 45] [--target 5]
                                              [--metric median|p90] [--max-bytes N] [--csv F]

Tables and the command's work directories (its fits, reused by a rerun) live in out/standin_targets/.
"""
import argparse
import csv
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from machine import cpu_model, logical_cpus  # noqa: E402  (bench/machine.py)

BIN = os.path.join(ROOT, "build", "bsdfmix")
WORK = os.path.join(ROOT, "out", "standin_targets")
RGL = ["satin_rosaline", "paper_white", "cg_sunflower", "cc_iris_purple_gem"]
PRESETS = ["silk", "cotton", "polyester", "wool"]


def run(cmd, ok=(0,)):
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if r.returncode not in ok:
        sys.exit("failed (%d): %s\n%s%s" % (r.returncode, " ".join(cmd), r.stdout, r.stderr))
    return r


def make_table(name, rows):
    table = os.path.join(WORK, "%s_%dx90x180.h5" % (name, rows))
    if os.path.exists(table):
        return table
    grid = ["--theta-o", str(rows), "--theta-i", "90", "--phi-i", "180", "-o", table, "--quiet"]
    if name in RGL:
        run([BIN, "import", "rgl", os.path.join(ROOT, "data", "rgl", name + "_rgb.bsdf")] + grid)
    else:
        run([BIN, "generate", "fiber", "--preset", name] + grid)
    return table


def hand_made_bytes(name, target, metric):
    """The fewest ragged_f32 bytes of the hand-made stand-ins meeting the target; None without one."""
    path = os.path.join(ROOT, "bench", "results", "stand_in_bytes.csv")
    if not os.path.exists(path):
        return None
    column = "median_rgb_error" if metric == "median" else "p90_rgb_error"
    ok = [int(r["bytes"]) for r in csv.DictReader(open(path))
          if r["material"] == name and r["storage"] == "ragged_f32" and float(r[column]) <= target / 100]
    return min(ok) if ok else None


def stand_in(name, table, a):
    out = os.path.join(WORK, "%s_%d_standin.h5" % (name, a.rows))
    cand = os.path.join(WORK, "%s_%d_candidates.csv" % (name, a.rows))
    cmd = [BIN, "standin", table, "--target", str(a.target), "--metric", a.metric, "-o", out, "--csv", cand,
           "--quiet"]
    if a.max_bytes:
        cmd += ["--max-bytes", str(a.max_bytes)]
    t0 = time.time()
    r = run(cmd, ok=(0, 1))
    seconds = time.time() - t0
    if not os.path.exists(cand):
        sys.exit("no candidates from %s:\n%s" % (" ".join(cmd), r.stderr))
    rows = list(csv.DictReader(open(cand)))
    chosen = [x for x in rows if x["chosen"] == "1"]
    met = r.returncode == 0 and len(chosen) == 1
    if not met:  # the closest, as the command names it
        key = "median" if a.metric == "median" else "p90"
        within = [x for x in rows if not a.max_bytes or int(x["bytes"]) <= a.max_bytes] or rows
        chosen = [min(within, key=lambda x: float(x[key]))]
    c = chosen[0]
    print("%s: %s stride %s, K cap %s, %s bytes, median %.2f%%, p90 %.2f%% (%d candidates, %.0f s)"
          % (name, "chose" if met else "missed; closest", c["stride"], c["k_max"], c["bytes"],
             100 * float(c["median"]), 100 * float(c["p90"]), len(rows), seconds), flush=True)
    return dict(met=int(met), stride=c["stride"], rows_fitted=c["rows"], k_max=c["k_max"], bytes=c["bytes"],
                file_bytes=c["file_bytes"], median=c["median"], p90=c["p90"], candidates=len(rows),
                fit_seconds=round(sum(float(x["fit_seconds"]) for x in rows if x["stride"] == "1"), 1),
                seconds=round(seconds, 1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="", help="comma-separated materials (default: all eight)")
    ap.add_argument("--rows", type=int, default=45, help="theta_o rows of every table")
    ap.add_argument("--target", type=float, default=5.0, help="percent")
    ap.add_argument("--metric", default="median", choices=["median", "p90"])
    ap.add_argument("--max-bytes", type=int, default=0)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "standin_targets.csv"))
    a = ap.parse_args()
    names = a.only.split(",") if a.only else RGL + PRESETS
    for n in names:
        if n not in RGL + PRESETS:
            sys.exit("unknown material %s (expected one of %s)" % (n, ", ".join(RGL + PRESETS)))
    os.makedirs(WORK, exist_ok=True)
    out = []
    for name in names:
        table = make_table(name, a.rows)
        r = dict(material=name, kind="rgl" if name in RGL else "fiber preset", grid="%dx90x180" % a.rows,
                 target=a.target, metric=a.metric, max_bytes=a.max_bytes)
        r.update(stand_in(name, table, a))
        hand = hand_made_bytes(name, a.target, a.metric)
        r["hand_made_bytes_30_rows"] = "" if hand is None else hand
        r.update(cpu=cpu_model(), cores=logical_cpus())
        out.append(r)
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(out[0].keys()), lineterminator="\n")
        w.writeheader()
        w.writerows(out)
    print("wrote %s" % a.csv)


if __name__ == "__main__":
    main()
