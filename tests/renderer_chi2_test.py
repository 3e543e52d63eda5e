"""A renderer's sampling test on bsdfmix's mixtures: Mitsuba 3's chi-square test, and the pole density.

Run by ctest (renderer_chi2_test) on the fixture examples_data (tests/examples_data.cmake):
  BSDFMIX_MODULE_DIR=<build>/python BSDFMIX_EXAMPLES_DATA=<dir> BSDFMIX_CLI=<build>/bsdfmix \
    /usr/bin/python3 -m pytest -q tests/renderer_chi2_test.py
- the port itself (scripts/mitsuba_chi2.py) on exact analytic samplers: correct ones pass, wrong
  pdfs are rejected (these need no build: add `-k analytic`);
- files fitted here with `fit.map: equal_area` (docs/fitting.md, "The map"): the silk preset at
  6 x 32 x 64 (rows 1 and 4, K <= 6), the same packed to interpolate by displacement, and
  paper_white imported at 8 x 30 x 60 (rows 0, 3, 7, K <= 8): Mitsuba's test at 1,000,000
  samples for 3 fitted rows and 3 rows between (fewer when the file has fewer), all views under
  one Sidak correction;
- the pole density: pdf_omega at 1e-1 .. 1e-6 rad from each pole (hemisphere: the normal and the
  horizon; fiber: both ends of the axis), at 5 phi. The values at 1e-5 and 1e-6 rad must be finite
  and differ by under 1e-3 of the larger of the value and the view's peak (its largest sampled pdf),
  so that a finite limit passes, zero included (a cosine at the horizon), and 1/theta fails. The
  fixture's (theta, phi) file fails it: that is what the map is for.
"""
import math
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
import mitsuba_chi2  # noqa: E402
import mixture_views  # noqa: E402

DATA = pathlib.Path(os.environ.get("BSDFMIX_EXAMPLES_DATA", ROOT / "build" / "tests" / "examples"))
CLI = os.environ.get("BSDFMIX_CLI", str(ROOT / "build" / "bsdfmix"))
FILES = ["silk_equal_area.h5", "silk_equal_area_displace.h5", "paper_equal_area.h5"]
SAMPLES = 1_000_000


@pytest.mark.parametrize("case", mitsuba_chi2.analytic_cases(), ids=lambda c: c[0])
def test_analytic(case):
    name, sample, pdf, should_pass = case
    r = mitsuba_chi2.chi2_test(sample, pdf, SAMPLES, test_count=len(mitsuba_chi2.analytic_cases()))
    assert r.passed == should_pass, f"{name}: {r.summary()}"


def test_analytic_pole_row_is_where_it_fails():
    """The correct sampler uniform in (theta, phi) has a pdf growing like 1/theta at the pole, as
    bsdfmix's (theta, phi) mixtures do: the quadrature overestimates the pole row."""
    s, p = mitsuba_chi2.uniform_theta_phi(np.random.default_rng(3))
    r = mitsuba_chi2.chi2_test(s, p, SAMPLES)
    assert not r.passed and r.worst_row().row == 0 and r.rows[0].expected > 10 * r.rows[0].observed, r.summary()


class AnalyticSet:
    """A stand-in for MixtureSet with an analytic pdf per steradian, for the pole check's own check."""

    def __init__(self, domain, pdf_dirs):
        self.domain, self.pdf_dirs = domain, pdf_dirs

    def pdf_omega(self, theta_o, phi_o, theta, phi):
        t, p = np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64)
        return self.pdf_dirs(mixture_views.to_dirs(self.domain, t.ravel(), p.ravel())).reshape(t.shape)


@pytest.mark.parametrize("domain,pdf,peak,should_pass", [
    ("hemisphere", mitsuba_chi2.cosine_hemisphere(None)[1], 1 / math.pi, True),  # 0 at the horizon
    ("fiber", mitsuba_chi2.von_mises_fisher(None, (0.2, 0.1, 0.97), 30.0)[1], 30 / (2 * math.pi), True),
    ("hemisphere", mitsuba_chi2.uniform_theta_phi(None)[1], 1.0, False),  # 1 / (pi^2 sin theta)
], ids=["analytic cosine", "analytic vMF at the axis", "analytic 1/theta"])
def test_pole_check_analytic(domain, pdf, peak, should_pass):
    probe = mixture_views.pole_probe(AnalyticSet(domain, pdf), 0.0, 0.0)
    verdict = all(mixture_views.converged(v, scale=peak).all() for v in probe.values())
    assert verdict == should_pass, {k: v[0] for k, v in probe.items()}


def cli(*args):
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"`{CLI} {' '.join(map(str, args))}` failed ({r.returncode}): {r.stderr.strip()}"


def fit_rgl(work):
    """paper_white_rgb.bsdf: 8 theta_o x 30 theta_i x 60 phi_i, rows 0, 3, 7, K <= 8, on the disk."""
    table, out = work / "rgl_paper_table.h5", work / "paper_equal_area.h5"
    cli("import", "rgl", "-q", ROOT / "data" / "rgl" / "paper_white_rgb.bsdf", "--theta-o", 8, "--theta-i", 30,
        "--phi-i", 60, "-o", table)
    rows = [(i + 0.5) * math.pi / 16 for i in (0, 3, 7)]
    (work / "rgl_fit.yaml").write_text(
        f"table: {table}\nfit:\n  output: {out}\n  report: {work / 'rgl_fit.csv'}\n"
        f"  search_report: {work / 'rgl_search.csv'}\n  k_max: 8\n  seed: 1\n  map: equal_area\n  theta_o: {rows}\n")
    cli("fit", "-q", work / "rgl_fit.yaml")
    return out


def fit_silk(work):
    """The silk preset at 6 x 32 x 64, rows 1 and 4, K <= 6, on the cylinder; and packed to displace."""
    out, moved = work / "silk_equal_area.h5", work / "silk_equal_area_displace.h5"
    (work / "silk_fit.yaml").write_text(
        f"table: {work / 'silk_table.h5'}\ngenerate:\n  preset: silk\n  theta_o: 6\n  theta_i: 32\n  phi_i: 64\n"
        f"fit:\n  output: {out}\n  report: {work / 'silk_fit.csv'}\n  search_report: {work / 'silk_search.csv'}\n"
        f"  k_max: 6\n  restarts: 1\n  final_restarts: 2\n  map: equal_area\n"
        f"  theta_o: [-0.7853981633974483, 0.7853981633974483]\n")
    cli("fit", "-q", work / "silk_fit.yaml")
    cli("pack", "-q", out, "--interpolation", "displace", "-o", moved)
    return out, moved


@pytest.fixture(scope="module")
def bsdfmix():
    import bsdfmix_import
    return bsdfmix_import.load()


@pytest.fixture(scope="module")
def suite(tmp_path_factory, bsdfmix):
    """{file: (MixtureSet, views)} and the number of views tested together."""
    work = tmp_path_factory.mktemp("maps")
    silk, moved = fit_silk(work)
    paths = {"silk_equal_area.h5": silk, "silk_equal_area_displace.h5": moved, "paper_equal_area.h5": fit_rgl(work)}
    out = {}
    for f, path in paths.items():
        m = bsdfmix.load_mixture(str(path))
        assert m.map in ("disk", "cylinder"), f"{f}: map {m.map}"
        out[f] = (m, mixture_views.views(m))
    return out, sum(len(v) for _, v in out.values())


def test_theta_phi_file_diverges_at_the_pole(bsdfmix):
    """The fixture's file in (theta, phi): its pdf_omega grows like 1/theta at the fiber axis."""
    m = bsdfmix.load_mixture(str(DATA / "mixture.h5"))
    assert m.map == "theta_phi"
    theta_o, phi_o, _ = mixture_views.views(m)[0]
    _, _, pdf, valid = m.sample_counter(theta_o, phi_o, 100_000, seed=2)
    peak = float(np.max(np.where(valid, pdf, 0.0)))
    probe = mixture_views.pole_probe(m, theta_o, phi_o)
    assert not all(mixture_views.converged(v, scale=peak).all() for v in probe.values())


def view_line(f, theta_o, kind, r):
    return f"{f} theta_o {round(math.degrees(theta_o), 1) + 0.0:6.1f} deg ({kind}): {r.summary()}"


@pytest.mark.parametrize("name", FILES)
def test_mitsuba_chi2(suite, name):
    files, test_count = suite
    m, views = files[name]
    lines, failed = [], 0
    for theta_o, phi_o, kind in views:
        r = mitsuba_chi2.chi2_test(mixture_views.sampler(m, theta_o, phi_o), mixture_views.density(m, theta_o, phi_o),
                                   SAMPLES, test_count=test_count)
        failed += not r.passed
        lines.append(view_line(name, theta_o, kind, r))
    print("\n".join(lines))
    assert failed == 0, f"{failed} of {len(views)} views rejected (Sidak over {test_count}):\n" + "\n".join(lines)


@pytest.mark.parametrize("name", FILES)
def test_pole_density_converges(suite, name):
    files, _ = suite
    m, views = files[name]
    theta_o, phi_o, _ = views[0]
    _, _, pdf, valid = m.sample_counter(theta_o, phi_o, 100_000, seed=2)
    peak = float(np.max(np.where(valid, pdf, 0.0)))
    bad = []
    for place, values in mixture_views.pole_probe(m, theta_o, phi_o).items():
        ok = mixture_views.converged(values, scale=peak)
        if not ok.all():
            bad.append(f"{place}: pdf_omega at 1e-1 .. 1e-6 rad, one row per phi:\n"
                       + np.array2string(values[~ok], precision=4, max_line_width=200))
    assert not bad, (f"{name} theta_o {math.degrees(theta_o):.1f} deg: pdf_omega does not converge at the pole "
                     f"(peak pdf {peak:.3g}):\n" + "\n".join(bad))
