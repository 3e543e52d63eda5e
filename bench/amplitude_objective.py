#!/usr/bin/python3
"""The objective of the stand-in's amplitudes, by measurement (docs/studies/colour.md, "The
objective"): on the Gaussians of a mixture file, held fixed, the amplitudes of the luminance
and of R, G, B fitted three ways, each channel's integral kept (but for a channel that is
noise around zero, whose negative cells hold more than 0.5% of its absolute sum):

- `ls`: non-negative least squares;
- `irls`: least squares reweighted toward L1, as the sweep fits them (a first unweighted
  solve, then 12 weighted by 1 / max(|r|, delta), delta 1e-2 of the mean |w|; the best
  iterate kept);
- `lp`: the L1 optimum itself, a linear program (scipy's HiGHS), 16200 cells per channel.

Per slice: the luminance L1 error, the RGB error and the RGB error less its part in cells
whose measured channel is negative, as the fit report defines them (docs/formats.md), and
the seconds of each. Reads the tables and mixture files that bench/rgb_stand_in.py made; on
a disk file the Lambertian base is held as the file has it, like the Gaussians, and the
amplitudes fit what it leaves.

    bench/amplitude_objective.py [--work out/bench_rgb] [--tables satin,paper,sunflower]
                                 [--slices 3,39,75] [--csv bench/results/amplitude_objective.csv]
"""
import argparse
import csv
import importlib.util
import os
import statistics
import time

import h5py
import numpy as np
from scipy.optimize import linprog, nnls
from scipy.sparse import csr_matrix, hstack, identity, vstack

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_spec = importlib.util.spec_from_file_location("rgb_stand_in", os.path.join(ROOT, "bench", "rgb_stand_in.py"))
rgb_stand_in = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rgb_stand_in)


def solve_ls(phi, w, z, total, d=None):
    """Non-negative least squares of the cells weighted by d, z . a = total as a heavy row
    (None: no constraint), then scaled to meet it exactly: the sweep's solve."""
    d = np.ones_like(w) if d is None else d
    g = phi.T @ (phi * d[:, None])
    b = phi.T @ (d * w)
    diag = np.trace(g) / len(g)
    if total is not None:
        mu = 1e4 * diag * len(g) / (z @ z)
        g = g + mu * np.outer(z, z)
        b = b + mu * total * z
    chol = np.linalg.cholesky(g + 1e-10 * diag * np.eye(len(g)))
    a, _ = nnls(chol.T, np.linalg.solve(chol, b))
    if total is not None and z @ a > 0:
        a *= total / (z @ a)
    return a


def solve_irls(phi, w, z, total, iterations=12, delta=1e-2):
    a = solve_ls(phi, w, z, total)
    best, best_l1 = a, np.abs(w - phi @ a).sum()
    floor = delta * np.mean(np.abs(w))
    for _ in range(iterations):
        a = solve_ls(phi, w, z, total, 1.0 / np.maximum(np.abs(w - phi @ a), floor))
        l1 = np.abs(w - phi @ a).sum()
        if l1 < best_l1:
            best, best_l1 = a, l1
    return best


def solve_lp(phi, w, z, total):
    n, k = phi.shape
    p = csr_matrix(phi)
    eye = identity(n, format="csr")
    a_ub = vstack([hstack([p, -eye]), hstack([-p, -eye])]).tocsr()
    eq = {} if total is None else {"A_eq": csr_matrix(np.concatenate([z, np.zeros(n)])[None, :]), "b_eq": [total]}
    r = linprog(np.concatenate([np.zeros(k), np.ones(n)]), A_ub=a_ub, b_ub=np.concatenate([w, -w]),
                bounds=[(0, None)] * (k + n), method="highs", **eq)
    if not r.success:
        raise RuntimeError(r.message)
    return r.x[:k]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "bench_rgb"))
    ap.add_argument("--tables", default="satin,paper,sunflower")
    ap.add_argument("--slices", default="3,39,75")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "amplitude_objective.csv"))
    args = ap.parse_args()
    rows = []
    for name in [n for n in args.tables.split(",") if n]:
        t = h5py.File(os.path.join(args.work, name + ".h5"), "r")["table"]
        m = h5py.File(os.path.join(args.work, name + "_mixture.h5"), "r")["mixture"]
        theta, phi_i = t["theta_i"][:], t["phi_i"][:]
        dth, dph = theta[1] - theta[0], phi_i[1] - phi_i[0]
        tt, pp = np.meshgrid(theta, phi_i, indexing="ij")
        jac = (np.cos(tt) * np.sin(tt) * dth * dph).ravel()
        plane = rgb_stand_in.Plane(m, theta, phi_i, "hemisphere")
        for s in [int(x) for x in args.slices.split(",")]:
            k = int(m["k"][s])
            basis, z = [], []
            for j in range(k):
                a, b, c = (float(x) for x in m["covariances"][s, j])
                mt, mp = (float(x) for x in m["means"][s, j])
                basis.append(plane.mass(mt, mp, a, b, c).ravel())
                z.append(plane.in_domain(mt, mp, a, b, c))
            basis, z = np.array(basis).T, np.array(z)
            w_y = t["values"][s, 0].ravel().astype(np.float64) * jac
            w_c = t["rgb"][s, 0].reshape(-1, 3).astype(np.float64) * jac[:, None]
            # a Lambertian base (map disk) held as the file has it, like the Gaussians: the
            # amplitudes fit what it leaves, the errors are of the whole
            weights = m["weights"][s, :k].astype(np.float64)
            base = float(m["base"][s]) if "base" in m else 0.0
            base /= weights.sum() + base
            dome = (plane.base_density * plane.area).ravel()
            b_y = float(m["scale"][s]) * base * dome
            b_c = dome[:, None] * (m["base_rgb"][s].astype(np.float64) if base > 0 and "base_rgb" in m else np.zeros(3))
            totals = [None if -w_c[:, c][w_c[:, c] < 0].sum() > 0.005 * np.abs(w_c[:, c]).sum()
                      else w_c[:, c].sum() - b_c[:, c].sum() for c in range(3)]
            negative = w_c < 0
            for method, solve in (("ls", solve_ls), ("irls", solve_irls), ("lp", solve_lp)):
                start = time.monotonic()
                a_y = solve(basis, w_y - b_y, z, w_y.sum() - b_y.sum())
                a_c = np.array([solve(basis, w_c[:, c] - b_c[:, c], z, totals[c]) for c in range(3)]).T
                seconds = time.monotonic() - start
                err = np.abs(w_c - b_c - basis @ a_c)
                den = np.abs(w_c).sum()
                row = {"table": name, "slice": s, "method": method, "k": k,
                       "l1_rel": np.abs(w_y - b_y - basis @ a_y).sum() / w_y.sum(), "rgb_l1_rel": err.sum() / den,
                       "rgb_less_negative": (err.sum() - err[negative].sum()) / den, "seconds": seconds}
                rows.append(row)
                print(f"{name:10s} slice {s:2d} {method:4s}: L1 {100 * row['l1_rel']:.3f}%, RGB {100 * row['rgb_l1_rel']:.3f}%, "
                      f"less negative {100 * row['rgb_less_negative']:.3f}%, {seconds:.2f} s", flush=True)
        for method in ("ls", "irls", "lp"):
            sel = [r for r in rows if r["table"] == name and r["method"] == method]
            print(f"{name:10s} {method:4s} medians: L1 {100 * statistics.median(r['l1_rel'] for r in sel):.3f}%, RGB "
                  f"{100 * statistics.median(r['rgb_l1_rel'] for r in sel):.3f}%, less negative "
                  f"{100 * statistics.median(r['rgb_less_negative'] for r in sel):.3f}%")
    os.makedirs(os.path.dirname(args.csv), exist_ok=True)
    with open(args.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()) + ["cpu_model", "logical_cpus"])
        w.writeheader()
        for r in rows:
            w.writerow({**{k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()},
                        "cpu_model": rgb_stand_in.cpu_model(), "logical_cpus": os.cpu_count()})
    print(f"wrote {args.csv}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
