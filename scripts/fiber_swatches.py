#!/usr/bin/python3
"""Draw each fiber preset's colour as swatches (docs/fiber.md, "Colour").

For every preset, the script tabulates a small fiber table with `bsdfmix generate fiber`
(or reads the tables given with --tables) and draws two patches side by side:

  left   the colour C of a mass of the fibers, the target of Chiang et al. 2016's mapping
         from which the preset's sigma_a comes (the table's `source` "color");
  right  the albedo of one fiber: each channel of `rgb` integrated over the sphere of
         omega_i (L_i = 1), averaged over the omega_o of the table (weights cos theta_o,
         i.e. uniform over the sphere of view directions).

Patches are linear Rec. 709 RGB encoded with the sRGB transfer curve. One fiber absorbs
little: its albedo is nearly white for the natural fibers; their colour is the colour of
many scattering events, which the left patch shows.

Examples:
  scripts/fiber_swatches.py -o docs/images/fiber_swatches.png
  scripts/fiber_swatches.py --tables out/tables/silk.h5 out/tables/cotton.h5 -o swatches.png
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

import h5py  # noqa: E402

PRESETS = ["silk", "cotton", "polyester", "wool", "lossless"]


def fail(msg):
    print("fiber_swatches: error: " + msg, file=sys.stderr)
    sys.exit(1)


def srgb_encode(v):
    v = np.clip(np.asarray(v, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def read_table(path):
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        fail("cannot open %s: %s" % (path, e))
    with f:
        if "table" not in f or "rgb" not in f["table"]:
            fail("%s: no /table/rgb (a fiber table with colour is needed)" % path)
        g = f["table"]
        src = g.attrs.get("source", "{}")
        src = json.loads(src.decode() if isinstance(src, bytes) else str(src))
        theta_o, theta_i, phi_i = g["theta_o"][...], g["theta_i"][...], g["phi_i"][...]
        rgb = np.asarray(g["rgb"][...], dtype=np.float64)  # [t_o, p_o, t_i, p_i, 3]
    d_theta = theta_i[1] - theta_i[0]
    d_phi = phi_i[1] - phi_i[0]
    # Integrand weights of the fiber domain: f cos(theta_i) dtheta dphi (docs/formats.md).
    w = (np.cos(theta_i) * d_theta * d_phi)[None, None, :, None, None]
    albedo = (rgb * w).sum(axis=(2, 3))  # [t_o, p_o, 3]
    wo = np.cos(theta_o)[:, None, None]
    mean = (albedo * wo).sum(axis=(0, 1)) / (wo.sum() * albedo.shape[1])
    return src, mean


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", nargs="+", help="fiber tables with rgb (default: tabulate every preset)")
    ap.add_argument("--bsdfmix", default="build/bsdfmix", help="the bsdfmix binary (default: %(default)s)")
    ap.add_argument("--theta-o", type=int, default=36, help="theta_o slices of the tables made (default: 36)")
    ap.add_argument("-o", "--output", default="fiber_swatches.png", help="the PNG to write")
    args = ap.parse_args()

    rows = []
    with tempfile.TemporaryDirectory(prefix="fiber_swatches_") as tmp:
        paths = args.tables
        if not paths:
            if not os.access(args.bsdfmix, os.X_OK):
                fail("%s is not an executable (build first, or give --bsdfmix or --tables)" % args.bsdfmix)
            paths = []
            for name in PRESETS:
                p = os.path.join(tmp, name + ".h5")
                cmd = [args.bsdfmix, "generate", "fiber", "--preset", name, "--theta-o", str(args.theta_o),
                       "--theta-i", "90", "--phi-i", "180", "-q", "-o", p]
                if subprocess.run(cmd).returncode != 0:
                    fail("'%s' failed" % " ".join(cmd))
                paths.append(p)
        for p in paths:
            src, albedo = read_table(p)
            color = np.asarray(src.get("color", [1, 1, 1]), dtype=np.float64)
            rows.append((src.get("preset", os.path.basename(p)), src.get("sigma_a", []), color, albedo))

    fig, ax = plt.subplots(figsize=(7.2, 0.75 * len(rows) + 0.6), dpi=110)
    ax.set_xlim(0, 7.2)
    ax.set_ylim(0, len(rows) + 0.4)
    ax.axis("off")
    ax.text(1.6, len(rows) + 0.15, "a mass of fibers (C)", ha="center", fontsize=8)
    ax.text(2.8, len(rows) + 0.15, "one fiber (albedo)", ha="center", fontsize=8)
    for k, (name, sigma, color, albedo) in enumerate(rows):
        y = len(rows) - 1 - k
        ax.text(0.05, y + 0.45, name, va="center", fontsize=10)
        ax.add_patch(Rectangle((1.1, y + 0.1), 1.0, 0.75, color=srgb_encode(color), ec="0.5", lw=0.5))
        ax.add_patch(Rectangle((2.3, y + 0.1), 1.0, 0.75, color=srgb_encode(albedo), ec="0.5", lw=0.5))
        s = ", ".join("%.4g" % x for x in sigma)
        ax.text(3.5, y + 0.62, "sigma_a  (%s)" % s, va="center", fontsize=7.5, family="monospace")
        ax.text(3.5, y + 0.42, "C        (%s)" % ", ".join("%.3f" % x for x in color), va="center", fontsize=7.5,
                family="monospace")
        ax.text(3.5, y + 0.22, "albedo   (%s)" % ", ".join("%.3f" % x for x in albedo), va="center",
                fontsize=7.5, family="monospace")
    fig.tight_layout(pad=0.2)
    out_dir = os.path.dirname(args.output)
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
    fig.savefig(args.output)
    print("wrote " + args.output)


if __name__ == "__main__":
    main()
