#!/usr/bin/python3
"""The pole and the border: does a pole-free parameterization of the hemisphere pay?

Fits the same weighted EM at pinned K to chosen slices of a hemisphere table in three
parameterizations of omega_i, and scores each fit as a stand-in in the table's own cells
(the relative L1 error of docs/fitting.md, mass past the border counted as missing):

  native  (theta_i, phi_i), the project's parameterization, phi turned so that the slice's
          peak sits at phi = 0 (the seam opposite it; the project's phi images do the same
          job);
  disk    Lambert's equal-area map of omega_i, u = 2 sin(theta_i / 2) (cos phi_i, sin phi_i):
          no pole at the normal, no seam, the border a circle of radius sqrt(2);
  half    the same map of the half vector h = (omega_i + omega_o) / |omega_i + omega_o|
          (Rusinkiewicz 1998): a specular peak sits at h = n, u = 0, for every view.

A fit in u has density p(u) there; its mass in cell i is p(u) |det du/d(theta, phi)|
dtheta dphi averaged over 3 x 3 points of the cell (so that a component narrower than a
cell, or a map that shrinks cells, is not judged by one point), the Jacobian by central
differences.

  native_t  (theta_i, phi_i) as native, with Student-t components of --nu degrees of
          freedom instead of Gaussians (tails that fall as a power of the distance): does a
          heavier-tailed lobe pay where Gaussians need many components (--maps; the CSV's
          map is native_t<nu>)?

EM is the plain weighted EM (k-means++ seeds, a covariance floor of a quarter cell),
without the project's split-and-merge or L1 refinement, the same for the three maps: the
comparison is between parameterizations, not against the project's fits. Numpy only.
With --bsdfmix the project's own fits of the same slices are added, in each of the maps it
builds (--project-maps, `fit.map`): `project` in (theta, phi) and `project_disk` on the
equal-area disk with its Lambertian base, the search pinned at each K (k-means++,
split-and-merge, L1 refinement, colour amplitudes), and `project_default` /
`project_default_disk`, the default search's chosen K (in `k`).

    /usr/bin/python3 bench/parameterization.py --table T.h5 --name satin --rows 0,3,6,80,84,88 \
        --k 4,8,16 --csv bench/results/parameterization.csv [--append] [--bsdfmix build/bsdfmix]
"""
import argparse
import csv
import itertools
import os
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np


def lambert(x, y, z):
    """Equal-area map of unit vectors with z >= 0 to the disk of radius sqrt(2)."""
    theta = np.arccos(np.clip(z, -1.0, 1.0))
    phi = np.arctan2(y, x)
    r = 2.0 * np.sin(0.5 * theta)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)


def direction(theta, phi):
    return np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)


def make_map(kind, theta_o, phi_o, phi_turn):
    wo = np.array(direction(theta_o, phi_o))

    def native(t, p):
        q = np.mod(p - phi_turn + np.pi, 2.0 * np.pi) - np.pi
        return np.stack([t, q], axis=-1)

    def disk(t, p):
        return lambert(*direction(t, p))

    def half(t, p):
        x, y, z = direction(t, p)
        hx, hy, hz = x + wo[0], y + wo[1], z + wo[2]
        n = np.sqrt(hx * hx + hy * hy + hz * hz)
        return lambert(hx / n, hy / n, hz / n)

    return {"native": native, "native_t": native, "disk": disk, "half": half}[kind]


def jacobian(fmap, t, p, eps=1e-5):
    ut = (fmap(t + eps, p) - fmap(t - eps, p)) / (2 * eps)
    up = (fmap(t, p + eps) - fmap(t, p - eps)) / (2 * eps)
    return np.abs(ut[:, 0] * up[:, 1] - ut[:, 1] * up[:, 0])


def quadratic(u, mean, cov):
    """The quadratic form (u - mean)^T cov^-1 (u - mean) at every point of u."""
    d = u - mean
    a, b, c = cov[0, 0], cov[0, 1], cov[1, 1]
    return (c * d[:, 0] ** 2 - 2 * b * d[:, 0] * d[:, 1] + a * d[:, 1] ** 2) / (a * c - b * b)


# Not the header's evaluator, and not meant to be: this study's own EM fits and scores plain
# (non-periodic) Gaussians and Student-t components in its three maps, the disk and half-vector
# maps among them, none of which is a slice mixture of include/bsdfmix/mixture.hpp (periodic in
# phi over (theta, phi)); scoring the native map with the header's phi images would judge it by
# another model than the one its EM fitted. The project's own fits (`project` rows) are scored
# by bsdfmix itself (the fit report's l1_rel).
def density(q, cov, nu=None):
    """A component's density from its quadratic form q: a Gaussian, or with nu a bivariate
    Student-t of nu degrees of freedom (scale matrix cov)."""
    det = cov[0, 0] * cov[1, 1] - cov[0, 1] * cov[0, 1]
    shape = np.exp(-0.5 * q) if nu is None else (1 + q / nu) ** (-0.5 * (nu + 2))
    return shape / (2 * np.pi * np.sqrt(det))


def mixture_pdf(u, pi, mu, cov, nu=None):
    return sum(pi[k] * density(quadratic(u, mu[k], cov[k]), cov[k], nu) for k in range(len(pi)))


def em(u, w, k, floor, rng, iterations, nu=None):
    """Weighted EM of k Gaussians (or, with nu, Student-t components of nu degrees of
    freedom: each point's latent scale (nu + 2) / (nu + q) weighs the mean and covariance)
    to points u with weights w (sum 1)."""
    n = len(w)
    centers = [u[rng.choice(n, p=w)]]
    for _ in range(1, k):
        d2 = np.min([np.sum((u - c) ** 2, axis=1) for c in centers], axis=0)
        p = w * d2
        centers.append(u[rng.choice(n, p=p / p.sum())] if p.sum() > 0 else u[rng.choice(n, p=w)])
    mu = np.array(centers)
    spread = np.cov(u.T, aweights=w) + floor * np.eye(2)
    cov = np.array([spread / k for _ in range(k)])
    pi = np.full(k, 1.0 / k)
    for _ in range(iterations):
        q = np.stack([quadratic(u, mu[j], cov[j]) for j in range(k)], axis=1)
        dens = np.stack([pi[j] * density(q[:, j], cov[j], nu) for j in range(k)], axis=1)
        tot = dens.sum(axis=1, keepdims=True)
        tot[tot <= 0] = 1e-300
        r = dens / tot * w[:, None]
        nk = r.sum(axis=0)
        keep = nk > 1e-12
        if not keep.all():
            r, nk, k, q = r[:, keep], nk[keep], int(keep.sum()), q[:, keep]
        pi = nk / nk.sum()
        # Student-t: each point weighed by its latent scale at the E-step's parameters
        ru = r if nu is None else r * (nu + 2) / (nu + q)
        mu = (ru.T @ u) / ru.sum(axis=0)[:, None]
        cov = np.empty((k, 2, 2))
        for j in range(k):
            d = u - mu[j]
            cj = (ru[:, j, None] * d).T @ d / nk[j]
            vals, vecs = np.linalg.eigh(cj)
            vals = np.maximum(vals, floor)
            cov[j] = (vecs * vals) @ vecs.T
    return pi, mu, cov


def fit_rows(bsdfmix, table, theta_o, rows, k, work, extra=""):
    """The project's fit of the table's theta_o `rows` (K pinned at k, or the default search
    when k is None) in `work`, with the fit: lines `extra`: (report CSV, mixture, seconds)."""
    tag = f"k{k}" if k else "default"
    cfg = os.path.join(work, tag + ".yaml")
    with open(cfg, "w") as f:
        f.write(f"table: {os.path.abspath(table)}\nfit:\n"
                f"  output: {work}/{tag}.h5\n  report: {work}/{tag}.csv\n{extra}")
        if k:
            f.write(f"  k_min: {k}\n  k_max: {k}\n")
        f.write("  theta_o: [" + ", ".join(repr(float(theta_o[r])) for r in rows) + "]\n")
    t0 = time.time()
    subprocess.run([bsdfmix, "fit", cfg, "--quiet"], check=True, stdout=subprocess.DEVNULL)
    return os.path.join(work, tag + ".csv"), os.path.join(work, tag + ".h5"), time.time() - t0


PROJECT_MAPS = {"theta_phi": "", "equal_area": "_disk"}  # fit.map: the label's suffix


def project_fits(a, theta_o, rows, ks):
    """The project's fits of the rows in each of --project-maps: pinned at each K, and the
    default search. Each map's fits have a work folder of their own."""
    out = []
    with tempfile.TemporaryDirectory() as work:
        for fit_map, k in itertools.product(a.project_maps.split(","), ks + [None]):
            map_work = os.path.join(work, fit_map)
            os.makedirs(map_work, exist_ok=True)
            report, _, seconds = fit_rows(a.bsdfmix, a.table, theta_o, rows, k, map_work,
                                          f"  seed: 1\n  map: {fit_map}\n")
            label = ("project" if k else "project_default") + PROJECT_MAPS[fit_map]
            with open(report) as f:
                fitted = [rec for rec in csv.DictReader(f) if int(rec["slice"]) in rows]
            for rec in fitted:
                r = int(rec["slice"])
                out.append([a.name, r, f"{theta_o[r]:.6f}", label,
                            rec["k"], f"{float(rec['l1_rel']):.6f}", f"{seconds / len(rows):.2f}"])
                print(",".join(str(x) for x in out[-1]), flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--table", required=True)
    ap.add_argument("--name", required=True)
    ap.add_argument("--rows", required=True, help="theta_o rows, comma separated")
    ap.add_argument("--k", default="4,8,16")
    ap.add_argument("--restarts", type=int, default=3, help="EM restarts per fit; 0: no EM of this script")
    ap.add_argument("--iterations", type=int, default=150)
    ap.add_argument("--maps", default="native,disk,half", help="of native, disk, half, native_t")
    ap.add_argument("--nu", type=float, default=3.0, help="native_t: the Student-t components' degrees of freedom")
    ap.add_argument("--csv", required=True)
    ap.add_argument("--append", action="store_true")
    ap.add_argument("--bsdfmix", help="also fit the slices with this build (pinned K and default)")
    ap.add_argument("--project-maps", default="theta_phi,equal_area",
                    help="the fit.map values the project's fits are made in (of theta_phi, equal_area)")
    a = ap.parse_args()
    for m in a.project_maps.split(","):
        if m not in PROJECT_MAPS:
            sys.exit(f"parameterization: --project-maps: '{m}' is not one of {', '.join(PROJECT_MAPS)}")

    with h5py.File(a.table, "r") as h:
        f = h["table"]
        domain = f.attrs.get("domain", "")
        if (domain.decode() if isinstance(domain, bytes) else domain) != "hemisphere":
            sys.exit(f"{a.table}: domain is not hemisphere")
        theta_o = f["theta_o"][:]
        ti = f["theta_i"][:]
        pi_ = f["phi_i"][:]
        values = f["values"]
        rows = [int(s) for s in a.rows.split(",")]
        slices = {r: values[r, 0, :, :].astype(np.float64) for r in rows}
    dt, dp = ti[1] - ti[0], pi_[1] - pi_[0]
    T, P = np.meshgrid(ti, pi_, indexing="ij")
    T, P = T.ravel(), P.ravel()
    ks = [int(s) for s in a.k.split(",")]
    out_rows = []
    for r in rows:
        f = slices[r].ravel()
        w = f * np.cos(T) * np.sin(T) * dt * dp
        W = w.sum()
        if W <= 0:
            continue
        wn = w / W
        peak = int(np.argmax(wn))
        phi_turn = P[peak]
        # The mirror direction of omega_o is the slice's peak: omega_o's azimuth is opposite.
        phi_o = phi_turn + np.pi
        for kind in a.maps.split(",") if a.restarts > 0 else ():  # 0: the project's fits alone
            fmap = make_map(kind, theta_o[r], phi_o, phi_turn)
            # 3 x 3 points of each cell, the map and its Jacobian there; the middle one is
            # the cell center, where EM sees the cell. native: the turn of phi is a shift
            # (Jacobian 1; differences would cross the seam).
            sub = [(a_ * dt / 3, b_ * dp / 3) for a_ in (-1, 0, 1) for b_ in (-1, 0, 1)]
            pts = [(fmap(T + x, P + y),
                    np.ones_like(T) if kind.startswith("native") else jacobian(fmap, T + x, P + y))
                   for x, y in sub]
            u, jac = pts[4]
            cellu = np.sqrt(np.median(jac) * dt * dp)
            floor = (0.25 * cellu) ** 2
            for k in ks:
                best = None
                t0 = time.time()
                for s in range(a.restarts):
                    rng = np.random.default_rng(1000 * r + 17 * k + s)
                    nu = a.nu if kind == "native_t" else None
                    pi, mu, cov = em(u, wn, k, floor, rng, a.iterations, nu)
                    m = sum(mixture_pdf(us, pi, mu, cov, nu) * js for us, js in pts) * dt * dp / 9
                    l1 = float(np.abs(wn - m).sum())
                    best = l1 if best is None else min(best, l1)
                label = f"native_t{a.nu:g}" if kind == "native_t" else kind  # the degrees of freedom named
                out_rows.append([a.name, r, f"{theta_o[r]:.6f}", label, k, f"{best:.6f}",
                                 f"{time.time() - t0:.2f}"])
                print(",".join(str(x) for x in out_rows[-1]), flush=True)
    if a.bsdfmix:
        out_rows += project_fits(a, theta_o, rows, ks)
    exists = os.path.exists(a.csv) and a.append
    tmp = a.csv + ".tmp"
    with open(tmp, "w", newline="") as fo:
        wr = csv.writer(fo)
        if exists:
            with open(a.csv) as fi:
                fo.write(fi.read())
        else:
            wr.writerow(["table", "row", "theta_o", "map", "k", "l1_rel", "seconds"])
        wr.writerows(out_rows)
    os.replace(tmp, a.csv)


if __name__ == "__main__":
    main()
