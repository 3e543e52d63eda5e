#!/usr/bin/python3
"""A mixture file's stand-in and sampling density at every cell center of every table slice,
through the Python module bsdfmix (examples/README.md): include/bsdfmix/mixture.hpp's `eval_rgb`,
`eval_f` and `pdf_param`, the slices the file does not hold blended as `MixtureSet::blend`
blends them. Azimuthally symmetric tables (phi_o = 0).

Used by bench/compact_rivals.py for the mixture's sampling variance, its evaluation cost and its
table for the image study; its errors agree with `bsdfmix compare` (the script checks).
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scripts"))
import bsdfmix_import  # noqa: E402

bsdfmix = bsdfmix_import.load()


class Mixtures:
    """A mixture file (any storage) as the header's MixtureSet, read by bsdfmix's reader."""

    def __init__(self, path):
        self.set = bsdfmix.load_mixture(path)
        self.grid = self.set.grid_theta_o  # the table's theta_o axis
        self.theta_o = np.array([s.theta_o for s in self.set.slices])  # the fitted slices'


def on_table(mix, table):
    """(rgb [nto, nti, npi, 3] the stand-in f per channel, y the luminance stand-in f, p the sampling
    probability of each cell: pdf_param at the center times the cell's area)."""
    tt, pp = np.meshgrid(table.theta_i, table.phi_i, indexing="ij")
    area = table.dth * table.dph
    n = len(table.theta_o)
    rgb = np.zeros((n,) + tt.shape + (3,))
    y = np.zeros((n,) + tt.shape)
    p = np.zeros((n,) + tt.shape)
    for t, to in enumerate(table.theta_o):
        rgb[t] = mix.set.eval_rgb(to, 0.0, tt, pp)
        y[t] = mix.set.eval_f(to, 0.0, tt, pp)
        p[t] = mix.set.pdf_param(to, 0.0, tt, pp) * area
    return rgb, y, p


def at_points(mix, theta_o, theta_i, phi_i):
    """The stand-in f per channel, [N, 3], at N points (theta_o, theta_i, phi_i), phi_o = 0."""
    return mix.set.eval_rgb(theta_o, 0.0, theta_i, phi_i)
