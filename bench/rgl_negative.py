#!/usr/bin/python3
"""Negative RGB channels of the shipped RGL materials: each file imported twice, keeping the
signed channels (`--negative keep`, the default) and clipping each to 0 as the RGL
authors' code, Mitsuba 3 and pbrt-v4 render it (`--negative clip`), and the luminance
compared cell by cell and slice by slice (the albedo, the integral of Y cos(theta_i)).

    /usr/bin/python3 bench/rgl_negative.py [--grid 30x90x180] [--csv bench/results/rgl_negative.csv]
"""
import argparse
import csv
import glob
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np
from machine import cpu_model  # noqa: E402  (bench/machine.py)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bsdfmix")


def load(path):
    with h5py.File(path, "r") as f:
        t = f["table"]
        return t["values"][:, 0], t["rgb"][:, 0], t["theta_i"][()]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--grid", default="30x90x180", help="theta_o x theta_i x phi_i")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "rgl_negative.csv"))
    a = ap.parse_args()
    n_to, n_ti, n_pi = a.grid.split("x")
    tmp = tempfile.mkdtemp(prefix="rgl_negative_")
    rows = []
    for path in sorted(glob.glob(os.path.join(ROOT, "data", "rgl", "*.bsdf"))):
        name = os.path.basename(path).replace("_rgb.bsdf", "")
        tables = {}
        for mode in ("keep", "clip"):
            out = os.path.join(tmp, "%s_%s.h5" % (name, mode))
            r = subprocess.run([BIN, "import", "rgl", path, "--theta-o", n_to, "--theta-i", n_ti, "--phi-i", n_pi,
                                "--negative", mode, "-o", out, "-q"], capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit("failed: %s" % r.stderr)
            tables[mode] = load(out)
        yk, ck, ti = tables["keep"]
        yc, cc, _ = tables["clip"]
        neg = (ck < 0).any(axis=-1)
        rel = (yc - yk) / np.maximum(yc, 1e-30)
        w = np.cos(ti)[None, :, None] * np.sin(ti)[None, :, None]  # Y cos(theta_i) dOmega, up to dtheta dphi
        albedo_k, albedo_c = (yk * w).sum(axis=(1, 2)), (yc * w).sum(axis=(1, 2))
        slice_rel = (albedo_c - albedo_k) / albedo_c
        worst_channel = float(np.min(ck) / max(np.max(ck), 1e-30))
        rows.append(dict(material=name, grid=a.grid, cells=int(neg.size), negative_cells=int(neg.sum()),
                         negative_share=round(float(neg.mean()), 4),
                         median_rel_y_difference_negative_cells=round(float(np.median(rel[neg])) if neg.any() else 0.0, 5),
                         max_rel_y_difference=round(float(rel.max()), 5),
                         median_albedo_difference=round(float(np.median(slice_rel)), 5),
                         max_albedo_difference=round(float(slice_rel.max()), 5),
                         most_negative_over_largest=round(worst_channel, 4),
                         cpu=cpu_model(), cores=os.cpu_count(),
                         command="/usr/bin/python3 bench/rgl_negative.py --grid " + a.grid))
        print(rows[-1])
    with open(a.csv + ".tmp", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    os.replace(a.csv + ".tmp", a.csv)


if __name__ == "__main__":
    main()
