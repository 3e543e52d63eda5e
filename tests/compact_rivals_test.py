#!/usr/bin/python3
"""Checks the maths of bench/compact_rivals.py's representations on small synthetic tables:
the harmonics are orthonormal, a least squares fit recovers an expansion exactly, the smaller
table at the full grid is the table, averages keep a slice's integral, CDF probabilities sum to
1, the per-slice measures are compare's, and the mixture evaluation (the module) integrates to its
weights and agrees with its colour copies. Run by ctest (compact_rivals_test)."""
import json
import math
import os
import sys
import tempfile

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
import compact_metrics as cm  # noqa: E402
import mixture_eval  # noqa: E402
import rival_sh  # noqa: E402
import rival_table  # noqa: E402

FAILED = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        FAILED.append(what)


def write_table(path, domain, fn, nto=6, nti=24, npi=48):
    lo, hi = (-math.pi / 2, math.pi / 2) if domain == "fiber" else (0.0, math.pi / 2)
    c = lambda n, a, b: a + (np.arange(n) + 0.5) * (b - a) / n
    to, ti, pi = c(nto, lo, hi), c(nti, lo, hi), c(npi, -math.pi, math.pi)
    rgb = fn(*np.meshgrid(to, ti, pi, indexing="ij"))
    with h5py.File(path, "w") as f:
        g = f.create_group("table")
        g["values"] = (rgb @ cm.LUMA)[:, None].astype(np.float32)
        g["rgb"] = rgb[:, None].astype(np.float32)
        g["theta_o"], g["phi_o"], g["theta_i"], g["phi_i"] = to, np.zeros(1), ti, pi
        for k, v in (("domain", domain), ("symmetry", "azimuthal"), ("source", json.dumps({"model": "test"}))):
            g.attrs[k] = v
    return cm.Table(path)


def lobe(to, ti, pi):
    b = 0.2 + 2 * np.exp(-((ti - to) ** 2) / 0.05 - (pi / 0.4) ** 2)
    return np.stack([b, 0.6 * b, 0.3 * b], axis=-1)


def main():
    tmp = tempfile.mkdtemp()
    # the harmonics: orthonormal on the sphere (half the phi period: 1/2)
    n = 200
    t = (np.arange(n) + 0.5) * math.pi / n
    p = (np.arange(n) + 0.5) * math.pi / n
    tt, pp = np.meshgrid(t, p, indexing="ij")
    a = rival_sh.basis(12, False, tt.ravel(), pp.ravel())
    w = (np.sin(tt) * (math.pi / n) ** 2).ravel()
    g = (a * w[:, None]).T @ a
    check(np.abs(g - 0.5 * np.eye(len(g))).max() < 1e-3, "harmonics orthonormal (sphere, cos(m phi) alone)")
    check(rival_sh.count(4, True) == 9 and rival_sh.count(4, False) == 15, "coefficient counts")

    for domain in ("hemisphere", "fiber"):
        tab = write_table(os.path.join(tmp, domain + ".h5"), domain, lobe)
        e = cm.slice_errors(tab, tab.rgb)
        check(np.abs(e["l1"]).max() < 1e-6 and np.abs(e["energy_c"]).max() < 1e-6, domain + ": the table against itself")
        # the smaller table at the full grid is the table (it is symmetric in phi)
        grid, coarse = rival_table.downsample(tab, len(tab.theta_o), len(tab.theta_i), len(tab.phi_i))
        check(np.abs(rival_table.reconstruct(grid, coarse) - tab.rgb).max() < 1e-5, domain + ": full-grid table exact")
        # averaging keeps each slice's integral (the theta_o grid kept)
        grid, coarse = rival_table.downsample(tab, len(tab.theta_o), 6, 12)
        whole = (tab.g[None, :, :, None] * tab.rgb).sum(axis=(1, 2))
        coarse_int = (coarse * grid.measure_ti[None, :, None, None]).sum(axis=(1, 2))
        check(np.abs(coarse_int / whole - 1).max() < 1e-9, domain + ": coarse cells keep the integral")
        pr = rival_table.probabilities(grid, coarse)
        check(np.abs(pr.sum(axis=(1, 2)) - 1).max() < 1e-9, domain + ": CDF probabilities sum to 1")
        # least squares recovers an expansion exactly
        hemi = domain == "hemisphere"
        idx = rival_sh.basis_index(4, hemi)
        coef = np.linspace(1, 0.2, len(idx))

        def expansion(to, ti, pi):
            colat = (math.pi / 2 - ti) if domain == "fiber" else ti
            v = rival_sh.basis(4, hemi, colat.ravel(), pi.ravel()) @ coef + 2.0
            v = v.reshape(ti.shape)
            return np.stack([v, v, v], axis=-1)
        tab2 = write_table(os.path.join(tmp, domain + "_sh.h5"), domain, expansion)
        fit = rival_sh.Fit(tab2, 4)
        rec = fit.reconstruct(fit.coefficients(4, len(tab2.theta_o)))
        check(np.abs(rec / tab2.rgb - 1).max() < 1e-5, domain + ": SH fit recovers an expansion")
        c = fit.coefficients(4, 2)
        pr = rival_sh.cdf_probabilities(fit, c, 4)
        check(np.abs(pr.sum(axis=(1, 2)) - 1).max() < 1e-9, domain + ": SH CDF probabilities sum to 1")

    # the mixture, through the module: a Gaussian's density integrates to 1 over the plane (phi images included)
    th = np.linspace(-3, 3, 601)
    ph = np.linspace(-math.pi, math.pi, 720, endpoint=False) + math.pi / 720
    T, P = np.meshgrid(th, ph, indexing="ij")
    area = (th[1] - th[0]) * (ph[1] - ph[0])
    one = mixture_eval.bsdfmix.SliceMixture([1.0], [[0.1, 3.0]], [[0.05, 0.01, 0.3]])
    check(abs(one.pdf_param(T, P).sum() * area - 1) < 1e-3, "mixture density integrates to 1")
    # four copies of equal amplitude have the component's mean and covariance
    cp = mixture_eval.bsdfmix.SliceMixture([1.0], [[0.2, 0.5]], [[0.04, 0.01, 0.09]], rgb=[[4.0, 4.0, 4.0]],
                                           copies=np.ones((1, 4, 3)))
    d = cp.eval_rgb_param(T, P)[..., 0] * area / 4
    mean_t, mean_p = (d * T).sum(), (d * P).sum()
    cov_tt = (d * (T - 0.2) ** 2).sum()
    check(abs(d.sum() - 1) < 1e-6 and abs(mean_t - 0.2) < 1e-6 and abs(mean_p - 0.5) < 1e-6 and abs(cov_tt - 0.04) < 1e-5,
          "colour copies' moments")
    check(cm.quantile([3, 1, 2, 4], 0.5) == 2.5 and abs(cm.quantile(list(range(10)), 0.9) - 8.1) < 1e-12, "compare's quantiles")
    if FAILED:
        sys.exit("%d check(s) failed" % len(FAILED))
    print("all checks passed")


if __name__ == "__main__":
    main()
