#!/usr/bin/python3
"""Spherical harmonics per theta_o slice: a rival of the mixture stand-in at equal bytes
(bench/compact_rivals.py).

Real spherical harmonics up to degree l_max, fitted per slice by least squares to f at the
table's cell centers, each cell weighted by its solid angle, on the sphere for fibers (the polar
axis is the fiber axis: colatitude pi/2 - theta) and on the hemisphere for measured materials.
Two symmetries keep half the coefficients each: the tables are mirror-symmetric in phi_i, so
only the cos(m phi) harmonics are kept; on the hemisphere f is extended to the lower half by
reflection in the equator, so only the harmonics with l + m even are kept (they are even in
cos theta; on the hemisphere they are orthogonal, and the fit is the least squares fit of f
there). n_to slices over the domain's theta_o range hold the fit to the table averaged over
their theta_o cell; between them the coefficients are interpolated linearly (clamped at the
ends). A renderer evaluates the expansion per channel and clamps it at 0 (negative lobes).

It cannot be sampled without more data: drawing directions in proportion to a clamped
expansion needs a tabulated CDF. The sampled variant holds one: per SH slice the clamped
luminance averaged into n_c x n_c cells (half the phi period), sampled like the smaller table's
(bench/rival_table.py), its bytes counted.

Bytes, float32: coefficients x 3 channels x n_to; with the CDF, n_to x (n_c x n_c + n_c) more.
The normalised associated Legendre functions come from the standard stable recurrence in l.
"""
import math

import numpy as np

from compact_metrics import LUMA, linear, overlap


def basis_index(l_max, hemisphere):
    """The (l, m) kept, ordered by l then m, so that a smaller l_max is a prefix."""
    return [(l, m) for l in range(l_max + 1) for m in range(l + 1) if not hemisphere or (l + m) % 2 == 0]


def count(l_max, hemisphere):
    return len(basis_index(l_max, hemisphere))


def eval_bytes(n_to, l_max, hemisphere):
    return 4 * 3 * n_to * count(l_max, hemisphere)


def cdf_bytes(n_to, n_c):
    return 4 * n_to * (n_c * n_c + n_c)


def legendre(l_max, x):
    """Normalised associated Legendre functions P[(l, m)](x), such that P_l^m(cos t) cos(m phi) (times
    sqrt 2 for m > 0) is orthonormal on the sphere."""
    x = np.asarray(x, dtype=np.float64)
    s = np.sqrt(np.maximum(0.0, 1 - x * x))
    out = {}
    pmm = np.full_like(x, 1 / math.sqrt(4 * math.pi))
    for m in range(l_max + 1):
        if m > 0:
            pmm = -math.sqrt((2 * m + 1) / (2 * m)) * s * pmm
        out[(m, m)] = pmm
        if m + 1 <= l_max:
            out[(m + 1, m)] = math.sqrt(2 * m + 3) * x * pmm
        for l in range(m + 2, l_max + 1):
            a = math.sqrt((4 * l * l - 1) / (l * l - m * m))
            b = math.sqrt(((l - 1) ** 2 - m * m) / (4 * (l - 1) ** 2 - 1))
            out[(l, m)] = a * (x * out[(l - 1, m)] - b * out[(l - 2, m)])
    return out


def basis(l_max, hemisphere, colat, phi):
    """[len(colat), n_basis]: the harmonics at points (colat, phi) (arrays of one length)."""
    p = legendre(l_max, np.cos(colat))
    cols = []
    for l, m in basis_index(l_max, hemisphere):
        c = p[(l, m)]
        cols.append(c if m == 0 else math.sqrt(2) * c * np.cos(m * phi))
    return np.stack(cols, axis=1)


_GRAMS = {}


class Fit:
    """The least squares machinery of one table up to l_max: the Gram matrix over the half period of
    phi_i and the right-hand sides of every fine slice (any smaller l_max is a prefix of both)."""

    def __init__(self, table, l_max, cosine=False):
        self.table, self.l_max = table, l_max
        # cosine: on the hemisphere, fit f cos(theta_i) and divide by it to evaluate
        self.cosine = cosine and table.domain == "hemisphere"
        self.cos = np.cos(table.theta_i) if cosine and table.domain == "hemisphere" else np.ones(len(table.theta_i))
        self.hemisphere = table.domain == "hemisphere"
        npi = len(table.phi_i)
        self.half = np.nonzero(table.phi_i >= 0)[0]  # phi in [0, pi): the mirror half
        if len(self.half) * 2 != npi:
            raise ValueError("phi_i is not symmetric about 0")
        key = (table.domain, tuple(table.theta_i), tuple(table.phi_i), l_max)
        if key not in _GRAMS:  # the same for every table on this grid
            tt, pp = np.meshgrid(table.theta_i, table.phi_i[self.half], indexing="ij")
            colat = (math.pi / 2 - tt) if table.domain == "fiber" else tt
            a = basis(l_max, self.hemisphere, colat.ravel(), pp.ravel())  # [cells of the half, n]
            w = np.repeat(table.solid_theta[:, None], len(self.half), axis=1).ravel() * table.dph
            aw = a * w[:, None]
            _GRAMS[key] = (a, aw, aw.T @ a)
        self.a, aw, self.gram = _GRAMS[key]
        sym = 0.5 * (table.rgb + table.rgb[:, :, ::-1])[:, :, self.half]  # [nto, nti, half, 3]
        sym = sym * self.cos[None, :, None, None]
        self.rhs = np.tensordot(aw.T, sym.reshape(len(table.theta_o), -1, 3), axes=(1, 1))  # [n, nto, 3]

    def coefficients(self, l_max, n_to):
        """[n_to, n, 3]: the fits of n_to slices, each to the table averaged over its theta_o cell."""
        n = count(l_max, self.hemisphere)
        t = self.table
        avg = overlap(len(t.theta_o), n_to, t.lo, t.hi)
        avg /= avg.sum(axis=1, keepdims=True)
        rhs = np.tensordot(self.rhs[:n], avg, axes=(1, 1))  # [n, 3, n_to]
        g = self.gram[:n, :n]
        c = np.linalg.solve(g + 1e-12 * np.trace(g) / n * np.eye(n), rhs.reshape(n, -1))
        return np.moveaxis(c.reshape(n, 3, n_to), 2, 0)

    def reconstruct(self, coef, rows=None):
        """The clamped expansion at every fine cell of every fine slice (or those of rows): [nto, nti, npi, 3]."""
        t = self.table
        n_to, n = coef.shape[0], coef.shape[1]
        lin = linear(len(t.theta_o), n_to, t.lo, t.hi)
        if rows is not None:
            lin = lin[rows]
        c = np.tensordot(lin, coef, axes=(1, 0))  # [nto, n, 3]
        half = np.einsum("cn,tnk->tck", self.a[:, :n], c, optimize=True)
        half = np.maximum(half, 0.0).reshape(len(lin), len(t.theta_i), len(self.half), 3)
        half /= self.cos[None, :, None, None]
        full = np.empty((len(lin), len(t.theta_i), len(t.phi_i), 3))
        full[:, :, self.half] = half
        full[:, :, self.half[::-1] - len(self.half)] = half  # phi -> -phi: index j -> npi - 1 - j
        return full

    def slices(self, coef):
        """The clamped expansion of each SH slice itself at the fine cells: [n_to, nti, npi, 3]."""
        t = self.table
        n = coef.shape[1]
        half = np.maximum(np.einsum("cn,snk->sck", self.a[:, :n], coef, optimize=True), 0.0)
        half = half.reshape(coef.shape[0], len(t.theta_i), len(self.half), 3) / self.cos[None, :, None, None]
        full = np.empty((coef.shape[0], len(t.theta_i), len(t.phi_i), 3))
        full[:, :, self.half] = half
        full[:, :, self.half[::-1] - len(self.half)] = half
        return full


def cdf_probabilities(fit, coef, n_c):
    """Per fine slice, the probability of each fine cell under the tabulated CDF (n_c x 2 n_c cells over
    the full period, half stored) of each SH slice's clamped luminance, slices picked by their weights."""
    from rival_table import CoarseGrid
    t = fit.table
    grid = CoarseGrid(t, coef.shape[0], n_c, 2 * n_c)
    lum = fit.slices(coef) @ LUMA  # [n_to, nti, npi]
    x = np.moveaxis(np.tensordot(grid.avg_ti, lum, axes=(1, 1)), 0, 1)
    coarse = np.moveaxis(np.tensordot(grid.avg_pi, x, axes=(1, 2)), 0, 2)
    return grid.cdf_probabilities(coarse)
