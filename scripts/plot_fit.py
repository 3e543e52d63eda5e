#!/usr/bin/python3
"""Charts of a bsdfmix fitting sweep, PNG and SVG (matplotlib).

  fit_speed_accuracy   relative L1 error and fit time against K, for a few slice
                       types, on one chart (needs --timing, from the K-timing CSV: the
                       sweep's own fits with K pinned, as its final fits make them)
  fit_chosen_k         the chosen K (and the fit error) over theta_o
  fit_slices           original, mixture and error images of a few slices
                       (the thesis's figures 4.1 and 4.2)

Example:
  scripts/plot_fit.py --table data/silk.h5 --mixture out/silk_mixture.h5 \\
      --report out/silk_fit.csv --search out/silk_search.csv --timing out/charts/k_timing.csv -o out/charts
"""

import argparse
import csv
import math
import os
import sys

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import colors  # noqa: E402

import h5py  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bsdfmix_import  # noqa: E402

bsdfmix = bsdfmix_import.load()  # the mixtures are evaluated by the header, through the module


def fail(msg):
    print("plot_fit: error: " + msg, file=sys.stderr)
    sys.exit(1)


def read_csv(path):
    try:
        with open(path, newline="") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e))


def save(fig, out, name):
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out, name + "." + ext), dpi=130, bbox_inches="tight")
    plt.close(fig)
    print(os.path.join(out, name + ".png"))


def chart_speed_accuracy(timing, out):
    rows = read_csv(timing)
    if not rows:
        return
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ax2 = ax.twinx()
    slices = sorted({r["slice"] for r in rows}, key=int)
    palette = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, s in enumerate(slices):
        rs = sorted((r for r in rows if r["slice"] == s), key=lambda r: int(r["k"]))
        k = [int(r["k"]) for r in rs]
        label = "%s (theta_o %.0f deg)" % (rs[0].get("type", "slice " + s), math.degrees(float(rs[0]["theta_o"])))
        c = palette[i % len(palette)]
        ax.plot(k, [100 * float(r["l1_rel"]) for r in rs], "-o", color=c, ms=3, label=label)
        ax2.plot(k, [1000 * float(r["seconds"]) for r in rs], "--s", color=c, ms=3, alpha=0.7)
    ax.set_xlabel("Gaussians K")
    ax.set_ylabel("relative L1 error (%), solid")
    ax2.set_ylabel("fit time per slice (ms), dashed")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper center", fontsize=8)
    ax.set_title("Fit error and fit time against K\n(the sweep's fits with K pinned: split-and-merge, final restarts, L1 refinement)",
                 fontsize=10)
    save(fig, out, "fit_speed_accuracy")


def chart_chosen_k(report, out):
    rows = read_csv(report)
    if not rows:
        return
    rows.sort(key=lambda r: (float(r["theta_o"]), float(r["phi_o"])))
    t = [math.degrees(float(r["theta_o"])) for r in rows]
    fig, ax = plt.subplots(figsize=(7.5, 4))
    ax.plot(t, [int(r["k"]) for r in rows], "o-", ms=3, label="chosen K")
    ax.set_xlabel("theta_o (degrees)")
    ax.set_ylabel("Gaussians K")
    ax2 = ax.twinx()
    ax2.plot(t, [100 * float(r["l1_rel"]) for r in rows], "s--", ms=2, color="C3", alpha=0.7, label="relative L1 (%)")
    ax2.set_ylabel("relative L1 error (%)", color="C3")
    ax.grid(True, alpha=0.3)
    ax.set_title("Chosen K and fit error over theta_o")
    save(fig, out, "fit_chosen_k")


def chart_slices(table_path, mixture_path, out, count):
    with h5py.File(table_path, "r") as tf, h5py.File(mixture_path, "r") as mf:
        t, m = tf["table"], mf["mixture"]
        theta_i, phi_i = t["theta_i"][...], t["phi_i"][...]
        th_o, ph_o = t["theta_o"][...], t["phi_o"][...]
        mt, mp, ks = m["theta_o"][...], m["phi_o"][...], m["k"][...]
        picks = np.unique(np.linspace(0, len(mt) - 1, count).round().astype(int))
        fig, axes = plt.subplots(len(picks), 3, figsize=(11, 2.8 * len(picks)), squeeze=False, layout="constrained")
        T, P = np.meshgrid(theta_i, phi_i, indexing="ij")
        mixture = bsdfmix.load_mixture(mixture_path)
        extent = [math.degrees(phi_i[0]), math.degrees(phi_i[-1]), math.degrees(theta_i[-1]), math.degrees(theta_i[0])]
        for row, s in enumerate(picks):
            it = int(np.argmin(np.abs(th_o - mt[s])))
            ip = int(np.argmin(np.abs(ph_o - mp[s])))
            f = t["values"][it, ip]
            k = ks[s]
            g = mixture.eval_f(mt[s], mp[s], T, P)  # the fitted slice's own stand-in for f
            vmax = max(f.max(), 1e-30)
            norm = colors.LogNorm(vmin=vmax * 1e-4, vmax=vmax)
            for col, (img, title) in enumerate(
                [(f, "table f"), (g, "mixture (K=%d)" % k), (np.abs(g - f), "|error|")]
            ):
                ax = axes[row][col]
                im = ax.imshow(np.maximum(img, vmax * 1e-4), extent=extent, aspect="auto", norm=norm, cmap="inferno")
                ax.set_title("%s, theta_o %.1f deg" % (title, math.degrees(mt[s])), fontsize=9)
                ax.set_xlabel("phi_i (deg)", fontsize=8)
                ax.set_ylabel("theta_i (deg)", fontsize=8)
                ax.tick_params(labelsize=7)
            fig.colorbar(im, ax=axes[row].tolist(), shrink=0.8, label="sr^-1")
        save(fig, out, "fit_slices")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--table", required=True)
    ap.add_argument("--mixture", required=True)
    ap.add_argument("--report", required=True)
    ap.add_argument("--search", help="search CSV (unused by the charts; checked to exist)")
    ap.add_argument("--timing", help="K-timing CSV: slice,type,theta_o,k,seconds,iterations,l1_rel")
    ap.add_argument("--slices", type=int, default=4, help="slices in the image chart")
    ap.add_argument("-o", "--out", required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    for p in (a.table, a.mixture, a.report):
        if not os.path.exists(p):
            fail("%s not found" % p)
    if a.timing:
        chart_speed_accuracy(a.timing, a.out)
    chart_chosen_k(a.report, a.out)
    chart_slices(a.table, a.mixture, a.out, a.slices)


if __name__ == "__main__":
    main()
