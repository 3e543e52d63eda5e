#!/usr/bin/python3
"""How many Gaussians a set of slices needs: the project's fits of the slices of a table
whose theta_o is at least --min-theta-o, with the default search and with K pinned at each
of --k (the sweep's own pinned fits: k-means++, split-and-merge, the L1 refinement, the
colour amplitudes), one row per slice and setting: the K and the relative L1 error of the
fit report, and where the error lies: the part of it (over the slice's mass) in the cells
within 10 degrees of phi of the slice's largest cell (`l1_peak`, with that band's share of
the mass, `mass_peak`) and in the cells past theta_i 85 degrees (`l1_horizon`), the
stand-in's luminance computed from the file as bench/rgb_stand_in.py does.
docs/studies/satin_grazing.md quotes it for satin's grazing slices, where the default
search keeps its p90.

    /usr/bin/python3 bench/pinned_k.py --table out/bench_rgb/satin.h5 --name satin \\
        --min-theta-o 1.2 --k 8,16,32 --csv bench/results/pinned_k.csv [--bsdfmix build/bsdfmix]
"""
import argparse
import csv
import os
import tempfile

import h5py
import numpy as np

from parameterization import fit_rows
from rgb_stand_in import component_mass

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def error_bands(table, mixture, rows):
    """Per slice of `rows`: (l1_peak, mass_peak, l1_horizon), each over the slice's mass."""
    with h5py.File(table, "r") as ft, h5py.File(mixture, "r") as fm:
        t, m = ft["table"], fm["mixture"]
        theta, phi = t["theta_i"][:], t["phi_i"][:]
        dth, dph = theta[1] - theta[0], phi[1] - phi[0]
        tt, pp = np.meshgrid(theta, phi, indexing="ij")
        jac = np.cos(tt) * np.sin(tt) * dth * dph  # hemisphere: f cos J, J = sin theta_i
        index = {float(x): i for i, x in enumerate(m["theta_o"][:])}
        out = {}
        for r in rows:
            s = index[float(t["theta_o"][r])]
            k = int(m["k"][s])
            w = t["values"][r, 0].astype(np.float64) * jac
            weights = m["weights"][s, :k].astype(np.float64)
            y = sum(float(m["scale"][s]) * weights[j] / weights.sum() *
                    component_mass(tt, pp, *(float(x) for x in m["means"][s, j]),
                                   *(float(x) for x in m["covariances"][s, j]), dth, dph, dth * dph)
                    for j in range(k))
            err, total = np.abs(w - y), w.sum()
            peak = pp.ravel()[np.argmax(w)]
            band = np.abs((pp - peak + np.pi) % (2 * np.pi) - np.pi) <= np.radians(10) + 1e-9
            out[r] = (err[band].sum() / total, w[band].sum() / total, err[tt > np.radians(85)].sum() / total)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--table", required=True)
    ap.add_argument("--name", required=True)
    ap.add_argument("--min-theta-o", type=float, required=True, help="radians")
    ap.add_argument("--k", default="8,16,32")
    ap.add_argument("--csv", required=True)
    ap.add_argument("--bsdfmix", default=os.path.join(ROOT, "build", "bsdfmix"))
    a = ap.parse_args()
    with h5py.File(a.table, "r") as h:
        theta_o = h["table"]["theta_o"][:]
    rows = [r for r in range(len(theta_o)) if theta_o[r] >= a.min_theta_o]
    out = []
    with tempfile.TemporaryDirectory() as work:
        for k in [None] + [int(x) for x in a.k.split(",")]:
            tag = f"k{k}" if k else "default"
            report, mixture, _ = fit_rows(a.bsdfmix, a.table, theta_o, rows, k, work)
            bands = error_bands(a.table, mixture, rows)
            with open(report) as f:
                for rec in csv.DictReader(f):
                    if int(rec["slice"]) in rows:  # the fit also takes the slices beside them
                        out.append([a.name, rec["slice"], f"{float(rec['theta_o']):.6f}", tag, rec["k"],
                                    f"{float(rec['l1_rel']):.6f}"] + [f"{x:.6f}" for x in bands[int(rec["slice"])]])
            print(f"{a.name} {tag}: {len(rows)} slices from theta_o {a.min_theta_o} rad", flush=True)
    tmp = a.csv + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["table", "slice", "theta_o", "setting", "k", "l1_rel", "l1_peak", "mass_peak", "l1_horizon"])
        w.writerows(out)
    os.replace(tmp, a.csv)
    print("wrote", a.csv)


if __name__ == "__main__":
    main()
