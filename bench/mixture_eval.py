#!/usr/bin/python3
"""A mixture file's stand-in and sampling density at every cell center of every table slice, in
numpy, as include/bsdfmix/mixture.hpp evaluates them (`eval_rgb`, `pdf_param`): each Gaussian's
density summed over its phi images within 9 sigma, colour copies for the slices that have them,
the slices the file does not hold blended linearly in theta_o between the nearest fitted ones
(`MixtureSet::blend`, clamped beyond the last). Azimuthally symmetric files only (phi_o = 0).

Used by bench/compact_rivals.py for the mixture's sampling variance, its evaluation cost and its
table for the image study; its errors agree with `bsdfmix compare` (the script checks).
"""
import math

import h5py
import numpy as np

COPIES, COPY_OFFSET = 4, 0.5


def density(theta, phi, mu_t, mu_p, s_tt, s_tp, s_pp):
    """The header's Gaussian::density at arrays theta, phi (phi in [-pi, pi))."""
    det = s_tt * s_pp - s_tp * s_tp
    i_tt, i_tp, i_pp = s_pp / det, -s_tp / det, s_tt / det
    norm = 1.0 / (2 * math.pi * math.sqrt(det))
    cut = 9.0 * math.sqrt(s_pp)
    images = int(math.ceil((cut + math.pi + abs(mu_p)) / (2 * math.pi)))
    dt = theta - mu_t
    out = np.zeros(np.broadcast(theta, phi).shape)
    for m in range(-images, images + 1):
        dp = phi + 2 * math.pi * m - mu_p
        q = i_tt * dt * dt + 2 * i_tp * dt * dp + i_pp * dp * dp
        out += np.where((np.abs(dp) <= cut) & (q < 1500), np.exp(-0.5 * np.minimum(q, 1500)), 0.0)
    return norm * out


def copy_of(mu_t, mu_p, s_tt, s_tp, s_pp, m):
    l_tt = math.sqrt(s_tt)
    l_pt = s_tp / l_tt
    l_pp = math.sqrt(max(s_pp - l_pt * l_pt, 0.0))
    sign = 1.0 if m % 2 else -1.0
    shrink = 1 - 0.5 * COPY_OFFSET ** 2
    return (mu_t + (sign * COPY_OFFSET * l_tt if m < 2 else 0.0),
            mu_p + (sign * COPY_OFFSET * l_pt if m < 2 else sign * COPY_OFFSET * l_pp),
            shrink * s_tt, shrink * s_tp, shrink * s_pp)


class Mixtures:
    """The slices of a mixture file (padded or ragged), as float64 from the stored values."""

    def __init__(self, path):
        with h5py.File(path, "r") as f:
            m = f["mixture"]
            self.theta_o = m["theta_o"][()]
            self.grid = m["table_theta_o"][()]
            k = m["k"][()]
            w, mu, cov = m["weights"][()], m["means"][()], m["covariances"][()]
            rgb = m["rgb_scale"][()]
            scale = m["scale"][()]
            if "offset" in m:  # ragged
                off = m["offset"][()]
                rows = [np.arange(o, o + kk) for o, kk in zip(off, k)]
            else:
                rows = None
            copies = m["rgb_copies"][()] if "rgb_copies" in m else None
            coff = m["copies_offset"][()] if "rgb_copies" in m else None
        self.slices = []
        for s in range(len(k)):
            idx = rows[s] if rows is not None else None
            get = (lambda a: a[idx]) if idx is not None else (lambda a: a[s, :k[s]])
            comps = [(float(a), tuple(map(float, b)), tuple(map(float, c)), tuple(map(float, d)))
                     for a, b, c, d in zip(get(w), get(mu), get(cov), get(rgb))]
            cp = None
            if copies is not None and coff[s] >= 0:
                cp = copies[coff[s]:coff[s] + k[s]].astype(np.float64)  # [k, 4, 3]
            self.slices.append(dict(scale=float(scale[s]), comps=comps, copies=cp))
        # each file slice's index on the table's theta_o grid
        self.at = [int(np.argmin(np.abs(self.grid - t))) for t in self.theta_o]

    def blend(self):
        """Per table slice, [(file slice, weight)], as MixtureSet::blend with azimuthal symmetry."""
        fitted = {a: s for s, a in enumerate(self.at)}
        order = sorted(fitted)
        out = []
        for t in range(len(self.grid)):
            lo = max([a for a in order if a <= t], default=None)
            hi = min([a for a in order if a >= t], default=None)
            if lo is not None and hi is not None and hi > lo:
                f = (t - lo) / (hi - lo)
                out.append([(fitted[lo], 1 - f), (fitted[hi], f)])
            else:
                out.append([(fitted[lo if lo is not None else hi], 1.0)])
        return out

    def slice_param(self, s, theta, phi):
        """File slice s at points: (pdf_param, rgb over (theta, phi) [..., 3], i.e. f [cos] J per channel)."""
        sl = self.slices[s]
        pdf = np.zeros(np.broadcast(theta, phi).shape)
        rgb = np.zeros(pdf.shape + (3,))
        for k, (w, mu, cov, amp) in enumerate(sl["comps"]):
            d = density(theta, phi, mu[0], mu[1], *cov)
            pdf += w * d
            if sl["copies"] is None:
                rgb += d[..., None] * np.array(amp)
        if sl["copies"] is not None:
            for k, (w, mu, cov, amp) in enumerate(sl["comps"]):
                for m in range(COPIES):
                    c = copy_of(mu[0], mu[1], cov[0], cov[1], cov[2], m)
                    rgb += density(theta, phi, *c)[..., None] * sl["copies"][k, m]
        return pdf, rgb


def on_table(mix, table):
    """(rgb [nto, nti, npi, 3] the stand-in f per channel, y the luminance stand-in f, p the sampling
    probability of each cell: pdf_param at the center times the cell's area)."""
    tt, pp = np.meshgrid(table.theta_i, table.phi_i, indexing="ij")
    per = [mix.slice_param(s, tt, pp) for s in range(len(mix.slices))]
    jac = table.jacobian(table.theta_i)[:, None]  # J [cos]
    area = table.dth * table.dph
    n = len(table.theta_o)
    rgb = np.zeros((n,) + tt.shape + (3,))
    y = np.zeros((n,) + tt.shape)
    p = np.zeros((n,) + tt.shape)
    for t, parts in enumerate(mix.blend()):
        for s, w in parts:
            pdf, c = per[s]
            rgb[t] += w * c
            y[t] += w * mix.slices[s]["scale"] * pdf
            p[t] += w * pdf * area
    rgb /= jac[None, :, :, None]
    y /= jac[None]
    return rgb, y, p
