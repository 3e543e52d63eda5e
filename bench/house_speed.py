#!/usr/bin/python3
"""Two builds of bsdfmix timed against each other: EM throughput and the render's ns per
path vertex, rounds alternating old and new, each row keeping its best run.

    bench/house_speed.py --old OLD/bsdfmix --new build/bsdfmix [--rounds 5] [--csv FILE]

EM: `bsdfmix bench em` at K 8 and 16 (64 slices of 90 x 180, 20 iterations, no peers, no
reference): updates per second at the marginal cost of an iteration (bench/em_row.py). Render: a 96 x 96 silk cloth under the sky at 8 samples
per pixel on one thread, every estimator's equal-sample ns per vertex from render.csv
(the fit and the converged image are made in the first round and reused after). The CSV has one row a
measurement: what, old, new and new / old (above 1: the new build is faster for EM,
slower for ns per vertex), with the machine's CPU.
"""
import argparse
import csv
import pathlib
import platform
import subprocess
import sys
import tempfile

import em_row

ROOT = pathlib.Path(__file__).resolve().parent.parent

RENDER = f"""
table: {ROOT}/out/house_speed/silk_table.h5
generate:
  preset: silk
  theta_o: 45
  theta_i: 45
  phi_i: 90
fit:
  output: mixture.h5
  report: fit.csv
  search_report: search.csv
  k_max: 8
render:
  output: images
  scene: {ROOT}/configs/scenes/sky.yaml
  width: 96
  height: 96
  spp: 8
  seconds: 0.01
  reference_spp: 16
  stand_in: false
  threads: 1
  estimators: [uniform, mis_tab, cdf_tab, mis_light_cdf, mis_light_gmm, mis_product]
"""


def cpu_model():
    for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def em_rate(binary, k, where):
    return float(em_row.bench_em(str(binary), k, str(where / f"em_k{k}.csv"))["pc_per_s"])


def render_ns(binary, where):
    where.mkdir(parents=True, exist_ok=True)
    (where / "render.yaml").write_text(RENDER)
    done = subprocess.run([binary, "render", "render.yaml", "--no-figures"], cwd=where, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"house_speed: {binary} render failed:\n{done.stderr[-2000:]}")
    ns = {}
    with open(where / "images" / "render.csv") as f:
        for row in csv.DictReader(f):
            if row["mode"] == "equal_spp":
                ns[row["estimator"]] = float(row["ns_per_vertex"])
    return ns


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--old", required=True)
    parser.add_argument("--new", required=True)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--csv", default=str(ROOT / "bench" / "results" / "house_speed.csv"))
    args = parser.parse_args()
    builds = {"old": str(pathlib.Path(args.old).resolve()), "new": str(pathlib.Path(args.new).resolve())}
    best = {}  # (what, build) -> best value
    with tempfile.TemporaryDirectory(prefix="house_speed_") as tmp:
        tmp = pathlib.Path(tmp)
        for r in range(args.rounds):
            for name, binary in (builds.items() if r % 2 == 0 else reversed(list(builds.items()))):
                for k in (8, 16):
                    rate = em_rate(binary, k, tmp)
                    key = (f"em_k{k}_updates_per_s", name)
                    best[key] = max(best.get(key, 0.0), rate)
                for est, ns in render_ns(binary, tmp / name).items():
                    key = (f"render_{est}_ns_per_vertex", name)
                    best[key] = min(best.get(key, float("inf")), ns)
            print(f"house_speed: round {r + 1} of {args.rounds}", file=sys.stderr)
    whats = sorted({w for w, _ in best})
    with open(args.csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["what", "old", "new", "new_over_old", "rounds", "cpu_model"])
        for what in whats:
            old, new = best[(what, "old")], best[(what, "new")]
            w.writerow([what, f"{old:.6g}", f"{new:.6g}", f"{new / old:.4f}", args.rounds, cpu_model()])
            print(f"{what:40s} old {old:12.6g} new {new:12.6g} new/old {new / old:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
