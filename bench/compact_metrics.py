#!/usr/bin/python3
"""A full-resolution table read into numpy, and the per-slice measures of a compact
representation of it, computed as `bsdfmix compare` computes them (host/compare/compare.cpp,
docs/formats.md "Compare"): every error weighs each cell by its integrand weight
(f [cos theta_i] J dtheta dphi with f = 1), at the table's cell centers, at every table slice.

Used by bench/compact_rivals.py for the rivals (the smaller table, spherical harmonics) and for
the mixture's sampling variance; the mixture's errors come from `bsdfmix compare` itself.
"""
import json
import math

import h5py
import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])
NOISE_SHARE = 0.005  # host/fit/amplitudes.cpp kNoiseShare: a channel whose negative cells hold more is noise


def attr(a, key):
    v = a[key]
    return v.decode() if isinstance(v, bytes) else str(v)


class Table:
    """A table file (docs/formats.md, "Table file") with azimuthal symmetry and colour, whole in memory."""

    def __init__(self, path):
        with h5py.File(path, "r") as f:
            t = f["table"]
            self.domain = attr(t.attrs, "domain")
            if attr(t.attrs, "symmetry") != "azimuthal":
                raise ValueError("%s: only tables with azimuthal symmetry" % path)
            self.source = attr(t.attrs, "source")
            self.theta_o = t["theta_o"][()]
            self.theta_i = t["theta_i"][()]
            self.phi_i = t["phi_i"][()]
            self.values = t["values"][:, 0].astype(np.float64)  # [n_theta_o, n_theta_i, n_phi_i]
            self.rgb = t["rgb"][:, 0].astype(np.float64)  # [..., 3]
        self.path = path
        self.lo, self.hi = (-math.pi / 2, math.pi / 2) if self.domain == "fiber" else (0.0, math.pi / 2)
        self.dth = self.theta_i[1] - self.theta_i[0]
        self.dph = self.phi_i[1] - self.phi_i[0]
        # the integrand measure of a cell with f = 1: J [cos] dtheta dphi
        self.measure_theta = self.jacobian(self.theta_i) * self.dth  # per theta_i row, times dphi below
        self.g = np.repeat(self.measure_theta[:, None], len(self.phi_i), axis=1) * self.dph
        # the solid angle of a cell (J dtheta dphi), the measure a CDF is uniform in within a cell
        jac = np.cos(self.theta_i) if self.domain == "fiber" else np.sin(self.theta_i)
        self.solid_theta = jac * self.dth

    def jacobian(self, theta):
        """J [cos theta] of the integrand (docs/formats.md, "Integrand weights")."""
        if self.domain == "fiber":
            return np.cos(theta)
        return np.cos(theta) * np.sin(theta)

    def symmetric_in_phi(self):
        """The largest share of a slice's RGB L1 between f(phi) and f(-phi): how far the table is from
        mirror symmetry in phi_i (the rivals keep half the period)."""
        m = self.rgb[:, :, ::-1]
        d = (np.abs(self.rgb - m) * self.g[None, :, :, None]).sum(axis=(1, 2, 3))
        t = (np.abs(self.rgb) * self.g[None, :, :, None]).sum(axis=(1, 2, 3))
        return float(np.max(d / np.maximum(t, 1e-300)))

    def write_like(self, path, rgb, what):
        """Writes rgb [n_theta_o, n_theta_i, n_phi_i, 3] as a table file on this table's axes, values its
        luminance (a negative luminance stored as 0), the source naming `what`."""
        rgb32 = rgb.astype(np.float32)
        y = np.maximum(0.0, rgb32.astype(np.float64) @ LUMA).astype(np.float32)
        src = json.loads(self.source)
        src = {"model": "compact_rival", "representation": what, "of": src}
        tmp = path + ".partial"
        with h5py.File(tmp, "w") as f:
            g = f.create_group("table")
            n = (len(self.theta_o), 1, len(self.theta_i), len(self.phi_i))
            g.create_dataset("values", data=y.reshape(n), chunks=(1, 1) + n[2:])
            g.create_dataset("rgb", data=rgb32.reshape(n + (3,)), chunks=(1, 1) + n[2:] + (3,))
            g.create_dataset("theta_o", data=self.theta_o)
            g.create_dataset("phi_o", data=np.zeros(1))
            g.create_dataset("theta_i", data=self.theta_i)
            g.create_dataset("phi_i", data=self.phi_i)
            dt = h5py.string_dtype("utf-8")
            g.attrs.create("domain", self.domain, dtype=dt)
            g.attrs.create("symmetry", "azimuthal", dtype=dt)
            g.attrs.create("source", json.dumps(src), dtype=dt)
        import os
        os.replace(tmp, path)


def slice_errors(table, rgb_hat, y_hat=None, rows=None):
    """Per slice, as compare computes them: luminance L1, RGB error, its negative share, energy of the
    luminance and of each channel, and which channels are noise. rgb_hat [n_theta_o, n_theta_i, n_phi_i, 3];
    y_hat the luminance stand-in (default: the luminance of rgb_hat, a negative one as 0)."""
    if y_hat is None:
        y_hat = np.maximum(0.0, rgb_hat @ LUMA)
    g = table.g[None]
    y = table.values if rows is None else table.values[rows]
    t_rgb = table.rgb if rows is None else table.rgb[rows]
    l1 = (g * np.abs(y_hat - y)).sum(axis=(1, 2)) / np.maximum((g * np.abs(y)).sum(axis=(1, 2)), 1e-300)
    y_int = (g * y).sum(axis=(1, 2))
    energy_y = np.where(y_int > 0, (g * y_hat).sum(axis=(1, 2)) / np.where(y_int > 0, y_int, 1) - 1, 0.0)
    gc = g[..., None]
    diff = gc * np.abs(rgb_hat - t_rgb)
    d_c = diff.sum(axis=(1, 2))  # [n_theta_o, 3]
    t_c = (gc * np.abs(t_rgb)).sum(axis=(1, 2))
    neg = t_rgb < 0
    d_neg = (diff * neg).sum(axis=(1, 2, 3))
    t_neg = -(gc * t_rgb * neg).sum(axis=(1, 2))
    e_c = (gc * (rgb_hat - t_rgb)).sum(axis=(1, 2)) / np.maximum(t_c, 1e-300)
    dsum, tsum = d_c.sum(axis=1), t_c.sum(axis=1)
    rgb_error = dsum / np.maximum(tsum, 1e-300)
    neg_share = np.where(dsum > 0, d_neg / np.maximum(dsum, 1e-300), 0.0)
    noise = t_neg > NOISE_SHARE * t_c
    return dict(l1=l1, rgb_error=rgb_error, neg_share=neg_share, energy_y=energy_y, energy_c=e_c, noise=noise)


def summary(e):
    """Medians and p90s over the slices (compare's quantile: numpy's linear one), the RGB error
    less its negative share, and the largest energy error (noise channels left out)."""
    rgb = e["rgb_error"] * (1 - e["neg_share"])
    energy = np.maximum(np.abs(e["energy_y"]), np.where(e["noise"], 0.0, np.abs(e["energy_c"])).max(axis=1))
    return dict(median_l1=quantile(e["l1"], 0.5), p90_l1=quantile(e["l1"], 0.9), median_rgb=quantile(rgb, 0.5),
                p90_rgb=quantile(rgb, 0.9), max_energy=float(np.max(energy)))


def quantile(v, q):
    """compare's quantile (host/core/stats.cpp): linear between the two nearest order statistics."""
    return float(np.percentile(np.asarray(v, dtype=np.float64), 100 * q))


def sampling_variance(table, prob):
    """Relative variance per sample of importance sampling the luminance integral under constant light
    (docs/formats.md, "Tail risk": sum_c (W_c / I)^2 / P_c - 1), with W_c the full table's integrand weights
    and P_c [n_theta_o, n_theta_i, n_phi_i] the sampler's probability of landing in cell c; cells it never
    lands in (P_c = 0) are left out and their share of the integral returned as `missed`."""
    w = table.g[None] * table.values
    i = w.sum(axis=(1, 2))
    ok = i > 0
    wn = w[ok] / i[ok][:, None, None]
    p = prob[ok]
    hit = p > 0
    relvar = (np.where(hit, wn ** 2 / np.where(hit, p, 1), 0.0)).sum(axis=(1, 2)) - 1
    missed = (wn * ~hit).sum(axis=(1, 2))
    return relvar, missed


def overlap(n_fine, n_coarse, lo, hi, weights=None):
    """[n_coarse, n_fine]: the share of each fine cell (of n_fine uniform cells of [lo, hi]) inside each
    coarse cell (of n_coarse), times the fine cell's weight (default 1): rows summed give the coarse
    cell's content."""
    ef = np.linspace(lo, hi, n_fine + 1)
    ec = np.linspace(lo, hi, n_coarse + 1)
    a = np.maximum(0.0, np.minimum(ec[1:, None], ef[None, 1:]) - np.maximum(ec[:-1, None], ef[None, :-1]))
    a /= (ef[1] - ef[0])
    if weights is not None:
        a = a * weights[None, :]
    return a


def linear(n_fine, n_coarse, lo, hi, periodic=False):
    """[n_fine, n_coarse]: linear interpolation from the coarse cell centers to the fine ones, clamped at
    the ends (or periodic)."""
    xf = lo + (np.arange(n_fine) + 0.5) * (hi - lo) / n_fine
    u = (xf - lo) / (hi - lo) * n_coarse - 0.5  # position on the coarse centers
    m = np.zeros((n_fine, n_coarse))
    if n_coarse == 1:
        m[:, 0] = 1
        return m
    if periodic:
        i0 = np.floor(u).astype(int)
        f = u - i0
        np.add.at(m, (np.arange(n_fine), i0 % n_coarse), 1 - f)
        np.add.at(m, (np.arange(n_fine), (i0 + 1) % n_coarse), f)
    else:
        u = np.clip(u, 0, n_coarse - 1)
        i0 = np.minimum(np.floor(u).astype(int), n_coarse - 2)
        f = u - i0
        m[np.arange(n_fine), i0] = 1 - f
        m[np.arange(n_fine), i0 + 1] += f
    return m
