"""Mitsuba 3's chi-square sampling test on the sphere, ported to numpy + scipy.

Reproduces `ChiSquareTest` with `SphericalDomain` of Mitsuba 3 (src/python/python/chi2.py,
and `chi2()` of its include/mitsuba/core/math.h), the test a renderer runs on a BSDF's
sampler. No Mitsuba code is used.

    import mitsuba_chi2
    r = mitsuba_chi2.chi2_test(sample_dirs, pdf_dirs, test_count=6)
    r.passed, r.p_value, r.reason, r.worst_row()

- sample_dirs(n) returns n unit directions [n, 3], or (directions, weights): weight 0 marks
  an invalid sample, which is not counted (Mitsuba's BSDF adapter gives it weight 0).
- pdf_dirs(v) returns the density per steradian at directions v [m, 3].

The domain: x = phi in [-pi, pi], y in [-1, 1]; a point maps to the direction with
cos(theta) = -y and azimuth x, and a direction v back to (atan2(v.y, v.x), -v.z). The
histogram has int(res / 2) columns (phi) and res rows (y). Row 0 holds the pole z = +1,
row res - 1 the pole z = -1. Each cell's expected count is the trapezoid rule over
ires x ires nodes of the pdf. Cells are sorted by expected count; cells expecting under 5
are pooled. p = 1 - P(dof / 2, chi2 / 2). With test_count views tested together, the
level is Sidak's 1 - (1 - 0.01)^(1 / test_count).

Mitsuba's 4 x 4 trapezoid nodes per cell bias sharp lobes: a correct von Mises-Fisher lobe of
kappa 80 centred on a pole integrates to 1.023 and is rejected; kappa 40 passes.

Run alone, it checks itself on analytic samplers (no bsdfmix needed):
    /usr/bin/python3 scripts/mitsuba_chi2.py
"""
import dataclasses
import math
import sys

import numpy as np
from scipy.special import gammaincc

BOUNDS_MIN = np.array([-math.pi, -1.0])
BOUNDS_MAX = np.array([math.pi, 1.0])
POOL_THRESHOLD = 5.0


def map_forward(x, y):
    """Mitsuba's SphericalDomain.map_forward: (phi, -cos theta) -> unit directions [n, 3]."""
    cos_t = -np.asarray(y, dtype=np.float64)
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    x = np.asarray(x, dtype=np.float64)
    return np.stack([np.cos(x) * sin_t, np.sin(x) * sin_t, cos_t], axis=-1)


def map_backward(v):
    """Mitsuba's SphericalDomain.map_backward: directions [n, 3] -> (phi, -cos theta) [n, 2]."""
    v = np.asarray(v, dtype=np.float64)
    return np.stack([np.arctan2(v[:, 1], v[:, 0]), -v[:, 2]], axis=-1)


def grid_shape(res=101):
    """(columns, rows) of the histogram: Mitsuba's (int(res / aspect), res), aspect 2."""
    return max(int(res / 2), 1), max(int(res), 1)


def histogram(dirs, weights, res=101):
    """Weighted counts [rows, columns] of directions binned as Mitsuba bins them.

    Returns (counts, outside): outside is the number of weighted samples that fall outside
    the domain by more than 1e-4 of its extent, or are not finite (Mitsuba then fails)."""
    nx, ny = grid_shape(res)
    res_v = np.array([nx, ny], dtype=np.float64)
    extents = BOUNDS_MAX - BOUNDS_MIN
    xy = map_backward(dirs)
    counted = weights != 0
    eps = extents * 1e-4
    inside = np.all(np.isfinite(xy) & (xy >= BOUNDS_MIN - eps) & (xy <= BOUNDS_MAX + eps), axis=1)
    outside = int(np.count_nonzero(counted & ~inside))
    keep = counted & np.all(np.isfinite(xy), axis=1)
    cell = np.clip((xy[keep] - BOUNDS_MIN) / extents * res_v, 0.0, res_v - 1).astype(np.int64)
    flat = cell[:, 0] + cell[:, 1] * nx
    counts = np.bincount(flat, weights=weights[keep], minlength=nx * ny)
    return counts.reshape(ny, nx), outside


def node_grid(res=101, ires=4):
    """Mitsuba's integration nodes: positions [rows, columns, ires, ires, 2] and weights [ires, ires].

    Node i of a cell lies at min + cell * size + (i + 1e-4)(1 - 2e-4) size / (ires - 1);
    weights are the trapezoid rule's (1/2 at the first and last node), times spacing^2."""
    nx, ny = grid_shape(res)
    size = (BOUNDS_MAX - BOUNDS_MIN) / np.array([nx, ny])
    spacing = size / (ires - 1)
    offs = (np.arange(ires) + 1e-4) * (1 - 2e-4)
    xs = BOUNDS_MIN[0] + np.arange(nx)[:, None] * size[0] + offs[None, :] * spacing[0]  # [nx, ires]
    ys = BOUNDS_MIN[1] + np.arange(ny)[:, None] * size[1] + offs[None, :] * spacing[1]  # [ny, ires]
    px = np.broadcast_to(xs[None, :, None, :], (ny, nx, ires, ires))  # [.., node y, node x]
    py = np.broadcast_to(ys[:, None, :, None], (ny, nx, ires, ires))
    w1 = np.ones(ires)
    w1[0] = w1[-1] = 0.5
    weights = np.outer(w1, w1) * spacing[0] * spacing[1]
    return np.stack([px, py], axis=-1), weights


def expected_counts(pdf_dirs, sample_count, res=101, ires=4):
    """Expected count per cell [rows, columns]: the trapezoid rule of pdf_dirs, times sample_count."""
    nodes, weights = node_grid(res, ires)
    shape = nodes.shape[:-1]
    flat = nodes.reshape(-1, 2)
    pdf = np.asarray(pdf_dirs(map_forward(flat[:, 0], flat[:, 1])), dtype=np.float64).reshape(shape)
    return np.sum(pdf * weights, axis=(2, 3)) * sample_count


def chi2_pooled(obs, exp, pool_threshold=POOL_THRESHOLD):
    """Mitsuba's chi2(): cells in the given order (ascending expected count).

    Returns (chi2, dof, pooled_in, pooled_out). Cells with exp == obs == 0 are skipped;
    cells expecting under the threshold are pooled until the pool expects more than it."""
    chsq = 0.0
    pooled_obs = pooled_exp = 0.0
    pooled_in = pooled_out = dof = 0
    for o, e in zip(obs.tolist(), exp.tolist()):
        if e == 0 and o == 0:
            continue
        if e < pool_threshold:
            pooled_obs += o
            pooled_exp += e
            pooled_in += 1
            if pooled_exp > pool_threshold:
                chsq += (pooled_obs - pooled_exp) ** 2 / pooled_exp
                pooled_obs = pooled_exp = 0.0
                pooled_out += 1
                dof += 1
        else:
            chsq += (o - e) ** 2 / e
            dof += 1
    return chsq, dof - 1, pooled_in, pooled_out


@dataclasses.dataclass
class RowStat:
    """One histogram row: y in [y_lo, y_hi], i.e. cos(theta) = -y with theta from the +z pole."""
    row: int
    cos_theta: float  # of the row center
    observed: float
    expected: float
    z: float  # (observed - expected) / sqrt(max(expected, 1)) of the whole row
    worst_column: int  # the cell of this row with the largest (obs - exp)^2 / max(exp, 1)
    worst_observed: float
    worst_expected: float

    @property
    def ratio(self):
        """expected / observed of the row (inf when nothing was observed)."""
        return self.expected / self.observed if self.observed > 0 else math.inf

    @property
    def theta_deg(self):
        """Polar angle of the row center from +z, degrees."""
        return math.degrees(math.acos(max(-1.0, min(1.0, self.cos_theta))))


@dataclasses.dataclass
class Chi2Result:
    passed: bool
    p_value: float
    alpha: float
    chi2: float
    dof: int
    hist_sum: float
    pdf_sum: float
    pooled_in: int
    pooled_out: int
    reason: str  # "" when passed; else why it failed or was rejected
    observed: np.ndarray  # [rows, columns]
    expected: np.ndarray  # [rows, columns]
    rows: list  # RowStat per row

    def worst_row(self):
        """The row whose observed total is furthest from its expected total, in standard deviations."""
        return max(self.rows, key=lambda r: abs(r.z))

    def summary(self):
        w = self.worst_row()
        verdict = "pass" if self.passed else f"REJECT ({self.reason})"
        return (f"{verdict}: p={self.p_value:.3g} alpha={self.alpha:.3g} chi2={self.chi2:.1f} dof={self.dof} "
                f"hist_sum={self.hist_sum:.4f} pdf_sum={self.pdf_sum:.4f}; worst row {w.row} "
                f"(theta {w.theta_deg:.2f} deg from +z) expected/observed {w.expected:.0f}/{w.observed:.0f}")


def row_stats(obs, exp, res):
    ny = obs.shape[0]
    out = []
    for j in range(ny):
        o, e = obs[j], exp[j]
        so, se = float(o.sum()), float(e.sum())
        z = (so - se) / math.sqrt(max(se, 1.0))
        score = (o - e) ** 2 / np.maximum(e, 1.0)
        c = int(np.argmax(score))
        y_center = -1.0 + (j + 0.5) * 2.0 / ny
        out.append(RowStat(j, -y_center, so, se, z, c, float(o[c]), float(e[c])))
    return out


def chi2_test(sample_dirs, pdf_dirs, sample_count=1_000_000, res=101, ires=4, significance=0.01, test_count=1):
    """Mitsuba's ChiSquareTest(SphericalDomain()).run(significance, test_count), as a Chi2Result."""
    out = sample_dirs(sample_count)
    dirs, weights = out if isinstance(out, tuple) else (out, np.ones(sample_count))
    dirs = np.asarray(dirs, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    if dirs.shape != (sample_count, 3) or weights.shape != (sample_count,):
        raise ValueError(f"mitsuba_chi2: sample_dirs({sample_count}) gave shapes {dirs.shape}, {weights.shape}; "
                         f"expected ({sample_count}, 3), ({sample_count},)")
    reasons = []
    obs, outside = histogram(dirs, weights, res)
    if outside:
        reasons.append(f"{outside} samples outside the domain")
    if not obs.min() >= 0:
        reasons.append(f"a cell with negative sample weights {obs.min()}")
    hist_sum = float(obs.sum()) / sample_count
    if hist_sum > 1.1:
        reasons.append(f"sample weights add up to {hist_sum:.4f} > 1.1")
    exp = expected_counts(pdf_dirs, sample_count, res, ires)
    pdf_min = float(exp.min()) / sample_count
    if not pdf_min >= 0:
        reasons.append(f"a cell with negative pdf {pdf_min}")
    pdf_sum = float(exp.sum()) / sample_count
    if pdf_sum > 1.1:
        reasons.append(f"pdf integrates to {pdf_sum:.4f} > 1.1")
    order = np.argsort(exp.ravel(), kind="stable")
    o_sorted, e_sorted = obs.ravel()[order], exp.ravel()[order]
    chsq, dof, pooled_in, pooled_out = chi2_pooled(o_sorted, e_sorted)
    if dof < 1:
        reasons.append(f"dof {dof} < 1")
    stray = int(np.count_nonzero((e_sorted == 0) & (o_sorted != 0)))
    if stray:
        reasons.append(f"{stray} cells with samples where the pdf is 0")
    p = float(gammaincc(dof / 2, chsq / 2)) if dof >= 1 else math.nan
    alpha = 1.0 - (1.0 - significance) ** (1.0 / test_count)
    if not reasons and (not math.isfinite(p) or p < alpha):
        reasons.append(f"p-value {p:.3g} < {alpha:.3g}")
    return Chi2Result(not reasons, p, alpha, chsq, dof, hist_sum, pdf_sum, pooled_in, pooled_out, "; ".join(reasons),
                      obs, exp, row_stats(obs, exp, res))


def p_value_without_rows(result, rows, expected=None):
    """Diagnosis, not part of Mitsuba's test: the p-value of the same counts with the given rows
    left out (e.g. the pole rows 0 and res - 1), pooled and sorted as Mitsuba does. expected
    replaces the result's expected counts (e.g. expected_counts(..., ires=16), a finer quadrature)."""
    expected = result.expected if expected is None else expected
    keep = np.ones(result.observed.shape[0], dtype=bool)
    keep[list(rows)] = False
    o, e = result.observed[keep].ravel(), expected[keep].ravel()
    order = np.argsort(e, kind="stable")
    chsq, dof, _, _ = chi2_pooled(o[order], e[order])
    return float(gammaincc(dof / 2, chsq / 2)) if dof >= 1 else math.nan


# --- analytic samplers (exact), for the self-check ---------------------------------------

def cosine_hemisphere(rng):
    """Cosine-weighted hemisphere around +z: (sample_dirs, pdf_dirs)."""
    def sample(n):
        u1, u2 = rng.random(n), rng.random(n)
        r, phi = np.sqrt(u1), 2 * math.pi * u2
        return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u1)], axis=-1)
    return sample, lambda v: np.maximum(v[:, 2], 0.0) / math.pi


def _frame(mu):
    mu = np.asarray(mu, dtype=np.float64) / np.linalg.norm(mu)
    a = np.array([1.0, 0.0, 0.0]) if abs(mu[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(mu, a)
    t /= np.linalg.norm(t)
    return t, np.cross(mu, t), mu


def von_mises_fisher(rng, mu, kappa):
    """von Mises-Fisher lobe of concentration kappa around mu: (sample_dirs, pdf_dirs)."""
    t, b, m = _frame(mu)
    norm = kappa / (2 * math.pi * -math.expm1(-2 * kappa))

    def sample(n):
        u1, u2 = rng.random(n), rng.random(n)
        w = 1 + np.log(u1 + (1 - u1) * math.exp(-2 * kappa)) / kappa
        s, phi = np.sqrt(np.maximum(1 - w * w, 0.0)), 2 * math.pi * u2
        return (s * np.cos(phi))[:, None] * t + (s * np.sin(phi))[:, None] * b + w[:, None] * m
    return sample, lambda v: norm * np.exp(kappa * (v @ m - 1))


def uniform_theta_phi(rng):
    """Uniform in (theta, phi) over the hemisphere: correct, with pdf 1 / (pi^2 sin theta), unbounded at the pole."""
    def sample(n):
        th, ph = rng.random(n) * math.pi / 2, (rng.random(n) * 2 - 1) * math.pi
        return np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)

    def pdf(v):
        s = np.sqrt(np.maximum(1 - v[:, 2] ** 2, 0.0))
        with np.errstate(divide="ignore"):
            return np.where(v[:, 2] > 0, 1 / (math.pi ** 2 * s), 0.0)
    return sample, pdf


def wrong_half(pdf, factor=1.05):
    """pdf times factor where x > 0: a wrong pdf for the same sampler."""
    return lambda v: pdf(v) * np.where(v[:, 0] > 0, factor, 1.0)


def analytic_cases(seed=1):
    """(name, sample_dirs, pdf_dirs, should_pass) of the self-check; each sampler has its own stream.

    The last case is a correct sampler that Mitsuba's test rejects: its pdf per steradian grows like
    1/theta at the pole, as a mixture in (theta, phi) does, and the pole row's quadrature nodes
    (1e-4 of a node spacing from the pole) overestimate that row."""
    def rng(i):
        return np.random.default_rng([seed, i])
    vmf = (0.3, -0.5, 0.6), 12.0
    return [
        ("cosine hemisphere", *cosine_hemisphere(rng(0)), True),
        ("vMF lobe kappa 12", *von_mises_fisher(rng(1), *vmf), True),
        ("vMF lobe kappa 20 at the +z pole", *von_mises_fisher(rng(2), (0.0, 0.0, 1.0), 20.0), True),
        ("vMF lobe, pdf x1.05 where x > 0", von_mises_fisher(rng(3), *vmf)[0],
         wrong_half(von_mises_fisher(None, *vmf)[1]), False),
        ("cosine sampler, uniform-hemisphere pdf", cosine_hemisphere(rng(4))[0],
         lambda v: np.where(v[:, 2] > 0, 1 / (2 * math.pi), 0.0), False),
        ("uniform in (theta, phi), its own pdf (unbounded at the pole)", *uniform_theta_phi(rng(5)), False),
    ]


def main():
    cases = analytic_cases()
    bad = 0
    for name, s, p, should in cases:
        r = chi2_test(s, p, test_count=len(cases))
        ok = r.passed == should
        bad += not ok
        print(f"{'ok  ' if ok else 'FAIL'} {name}: {r.summary()}")
    if bad:
        sys.exit(f"mitsuba_chi2: {bad} of {len(cases)} analytic cases gave the wrong verdict")


if __name__ == "__main__":
    main()
