#!/usr/bin/python3
"""A hard hemisphere table, the shape of a glossy measured paint: a broad base, a specular
peak 30x the base a few cells wide (Gaussian in the angle to the mirror direction, sigma
0.035 rad, about two theta cells), and thin-film fringes on the base (a 35% sine of that
angle, period 0.57 rad). Azimuthal symmetry, 90 x 180 cells per slice, `values` only.

    /usr/bin/python3 bench/hard_table.py OUT.h5 [--theta-o 12] [--peak-sigma 0.035]

bench/search_before_after.py fits it (CHANGELOG.md, "A walk that does not give up").
"""
import argparse
import json

import h5py
import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("output")
    ap.add_argument("--theta-o", type=int, default=12)
    ap.add_argument("--peak-sigma", type=float, default=0.035)
    a = ap.parse_args()
    nt, nph = 90, 180
    th = (np.arange(nt) + 0.5) * (np.pi / 2) / nt
    ph = -np.pi + (np.arange(nph) + 0.5) * 2 * np.pi / nph
    to = (np.arange(a.theta_o) + 0.5) * (np.pi / 2) / a.theta_o
    t, p = np.meshgrid(th, ph, indexing="ij")
    values = np.zeros((a.theta_o, 1, nt, nph), np.float32)
    for s, t0 in enumerate(to):
        # the angle to the mirror direction (theta_i = theta_o at phi = 0 in the table's frame)
        ang = np.arccos(np.clip(np.sin(t) * np.sin(t0) * np.cos(p) + np.cos(t) * np.cos(t0), -1, 1))
        base = np.exp(-ang ** 2 / (2 * 0.5 ** 2)) + 0.3
        fringes = 1 + 0.35 * np.sin(ang / 0.09)
        peak = 30.0 * np.exp(-ang ** 2 / (2 * a.peak_sigma ** 2))
        values[s, 0] = 0.1 * (base * fringes + peak)
    with h5py.File(a.output, "w") as f:
        g = f.create_group("table")
        g.attrs["domain"] = "hemisphere"
        g.attrs["symmetry"] = "azimuthal"
        g.attrs["source"] = json.dumps({"model": "bench/hard_table.py", "peak_sigma": a.peak_sigma})
        g["theta_i"], g["phi_i"], g["theta_o"], g["phi_o"] = th, ph, to, np.array([0.0])
        g.create_dataset("values", data=values, chunks=(1, 1, nt, nph))


if __name__ == "__main__":
    main()
