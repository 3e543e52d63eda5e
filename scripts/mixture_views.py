"""A bsdfmix mixture file seen as a renderer sees it: unit directions on Mitsuba's sphere.

Used by tests/renderer_chi2_test.py and bench/renderer_chi2.py with scripts/mitsuba_chi2.py.
Only the Python module's public calls are used: MixtureSet.sample_counter and pdf_omega.

Directions (docs/formats.md, "Angular conventions"):
- hemisphere: theta is the polar angle from the normal z: v = (sin t cos p, sin t sin p, cos t);
  the pdf is 0 below the surface (z < 0);
- fiber: theta is the longitudinal angle, sin(theta) = dot(v, axis), the axis is z:
  v = (cos t cos p, cos t sin p, sin t). Mitsuba's pole rows are then the fiber axis.
"""
import math

import numpy as np


def domain_name(mixture):
    """'hemisphere' or 'fiber' of a MixtureSet (its domain attribute, as text)."""
    d = str(mixture.domain).lower()
    for name in ("hemisphere", "fiber"):
        if name in d:
            return name
    raise ValueError(f"mixture_views: unknown domain {mixture.domain!r}")


def to_dirs(domain, theta, phi):
    """(theta, phi) of the domain -> unit directions [n, 3]."""
    theta, phi = np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64)
    if domain == "hemisphere":
        s, z = np.sin(theta), np.cos(theta)
    else:
        s, z = np.cos(theta), np.sin(theta)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=-1)


def from_dirs(domain, v):
    """Unit directions [n, 3] -> (theta, phi, inside): inside is False below a hemisphere."""
    z = np.clip(v[:, 2], -1.0, 1.0)
    phi = np.arctan2(v[:, 1], v[:, 0])
    if domain == "hemisphere":
        return np.arccos(z), phi, z >= 0
    return np.arcsin(z), phi, np.ones(len(z), dtype=bool)


def sampler(mixture, theta_o, phi_o, seed=1):
    """sample_dirs(n) of mitsuba_chi2.chi2_test: the mixture's samples, weight 0 when invalid."""
    domain = domain_name(mixture)

    def sample(n):
        theta, phi, _, valid = mixture.sample_counter(theta_o, phi_o, n, seed=seed)
        return to_dirs(domain, theta, phi), np.asarray(valid, dtype=np.float64)
    return sample


def density(mixture, theta_o, phi_o):
    """pdf_dirs(v) of mitsuba_chi2.chi2_test: the mixture's pdf_omega, 0 outside the domain."""
    domain = domain_name(mixture)

    def pdf(v):
        theta, phi, inside = from_dirs(domain, v)
        out = np.zeros(len(theta))
        out[inside] = mixture.pdf_omega(theta_o, phi_o, theta[inside], phi[inside])
        return out
    return pdf


def _spread(values, count=3):
    """first, middle and last of values (fewer when there are fewer), in order."""
    if len(values) <= count:
        return list(values)
    idx = sorted({0, (len(values) - 1) // 2, len(values) - 1})
    return [values[i] for i in idx]


def views(mixture, count=3):
    """[(theta_o, phi_o, 'fitted' | 'between')]: count fitted rows (the most normal, the middle,
    the most grazing) and count midpoints between grid rows, ordered by |theta_o|."""
    grid_t = list(mixture.grid_theta_o)
    grid_p = list(mixture.grid_phi_o)
    slice_of = np.asarray(mixture.slice_of).reshape(len(grid_t), len(grid_p))
    rows = [i for i in range(len(grid_t)) if np.any(slice_of[i] >= 0)]
    if not rows:
        raise ValueError("mixture_views: the mixture has no fitted slice")
    col = int(np.argmax(slice_of[rows[0]] >= 0))
    phi_o = 0.0 if mixture.azimuthal else float(grid_p[col])
    fitted = sorted((grid_t[i] for i in rows), key=abs)
    between = sorted(((a + b) / 2 for a, b in zip(grid_t, grid_t[1:])), key=abs)
    out = [(float(t), phi_o, "fitted") for t in _spread(fitted, count)]
    return out + [(float(t), phi_o, "between") for t in _spread(between, count)]


def pole_probe(mixture, theta_o, phi_o, phis=(-2.6, -1.0, 0.3, 1.7, 3.0), exponents=range(1, 7)):
    """pdf_omega at 10^-k rad from each pole (hemisphere: the normal and the horizon; fiber: both
    ends of the axis), at a few phi: {place: array [len(phis), len(exponents)]}."""
    domain = domain_name(mixture)
    eps = np.array([10.0 ** -k for k in exponents])
    if domain == "hemisphere":
        places = {"normal (theta_i -> 0)": eps, "horizon (theta_i -> pi/2)": math.pi / 2 - eps}
    else:
        places = {"axis (theta -> +pi/2)": math.pi / 2 - eps, "axis (theta -> -pi/2)": -math.pi / 2 + eps}
    out = {}
    for name, thetas in places.items():
        t, p = np.meshgrid(thetas, np.asarray(phis, dtype=np.float64))
        out[name] = np.asarray(mixture.pdf_omega(theta_o, phi_o, t, p), dtype=np.float64)
    return out


def converged(values, scale=0.0, tol=1e-3):
    """True where the last two columns (1e-5 and 1e-6 rad) are finite and differ by less than tol,
    relative to the larger of |value at 1e-5| and scale. With scale the view's peak pdf, a density
    growing like 1/theta fails unless negligible (under 1e-9 of the peak at 1 rad), while a density
    with a finite limit passes, a zero limit (the cosine at the horizon) included."""
    a, b = values[:, -2], values[:, -1]
    ref = np.maximum(np.abs(a), scale)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(ref > 0, np.abs(b - a) / ref, 0.0)
    return np.isfinite(a) & np.isfinite(b) & (rel < tol)
