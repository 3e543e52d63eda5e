#!/usr/bin/python3
"""Plot one slice of a table beside its mixture, and samples drawn from the mixture.

    /usr/bin/python3 examples/python/plot_slice.py MIXTURE.h5 TABLE.h5 [--theta-o RAD] [-n N] [--out PNG]

Uses the Python module bsdfmix (examples/README.md; built in build/python by scripts/setup, or
set BSDFMIX_MODULE_DIR to its folder). Left: the table's f over (theta_i, phi_i); middle: the
mixture's stand-in for f there (blended between fitted slices when the file does not hold
this one); right: the stand-in again with N importance samples drawn from the mixture.
Without --theta-o it shows the first table slice between two fitted ones that the file does
not hold (blended), else the middle one. Writes --out (a PNG) or opens a window.
"""
import argparse
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "scripts"))
import bsdfmix_import  # noqa: E402

bsdfmix = bsdfmix_import.load()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mixture")
    ap.add_argument("table")
    ap.add_argument("--theta-o", type=float, help="outgoing theta (radians); the nearest table slice is shown")
    ap.add_argument("-n", type=int, default=400, help="samples to draw (default 400)")
    ap.add_argument("--out", help="PNG to write (default: show a window)")
    a = ap.parse_args()
    import matplotlib
    if a.out:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mix = bsdfmix.load_mixture(a.mixture)
    table = bsdfmix.Table(a.table)
    if a.theta_o is not None:
        t = int(np.argmin(np.abs(table.theta_o - a.theta_o)))
    else:  # the first slice the file does not hold with fitted slices on both sides
        fitted = [i for i, s in enumerate(mix.slice_of[::len(mix.grid_phi_o)]) if s >= 0]
        between = [i for i in range(fitted[0] + 1, fitted[-1]) if i not in fitted]
        t = between[0] if between else len(table.theta_o) // 2
    theta_o, phi_o = table.theta_o[t], table.phi_o[0]

    f = table.slice(t, 0)
    th, ph = np.meshgrid(table.theta_i, table.phi_i, indexing="ij")
    fhat = mix.eval_f(theta_o, phi_o, th, ph)
    theta, phi, _, valid = mix.sample_counter(theta_o, phi_o, a.n, seed=1)

    half_t, half_p = (table.theta_i[1] - table.theta_i[0]) / 2, (table.phi_i[1] - table.phi_i[0]) / 2
    extent = [table.phi_i[0] - half_p, table.phi_i[-1] + half_p, table.theta_i[0] - half_t, table.theta_i[-1] + half_t]
    vmax = max(f.max(), fhat.max())
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), sharey=True, constrained_layout=True)
    fitted = mix.slice_of[t * len(mix.grid_phi_o)] >= 0
    titles = ["table f", "mixture stand-in (%s)" % ("fitted slice" if fitted else "blended"),
              "stand-in and %d samples (%d valid)" % (a.n, valid.sum())]
    for ax, img, title in zip(axes, [f, fhat, fhat], titles):
        im = ax.imshow(img, origin="lower", extent=extent, aspect="auto", cmap="magma", vmin=0, vmax=vmax)
        ax.set_title(title)
        ax.set_xlabel("phi_i (rad)")
    axes[0].set_ylabel("theta_i (rad)")
    axes[2].plot(phi[valid], theta[valid], ".", ms=2, color="cyan")
    axes[2].set_xlim(extent[:2])
    axes[2].set_ylim(extent[2:])
    fig.colorbar(im, ax=axes, label="f (1/sr)")
    fig.suptitle("%s, theta_o = %.3f rad" % (pathlib.Path(a.table).name, theta_o))
    if a.out:
        fig.savefig(a.out, dpi=90)
        print("plot_slice: wrote", a.out)
    else:
        plt.show()


if __name__ == "__main__":
    main()
