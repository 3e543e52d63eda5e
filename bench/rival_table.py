#!/usr/bin/python3
"""The smaller table: a rival of the mixture stand-in at equal bytes (bench/compact_rivals.py).

The full table averaged into coarser cells, theta_o, theta_i and phi_i reduced together: n_to
slices over the domain's theta range, n_ti x n_pi cells per slice (phi_i over a full period, of
which half is stored: the tables are mirror-symmetric in phi_i, so f(-phi) is f(phi)). A coarse
cell is the average of the fine cells it covers, weighted by their integrand measure along
theta_i (J [cos]), so that it keeps their integral. A renderer evaluates it by trilinear
interpolation between cell centers (clamped in theta, periodic in phi) and samples it by the CDF
of its luminance: per coarse slice, a coarse cell picked in proportion to its luminance times
its integrand measure, a point uniform in solid angle within it; between slices, the slice picked
by its interpolation weight.

Bytes, float32: the cells, 3 channels (n_to x n_ti x n_pi / 2 x 3 x 4); the CDF adds one
luminance value per cell and one marginal value per theta_i row per slice
(n_to x (n_ti x n_pi / 2 + n_ti) x 4).
"""
import numpy as np

from compact_metrics import LUMA, linear, overlap


def eval_bytes(n_to, n_ti, n_pi):
    return 4 * 3 * n_to * n_ti * (n_pi // 2)


def cdf_bytes(n_to, n_ti, n_pi):
    return 4 * n_to * (n_ti * (n_pi // 2) + n_ti)


class CoarseGrid:
    """The linear maps between a table's fine axes and a coarse grid (n_to, n_ti, n_pi)."""

    def __init__(self, table, n_to, n_ti, n_pi):
        self.table = table
        self.shape = (n_to, n_ti, n_pi)
        nto, nti, npi = len(table.theta_o), len(table.theta_i), len(table.phi_i)
        import math
        # averages: rows normalised
        a = overlap(nto, n_to, table.lo, table.hi)
        self.avg_to = a / a.sum(axis=1, keepdims=True)
        a = overlap(nti, n_ti, table.lo, table.hi, table.measure_theta)
        self.avg_ti = a / a.sum(axis=1, keepdims=True)
        a = overlap(npi, n_pi, -math.pi, math.pi)
        self.avg_pi = a / a.sum(axis=1, keepdims=True)
        # interpolation back to the fine centers
        self.lin_to = linear(nto, n_to, table.lo, table.hi)
        self.lin_ti = linear(nti, n_ti, table.lo, table.hi)
        self.lin_pi = linear(npi, n_pi, -math.pi, math.pi, periodic=True)
        # a coarse cell's integrand measure, and the fine cells' shares of its solid angle
        self.measure_ti = overlap(nti, n_ti, table.lo, table.hi, table.measure_theta).sum(axis=1) * (2 * math.pi / n_pi)
        s = overlap(nti, n_ti, table.lo, table.hi, table.solid_theta)
        self.share_ti = s / s.sum(axis=1, keepdims=True)
        s = overlap(npi, n_pi, -math.pi, math.pi)
        self.share_pi = s / s.sum(axis=1, keepdims=True)

    def average(self, x):
        """[nto, nti, npi, ...] -> [n_to, n_ti, n_pi, ...]"""
        x = np.tensordot(self.avg_to, x, axes=(1, 0))
        x = np.moveaxis(np.tensordot(self.avg_ti, x, axes=(1, 1)), 0, 1)
        return np.moveaxis(np.tensordot(self.avg_pi, x, axes=(1, 2)), 0, 2)

    def along_theta_o(self, x, rows=None):
        """Coarse slices [n_to, ...] interpolated to every fine theta_o (or those of rows)."""
        return np.tensordot(self.lin_to if rows is None else self.lin_to[rows], x, axes=(1, 0))

    def interpolate_cells(self, x):
        """[n, n_ti, n_pi, ...] -> [n, nti, npi, ...] (bilinear within a slice)."""
        x = np.moveaxis(np.tensordot(self.lin_ti, x, axes=(1, 1)), 0, 1)
        return np.moveaxis(np.tensordot(self.lin_pi, x, axes=(1, 2)), 0, 2)

    def cdf_probabilities(self, lum):
        """Per fine slice, the probability of each fine cell under the CDF of the coarse luminance lum
        [n_to, n_ti, n_pi] (negative values as 0)."""
        p = np.maximum(lum, 0.0) * self.measure_ti[None, :, None]
        tot = p.sum(axis=(1, 2), keepdims=True)
        n_pi = self.shape[2]
        p = np.where(tot > 0, p / np.where(tot > 0, tot, 1), 1.0 / (self.shape[1] * n_pi))
        # uniform in solid angle within a coarse cell
        fine = np.einsum("sij,ia,jb->sab", p, self.share_ti, self.share_pi, optimize=True)
        return self.along_theta_o(fine)


def downsample(table, n_to, n_ti, n_pi):
    """The smaller table: (grid, coarse rgb [n_to, n_ti, n_pi, 3]), mirror-symmetric in phi."""
    grid = CoarseGrid(table, n_to, n_ti, n_pi)
    sym = 0.5 * (table.rgb + table.rgb[:, :, ::-1])
    return grid, grid.average(sym)


def reconstruct(grid, coarse, rows=None):
    """Its value at every fine cell center of every fine slice (or those of rows): [nto, nti, npi, 3]."""
    return grid.interpolate_cells(grid.along_theta_o(coarse, rows))


def probabilities(grid, coarse):
    return grid.cdf_probabilities(coarse @ LUMA)
