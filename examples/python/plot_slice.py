#!/usr/bin/python3
"""Plot one slice of a table beside its mixture's stand-in, their difference, and samples.

    /usr/bin/python3 examples/python/plot_slice.py MIXTURE.h5 TABLE.h5 [--theta-o-deg DEG | --theta-o RAD]
        [--phi-o-deg DEG] [-n N] [--out PNG]

Uses the Python module bsdfmix (examples/README.md; built in build/python by scripts/setup, or
set BSDFMIX_MODULE_DIR to its folder). Panels, over the table's own (theta_i, phi_i) range in
degrees: the table's f; the mixture's stand-in for f (interpolated by the mixture at exactly the
theta_o asked for); the difference, stand-in minus table, with the slice's relative L1 error; the
stand-in with N importance samples drawn from the mixture. f is on a log colour scale (four
decades below the larger maximum; zero and negative cells blank), the difference on a
symmetric log scale. The table shows its row nearest theta_o (and its phi_o column nearest
--phi-o-deg). Without a theta_o it shows the first table row between two fitted slices that
the file does not hold, else the middle row. Writes --out (a PNG) or opens a window.
"""
import argparse
import math
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "scripts"))
import bsdfmix_import  # noqa: E402

bsdfmix = bsdfmix_import.load()


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mixture")
    ap.add_argument("table")
    at = ap.add_mutually_exclusive_group()
    at.add_argument("--theta-o-deg", type=float, help="outgoing theta in degrees (any value in the domain)")
    at.add_argument("--theta-o", type=float, help="outgoing theta in radians")
    ap.add_argument("--phi-o-deg", type=float, help="outgoing phi in degrees (default: the table's first phi_o)")
    ap.add_argument("-n", type=int, default=400, help="samples to draw (default 400)")
    ap.add_argument("--out", help="PNG to write (default: show a window)")
    return ap.parse_args()


def outgoing(a, mix, table):
    """(theta_o, phi_o) for the mixture, and the table's row and column nearest it."""
    theta_o = math.radians(a.theta_o_deg) if a.theta_o_deg is not None else a.theta_o
    if theta_o is None:  # the first row the file does not hold with fitted slices on both sides
        fitted = [i for i, s in enumerate(mix.slice_of[::len(mix.grid_phi_o)]) if s >= 0]
        between = [i for i in range(fitted[0] + 1, fitted[-1]) if i not in fitted]
        theta_o = table.theta_o[between[0] if between else len(table.theta_o) // 2]
    lo = 0.0 if table.domain == bsdfmix.Domain.hemisphere else -math.pi / 2
    if not lo <= theta_o <= math.pi / 2:
        sys.exit("plot_slice: theta_o %.2f deg lies outside the table's domain [%g, 90] deg"
                 % (math.degrees(theta_o), math.degrees(lo)))
    phi_o = math.radians(a.phi_o_deg) if a.phi_o_deg is not None else float(table.phi_o[0])
    t = int(np.argmin(np.abs(table.theta_o - theta_o)))
    p = 0 if table.azimuthal else int(np.argmin(np.abs(table.phi_o - phi_o)))
    return theta_o, phi_o, t, p


def main():
    a = parse_args()
    import matplotlib
    if a.out:
        matplotlib.use("Agg")
    import matplotlib.colors as colors
    import matplotlib.pyplot as plt

    mix = bsdfmix.load_mixture(a.mixture)
    table = bsdfmix.Table(a.table)
    theta_o, phi_o, t, p = outgoing(a, mix, table)
    # The table's slice at its own phi_o (with azimuthal symmetry phi only turns the slice).
    table_phi_o = phi_o if table.azimuthal else float(table.phi_o[p])
    f = table.slice(t, p)
    th, ph = np.meshgrid(table.theta_i, table.phi_i, indexing="ij")
    fhat = mix.eval_f(theta_o, table_phi_o, th, ph + (table_phi_o if table.azimuthal else 0.0))
    theta, phi, _, valid = mix.sample_counter(theta_o, table_phi_o, a.n, seed=1)
    phi = (phi - (table_phi_o if table.azimuthal else 0.0) + math.pi) % (2 * math.pi) - math.pi
    w = bsdfmix.integrand_weights(table.domain, table.theta_i, table.phi_i)
    l1 = np.abs(w * (fhat - f)).sum() / max(np.abs(w * f).sum(), 1e-300)

    deg = np.degrees
    half_t, half_p = (table.theta_i[1] - table.theta_i[0]) / 2, (table.phi_i[1] - table.phi_i[0]) / 2
    extent = deg([table.phi_i[0] - half_p, table.phi_i[-1] + half_p, table.theta_i[0] - half_t, table.theta_i[-1] + half_t])
    vmax = max(f.max(), fhat.max(), 1e-30)
    log = colors.LogNorm(vmin=vmax * 1e-4, vmax=vmax)
    dmax = max(np.abs(fhat - f).max(), 1e-30)
    sym = colors.SymLogNorm(linthresh=vmax * 1e-3, vmin=-dmax, vmax=dmax, base=10)
    fitted = mix.slice_of[t * len(mix.grid_phi_o) + (0 if mix.azimuthal else p)] >= 0
    exact = abs(table.theta_o[t] - theta_o) < 1e-9
    panels = [(np.ma.masked_less_equal(f, 0), log, "magma", "table f (row theta_o %.2f deg%s)" %
               (deg(table.theta_o[t]), "" if exact else ", nearest")),
              (np.ma.masked_less_equal(fhat, 0), log, "magma",
               "stand-in (%s)" % ("fitted slice" if fitted and exact else "interpolated")),
              (fhat - f, sym, "RdBu_r", "stand-in - table (L1 error %.1f%%%s)" % (100 * l1, "" if exact else
                                                                                   ", other theta_o")),
              (np.ma.masked_less_equal(fhat, 0), log, "magma", "stand-in, %d samples (%d valid)" % (a.n, valid.sum()))]
    fig, axes = plt.subplots(1, 4, figsize=(17, 4), sharey=True, constrained_layout=True)
    for ax, (img, norm, cmap, title) in zip(axes, panels):
        im = ax.imshow(img, origin="lower", extent=extent, aspect="auto", cmap=cmap, norm=norm)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("phi_i (deg)")
        if ax is axes[0]:
            fig.colorbar(im, ax=axes[:2], label="f (1/sr), log scale", shrink=0.9)
        elif ax is axes[2]:
            d = 10.0 ** np.floor(np.log10(dmax))  # decades down to the linear band, which the ticks leave out
            ticks = [v for v in (d, d / 10, d / 100) if v > 2 * sym.linthresh]
            fig.colorbar(im, ax=ax, label="difference (1/sr)", shrink=0.9,
                         ticks=sorted([-v for v in ticks] + [0.0] + ticks))
    axes[0].set_ylabel("theta_i (deg)")
    axes[3].plot(deg(phi[valid]), deg(theta[valid]), ".", ms=2, color="cyan")
    axes[3].set_xlim(extent[:2])
    axes[3].set_ylim(extent[2:])
    fig.suptitle("%s: mixture at theta_o = %.2f deg, phi_o = %.1f deg" % (pathlib.Path(a.table).name, deg(theta_o),
                                                                          deg(table_phi_o)))
    if a.out:
        fig.savefig(a.out, dpi=90)
        print("plot_slice: wrote %s (theta_o %.2f deg, table row %d, L1 error %.2f%%)" % (a.out, deg(theta_o), t, 100 * l1))
    else:
        plt.show()


if __name__ == "__main__":
    main()
