#!/usr/bin/python3
"""Draw omega_o slices of a bsdfmix table file (HDF5, group /table) as images.

Each image shows f(theta_i, phi_i) for one fixed omega_o = (theta_o, phi_o):
theta_i on the vertical axis, phi_i on the horizontal one, in degrees. Works for
both domains (fiber: theta in [-90, 90]; hemisphere: theta in [0, 90]).

Examples:
  scripts/plot_slices.py T.h5 --theta-o 0 30 60 -o out/         # nearest slices, degrees
  scripts/plot_slices.py T.h5 --index 0 45 90 --log -o out/      # slice indices
  scripts/plot_slices.py T.h5 --grid 3x2 --log -o out/           # one overview figure
"""

import argparse
import json
import math
import os
import sys

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import colors  # noqa: E402

import h5py  # noqa: E402


def fail(msg):
    print("plot_slices: error: " + msg, file=sys.stderr)
    sys.exit(1)


class Table:
    def __init__(self, path):
        try:
            self.file = h5py.File(path, "r")
        except OSError as e:
            fail("cannot open %s: %s" % (path, e))
        if "table" not in self.file:
            fail("%s has no /table group (not a table file)" % path)
        g = self.file["table"]
        for name in ("values", "theta_o", "phi_o", "theta_i", "phi_i"):
            if name not in g:
                fail("%s: /table/%s missing" % (path, name))
        self.path = path
        self.values = g["values"]
        self.theta_o = g["theta_o"][...]
        self.phi_o = g["phi_o"][...]
        self.theta_i = g["theta_i"][...]
        self.phi_i = g["phi_i"][...]
        attr = lambda k, d: g.attrs[k].decode() if isinstance(g.attrs.get(k, d), bytes) else str(g.attrs.get(k, d))
        self.domain = attr("domain", "?")
        self.symmetry = attr("symmetry", "?")
        try:
            self.source = json.loads(attr("source", "{}"))
        except ValueError:
            self.source = {}
        shape = self.values.shape
        want = (len(self.theta_o), len(self.phi_o), len(self.theta_i), len(self.phi_i))
        if tuple(shape[:4]) != want:
            fail("%s: values shape %s does not match the axes %s" % (path, shape, want))

    def label(self):
        s = self.source
        name = s.get("preset") or s.get("file") or os.path.basename(self.path)
        return "%s (%s)" % (name, s.get("model", self.domain))

    def slice(self, t, p):
        return np.asarray(self.values[t, p, :, :], dtype=np.float64)


def nearest(axis_rad, deg):
    return int(np.argmin(np.abs(axis_rad - math.radians(deg))))


def edges(centers, lo, hi):
    step = centers[1] - centers[0] if len(centers) > 1 else hi - lo
    return np.concatenate([centers - step / 2, [centers[-1] + step / 2]])


def choose_slices(tab, args):
    n_to, n_po = len(tab.theta_o), len(tab.phi_o)
    po_list = [0]
    if args.phi_o is not None:
        po_list = [nearest(tab.phi_o, d) for d in args.phi_o]
    elif args.phi_o_index is not None:
        po_list = args.phi_o_index
    for p in po_list:
        if not 0 <= p < n_po:
            fail("phi_o index %d outside [0, %d)" % (p, n_po))
    if args.theta_o is not None:
        to_list = [nearest(tab.theta_o, d) for d in args.theta_o]
    elif args.index is not None:
        to_list = args.index
    else:
        k = args.count
        to_list = sorted(set(int(round(x)) for x in np.linspace(0, n_to - 1, k)))
    for t in to_list:
        if not 0 <= t < n_to:
            fail("theta_o index %d outside [0, %d)" % (t, n_to))
    return [(t, p) for t in to_list for p in po_list]


def draw(ax, tab, t, p, args, fig):
    f = tab.slice(t, p)
    th = np.degrees(edges(tab.theta_i, None, None))
    ph = np.degrees(edges(tab.phi_i, None, None))
    positive = f[f > 0]
    if args.log:
        if positive.size == 0:
            norm = colors.LogNorm(vmin=1e-6, vmax=1)
        else:
            vmax = positive.max()
            vmin = max(positive.min(), vmax * 10.0 ** (-args.decades))
            norm = colors.LogNorm(vmin=vmin, vmax=vmax)
        f = np.where(f > 0, f, np.nan)
    else:
        norm = colors.Normalize(vmin=0, vmax=max(f.max(), 1e-30))
    cmap = plt.get_cmap(args.cmap).copy()
    cmap.set_bad(cmap(0.0))  # cells with f = 0 on a log scale: the lowest color
    cmap.set_under(cmap(0.0))
    mesh = ax.pcolormesh(ph, th, f, norm=norm, cmap=cmap, shading="flat", rasterized=True)
    ax.set_xlabel(r"$\phi_i$ (deg)")
    ax.set_ylabel(r"$\theta_i$ (deg)")
    ax.set_xlim(ph[0], ph[-1])
    ax.set_ylim(th[0], th[-1])
    title = r"$\theta_o$ = %.1f°" % math.degrees(tab.theta_o[t])
    if len(tab.phi_o) > 1:
        title += r", $\phi_o$ = %.1f°" % math.degrees(tab.phi_o[p])
    ax.set_title(title)
    # omega_o marked: the slice direction itself (phi_o is 0 with azimuthal symmetry)
    ax.plot([math.degrees(tab.phi_o[p])], [math.degrees(tab.theta_o[t])], marker="+", color="w", ms=8)
    cb = fig.colorbar(mesh, ax=ax, fraction=0.046, pad=0.04)
    cb.set_label(r"f (sr$^{-1}$)")


def save(fig, out_dir, stem, formats):
    paths = []
    for fmt in formats:
        path = os.path.join(out_dir, "%s.%s" % (stem, fmt))
        fig.savefig(path, dpi=120, bbox_inches="tight")
        paths.append(path)
    plt.close(fig)
    return paths


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("table", help="table file (HDF5)")
    sel = ap.add_mutually_exclusive_group()
    sel.add_argument("--theta-o", type=float, nargs="+", help="slices nearest these theta_o (degrees)")
    sel.add_argument("--index", type=int, nargs="+", help="theta_o slice indices")
    ap.add_argument("--count", type=int, default=4, help="without --theta-o/--index: this many evenly spaced slices")
    sel2 = ap.add_mutually_exclusive_group()
    sel2.add_argument("--phi-o", type=float, nargs="+", help="phi_o nearest these (degrees; tables without symmetry)")
    sel2.add_argument("--phi-o-index", type=int, nargs="+", help="phi_o indices")
    ap.add_argument("--log", action="store_true", help="logarithmic color scale")
    ap.add_argument("--decades", type=float, default=4, help="decades shown with --log")
    ap.add_argument("--cmap", default="inferno")
    ap.add_argument("--grid", help="one figure with all chosen slices, COLSxROWS (e.g. 2x2) instead of one per slice")
    ap.add_argument("--format", nargs="+", default=["png", "svg"], choices=["png", "svg", "pdf"])
    ap.add_argument("-o", "--out", default=".", help="output directory")
    ap.add_argument("--prefix", help="file name prefix (default: the table's base name)")
    args = ap.parse_args()
    if args.count < 1:
        fail("--count must be at least 1")

    tab = Table(args.table)
    slices = choose_slices(tab, args)
    os.makedirs(args.out, exist_ok=True)
    prefix = args.prefix or os.path.splitext(os.path.basename(args.table))[0]
    written = []
    if args.grid:
        try:
            cols, rows = (int(x) for x in args.grid.lower().split("x"))
        except ValueError:
            fail("--grid wants COLSxROWS, got '%s'" % args.grid)
        if cols * rows < len(slices):
            fail("--grid %s holds %d slices, %d chosen" % (args.grid, cols * rows, len(slices)))
        aspect = (tab.phi_i[-1] - tab.phi_i[0]) / max(tab.theta_i[-1] - tab.theta_i[0], 1e-9)
        fig, axes = plt.subplots(rows, cols, figsize=(cols * (2.2 * aspect + 1.5), rows * 3.0), squeeze=False)
        for k, ax in enumerate(axes.flat):
            if k < len(slices):
                draw(ax, tab, slices[k][0], slices[k][1], args, fig)
            else:
                ax.axis("off")
        fig.suptitle("%s, %s domain%s" % (tab.label(), tab.domain, ", log scale" if args.log else ""))
        fig.tight_layout()
        written += save(fig, args.out, prefix + "_slices", args.format)
    else:
        for t, p in slices:
            fig, ax = plt.subplots(figsize=(7.5, 4.2))
            draw(ax, tab, t, p, args, fig)
            fig.suptitle(tab.label(), fontsize=10)
            stem = "%s_to%03d" % (prefix, t) + ("_po%03d" % p if len(tab.phi_o) > 1 else "")
            written += save(fig, args.out, stem, args.format)
    for w in written:
        print(w)


if __name__ == "__main__":
    main()
