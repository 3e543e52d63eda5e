#!/usr/bin/python3
"""Checks that two builds of bsdfmix give the same results.

Runs a small fit of the shipped silk table (colour), an RGL import and fit, the
convergence study (device and CPU estimators, the RGL file's own sampler among them) and a
small render with every estimator, once per binary, then compares what they wrote:
every HDF5 dataset and attribute bit for bit, every CSV cell (columns of times left out),
every PFM image bit for bit. Outputs that depend on the clock (equal-time images, times)
are left out by name.

    bench/same_results.py --old OLD/bsdfmix --new build/bsdfmix
    bench/same_results.py --save DIR --new build/bsdfmix     runs one binary into DIR
    bench/same_results.py --against DIR --new build/bsdfmix  compares with a saved DIR

Exits 1, naming each file and field that differs.
"""
import argparse
import csv
import os
import pathlib
import subprocess
import sys
import tempfile

import h5py
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
THETA_O = "[0.05, 0.5236, 1.0472, 1.3]"

CONFIGS = {
    "fit_silk.yaml": f"""
table: {ROOT}/data/silk_small.h5
fit:
  output: out/silk/mixture.h5
  report: out/silk/fit.csv
  search_report: out/silk/search.csv
  k_min: 1
  k_max: 6
  final_iterations: 120
  theta_o: {THETA_O}
converge:
  scene: {ROOT}/configs/scenes/sky.yaml
  theta_o: [0.5236, 1.0472]
  samples_max: 1024
  runs: 8
  csv: out/silk/convergence.csv
  estimators: [us_tab, us_gmm, is_tab, is_gmm, mis_tab, cdf_tab, light, mis_light_cdf, mis_light_gmm, product, mis_product]
""",
    "fit_satin.yaml": f"""
table: out/satin/table.h5
import:
  rgl: {ROOT}/data/rgl/satin_rosaline_rgb.bsdf
  theta_o: 12
  theta_i: 30
  phi_i: 60
fit:
  output: out/satin/mixture.h5
  report: out/satin/fit.csv
  search_report: out/satin/search.csv
  k_min: 1
  k_max: 6
  final_iterations: 120
converge:
  theta_o: [0.4]
  samples_max: 512
  runs: 8
  cpu: true
  csv: out/satin/convergence.csv
  estimators: [is_gmm, mis_tab, is_rgl, mis_light_rgl]
""",
    "render.yaml": f"""
table: out/render/silk_table.h5
generate:
  preset: silk
  theta_o: 24
  theta_i: 24
  phi_i: 48
fit:
  output: out/render/mixture.h5
  report: out/render/fit.csv
  search_report: out/render/search.csv
  k_min: 1
  k_max: 6
  final_iterations: 80
render:
  output: out/render/images
  scene: {ROOT}/configs/scenes/sky.yaml
  width: 24
  height: 24
  spp: 4
  reference_spp: 8
  stand_in_spp: 4
  threads: 2
  prepass: 12
  estimators: [uniform, mis_tab, cdf_tab, mis_light_cdf, mis_light_gmm, mis_product, guided, guided_product]
""",
}

# (subcommand, config) in order; `run` would also chart, which needs no comparison.
STEPS = [("fit", "fit_silk.yaml"), ("converge", "fit_silk.yaml"),
         ("fit", "fit_satin.yaml"), ("converge", "fit_satin.yaml"),
         ("render", "render.yaml")]

CLOCK_WORDS = ("second", "time", "_ns", "ns_", "rate", "wall", "cpu", "elapsed", "date", "host",
               "per_s", "speed", "throughput")


def run(binary, where):
    where.mkdir(parents=True, exist_ok=True)
    for name, text in CONFIGS.items():
        (where / name).write_text(text)
    env = dict(os.environ, BSDFMIX_DEVICE=os.environ.get("BSDFMIX_DEVICE", "0"))
    for sub, config in STEPS:
        done = subprocess.run([binary, sub, config], cwd=where, env=env, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"same_results: {binary} {sub} {config} failed ({done.returncode}):\n{done.stderr[-3000:]}")


def clock(name):
    return any(w in name.lower() for w in CLOCK_WORDS)


def compare_h5(a, b, rel, out):
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        def walk(ga, gb, path):
            for key in sorted(set(ga.attrs) | set(gb.attrs)):
                if clock(key):
                    continue
                if key not in ga.attrs or key not in gb.attrs:
                    out.append(f"{rel}:{path}@{key}: only in one")
                    continue
                va, vb = ga.attrs[key], gb.attrs[key]
                if isinstance(va, (bytes, str)) or isinstance(vb, (bytes, str)):
                    if va != vb and not (key.endswith("json") or key in ("settings", "fit_settings", "source")):
                        out.append(f"{rel}:{path}@{key}: {va!r} against {vb!r}")
                elif not np.array_equal(np.asarray(va), np.asarray(vb)):
                    out.append(f"{rel}:{path}@{key} differs")
            for key in sorted(set(ga.keys()) | set(gb.keys())):
                if key not in ga or key not in gb:
                    out.append(f"{rel}:{path}/{key}: only in one")
                    continue
                if isinstance(ga[key], h5py.Group):
                    walk(ga[key], gb[key], f"{path}/{key}")
                elif not clock(key):
                    da, db = ga[key][()], gb[key][()]
                    if np.asarray(da).shape != np.asarray(db).shape or not np.array_equal(da, db):
                        out.append(f"{rel}:{path}/{key} differs")
        walk(fa, fb, "")


def compare_csv(a, b, rel, out):
    with open(a) as fa, open(b) as fb:
        ra, rb = list(csv.reader(fa)), list(csv.reader(fb))
    if not ra or not rb or ra[0] != rb[0] or len(ra) != len(rb):
        out.append(f"{rel}: header or row count differs")
        return
    keep = [i for i, name in enumerate(ra[0]) if not clock(name)]
    mode = ra[0].index("mode") if "mode" in ra[0] else None
    for n, (x, y) in enumerate(zip(ra[1:], rb[1:]), start=2):
        if mode is not None and "time" in x[mode]:
            continue
        bad = [ra[0][i] for i in keep if i < len(x) and i < len(y) and x[i] != y[i]]
        if bad:
            out.append(f"{rel}:{n}: {', '.join(bad[:6])}")
            return


def compare(old, new):
    out, seen = [], 0
    for a in sorted(old.rglob("*")):
        rel = a.relative_to(old)
        b = new / rel
        if a.is_dir() or clock(str(rel)) or "equal_time" in str(rel) or "light_mixtures" in str(rel):
            continue
        if a.suffix not in (".h5", ".csv", ".pfm") or "checkpoint" in str(rel) or "part" in a.name:
            continue
        seen += 1
        if not b.exists():
            out.append(f"{rel}: missing from the new run")
        elif a.suffix == ".h5":
            compare_h5(a, b, rel, out)
        elif a.suffix == ".csv":
            compare_csv(a, b, rel, out)
        elif a.read_bytes() != b.read_bytes():
            out.append(f"{rel}: image differs")
    return seen, out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--new", required=True, help="the build to check")
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--old", help="the build to compare with")
    group.add_argument("--against", help="a folder an earlier --save wrote")
    group.add_argument("--save", help="run --new into this folder and stop")
    args = parser.parse_args()
    new_bin = str(pathlib.Path(args.new).resolve())
    if args.save:
        run(new_bin, pathlib.Path(args.save).resolve())
        print(f"same_results: saved {args.save}")
        return 0
    with tempfile.TemporaryDirectory(prefix="same_results_") as tmp:
        tmp = pathlib.Path(tmp)
        if args.old:
            old = tmp / "old"
            run(str(pathlib.Path(args.old).resolve()), old)
        else:
            old = pathlib.Path(args.against).resolve()
        run(new_bin, tmp / "new")
        seen, diffs = compare(old, tmp / "new")
    for d in diffs:
        print(f"same_results: {d}")
    print(f"same_results: {seen} files compared, {len(diffs)} differ")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
