"""A renderer's sampling test on bsdfmix's mixtures: Mitsuba 3's chi-square test, and the pole density.

Run by ctest (renderer_chi2_test) on the fixture examples_data (tests/examples_data.cmake):
  BSDFMIX_MODULE_DIR=<build>/python BSDFMIX_EXAMPLES_DATA=<dir> BSDFMIX_CLI=<build>/bsdfmix \
    /usr/bin/python3 -m pytest -q tests/renderer_chi2_test.py
- the port itself (scripts/mitsuba_chi2.py) on exact analytic samplers: correct ones pass, wrong
  pdfs are rejected (these need no build: add `-k analytic`);
- every mixture file of the fixture, and a small RGL fit made here with the CLI (import at
  8 x 30 x 60, 3 theta_o rows, K <= 8): Mitsuba's test at 1,000,000 samples for 3 fitted rows and
  3 rows between (fewer when the file has fewer), all views under one Sidak correction;
- the pole density: pdf_omega at 1e-1 .. 1e-6 rad from each pole (hemisphere: the normal and the
  horizon; fiber: both ends of the axis), at 5 phi. The values at 1e-5 and 1e-6 rad must be finite
  and differ by under 1e-3 of the larger of the value and the view's peak (its largest sampled pdf),
  so that a finite limit passes, zero included (a cosine at the horizon), and 1/theta fails.
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
FIXTURE_FILES = ["mixture.h5", "mixture_ragged.h5", "mixture_displace.h5"]
RGL_FILE = "rgl_paper_small.h5"
FILES = FIXTURE_FILES + [RGL_FILE]
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
    """A small fit of data/rgl/paper_white_rgb.bsdf: 8 theta_o x 30 theta_i x 60 phi_i, rows 0, 3, 7, K <= 8."""
    table, out = work / "rgl_paper_table.h5", work / RGL_FILE
    cli("import", "rgl", "-q", ROOT / "data" / "rgl" / "paper_white_rgb.bsdf", "--theta-o", 8, "--theta-i", 30,
        "--phi-i", 60, "-o", table)
    rows = [(i + 0.5) * math.pi / 16 for i in (0, 3, 7)]
    (work / "rgl_fit.yaml").write_text(
        f"table: {table}\nfit:\n  output: {out}\n  report: {work / 'rgl_fit.csv'}\n"
        f"  search_report: {work / 'rgl_search.csv'}\n  k_max: 8\n  seed: 1\n  theta_o: {rows}\n")
    cli("fit", "-q", work / "rgl_fit.yaml")
    return out


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    """{file: (MixtureSet, views)} and the number of views tested together."""
    import bsdfmix_import
    bsdfmix = bsdfmix_import.load()
    paths = {f: DATA / f for f in FIXTURE_FILES}
    paths[RGL_FILE] = fit_rgl(tmp_path_factory.mktemp("rgl"))
    out = {}
    for f, path in paths.items():
        m = bsdfmix.load_mixture(str(path))
        out[f] = (m, mixture_views.views(m))
    return out, sum(len(v) for _, v in out.values())


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
