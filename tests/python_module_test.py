"""The Python module `bsdfmix` (python/) against bsdfmix's C++ results, to float rounding.

Run by ctest (python_module_test) on the fixture examples_data (tests/examples_data.cmake):
  BSDFMIX_MODULE_DIR=<build>/python BSDFMIX_EXAMPLES_DATA=<dir> /usr/bin/python3 -m pytest tests/python_module_test.py
- the samples of `bsdfmix sample --cpu` (same seed and stream) and their pdf;
- every figure of `bsdfmix compare` (l1_rel, energy, per channel) from the module's eval_f,
  eval_rgb, Table and integrand_weights, on the padded and the ragged float32 file;
- the blend, the blended mixture and the product against the set's own pdf; the earned share;
- a file interpolated by displacement: its samples and figures as above, and at() as its pdf;
- tables read as h5py reads them; errors raised as Python exceptions.
"""
import csv
import math
import os
import pathlib
import sys

import h5py
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
import bsdfmix_import  # noqa: E402

bsdfmix = bsdfmix_import.load()
DATA = pathlib.Path(os.environ.get("BSDFMIX_EXAMPLES_DATA", ROOT / "build" / "tests" / "examples"))
FILES = [("mixture.h5", "compare.csv"), ("mixture_ragged.h5", "compare_ragged.csv"),
         ("mixture_displace.h5", "compare_displace.csv")]


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def table():
    return bsdfmix.Table(str(DATA / "table.h5"))


@pytest.mark.parametrize("mixture,samples", [("mixture.h5", "samples.csv"), ("mixture_displace.h5", "samples_displace.csv")])
def test_samples_match_the_cli(mixture, samples):
    m = bsdfmix.load_mixture(str(DATA / mixture))
    theta, phi, pdf, valid = m.sample_counter(0.3, 1.1, 2000, seed=7)
    ref = rows(DATA / samples)
    assert len(ref) == 2000
    r_theta = np.array([float(r["theta"]) for r in ref])
    r_phi = np.array([float(r["phi"]) for r in ref])
    r_pdf = np.array([float(r["pdf_omega"]) for r in ref])
    r_valid = np.array([r["valid"] == "1" for r in ref])
    # the CLI prints 9 significant digits
    np.testing.assert_array_equal(valid, r_valid)
    np.testing.assert_allclose(theta, r_theta, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(phi, r_phi, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(np.where(valid, pdf, 0.0), r_pdf, rtol=1e-8)
    # the pdf at the printed directions (rounded to 9 digits: the pdf moves by less than 1e-6)
    np.testing.assert_allclose(m.pdf_omega(0.3, 1.1, r_theta[r_valid], r_phi[r_valid]), r_pdf[r_valid], rtol=1e-6)
    # the same samples from the uniforms of the stream
    u = bsdfmix.uniforms(7, bsdfmix.SAMPLE_STREAM, 2000)
    t2, p2, d2, v2 = m.sample(0.3, 1.1, u)
    np.testing.assert_array_equal(t2, theta)
    np.testing.assert_array_equal(p2, phi)
    np.testing.assert_array_equal(d2, pdf)
    np.testing.assert_array_equal(v2, valid)


@pytest.mark.parametrize("mixture,compare", FILES)
def test_compare_figures(table, mixture, compare):
    m = bsdfmix.load_mixture(str(DATA / mixture))
    ref = rows(DATA / compare)
    assert table.domain == m.domain and len(ref) == len(table.theta_o) * len(table.phi_o)
    g = bsdfmix.integrand_weights(table.domain, table.theta_i, table.phi_i)
    tt, pp = np.meshgrid(table.theta_i, table.phi_i, indexing="ij")
    for r in ref:
        s = int(r["slice"])
        t, p = divmod(s, len(table.phi_o))
        to, po = table.theta_o[t], table.phi_o[p]
        assert math.isclose(float(r["theta_o"]), to, rel_tol=1e-5)
        f = table.slice(t, p).astype(np.float64)
        fhat = m.eval_f(to, po, tt, pp)
        assert fhat.shape == f.shape
        l1 = np.sum(g * np.abs(fhat - f)) / np.sum(g * np.abs(f))
        energy = np.sum(g * fhat) / np.sum(g * f) - 1
        # the CSV holds 6 significant digits
        assert l1 == pytest.approx(float(r["l1_rel"]), rel=1e-5, abs=1e-9)
        assert energy == pytest.approx(float(r["energy"]), rel=1e-5, abs=1e-9)
        rgb = table.slice_rgb(t, p).astype(np.float64)
        ch = m.eval_rgb(to, po, tt, pp)
        assert ch.shape == rgb.shape
        for q, name in enumerate("rgb"):
            tot = np.sum(g * np.abs(rgb[..., q]))
            assert np.sum(g * np.abs(ch[..., q] - rgb[..., q])) / tot == pytest.approx(float(r["l1_" + name]), rel=1e-5, abs=1e-9)
            assert np.sum(g * (ch[..., q] - rgb[..., q])) / tot == pytest.approx(float(r["energy_" + name]), rel=1e-5, abs=1e-9)


def test_ragged_is_the_padded_file():
    a = bsdfmix.load_mixture(str(DATA / "mixture.h5"))
    b = bsdfmix.load_mixture(str(DATA / "mixture_ragged.h5"))
    info = bsdfmix.mixture_info(str(DATA / "mixture_ragged.h5"))
    assert info["storage"] == "ragged_f32" and bsdfmix.mixture_info(str(DATA / "mixture.h5"))["storage"] == "padded"
    assert len(a) == len(b) == 2 and list(info["k"]) == [len(s) for s in b.slices]
    th, ph = np.meshgrid(np.linspace(-1.5, 1.5, 31), np.linspace(-3.1, 3.1, 33), indexing="ij")
    for to in (-1.2, -0.3, 0.0, 0.3, 1.2):
        np.testing.assert_array_equal(a.pdf_omega(to, 0.4, th, ph), b.pdf_omega(to, 0.4, th, ph))
        np.testing.assert_allclose(a.eval_rgb(to, 0.4, th, ph), b.eval_rgb(to, 0.4, th, ph), rtol=1e-6, atol=1e-12)


def test_slices_and_blend():
    m = bsdfmix.load_mixture(str(DATA / "mixture.h5"))
    assert m.domain == bsdfmix.Domain.fiber and m.azimuthal
    assert list(m.slice_of) == [-1, 0, -1, -1, 1, -1]
    grid = m.grid_theta_o
    slices, weights, rotate = m.blend(grid[2], 0.7)
    assert slices == [0, 1] and weights == pytest.approx([2 / 3, 1 / 3]) and rotate == 0.7
    # a set rebuilt from the slices' arrays evaluates as the file's
    rebuilt = bsdfmix.MixtureSet("fiber", True, grid, m.grid_phi_o, [
        bsdfmix.SliceMixture(s.weights, s.means, s.covariances, s.scale, rgb=s.rgb, theta_o=s.theta_o, phi_o=s.phi_o,
                             map=s.map)
        for s in m.slices], map=m.map)
    th, ph = np.meshgrid(np.linspace(-1.5, 1.5, 17), np.linspace(-3.1, 3.1, 19), indexing="ij")
    if not any(s.has_copies for s in m.slices):
        np.testing.assert_allclose(rebuilt.eval_rgb(0.1, 0.2, th, ph), m.eval_rgb(0.1, 0.2, th, ph), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(rebuilt.eval_f(0.1, 0.2, th, ph), m.eval_f(0.1, 0.2, th, ph), rtol=1e-12, atol=1e-300)
    # the blended mixture is the set's pdf and stand-in at that omega_o
    b = m.blended(0.1, 0.2)
    np.testing.assert_allclose(b.pdf_param(th, ph), m.pdf_param(0.1, 0.2, th, ph), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(b.pdf_omega("fiber", th, ph), m.pdf_omega(0.1, 0.2, th, ph), rtol=1e-12, atol=1e-300)
    jac = bsdfmix.jacobian("fiber", th)
    np.testing.assert_allclose(b.eval_rgb_param(th, ph) / jac[..., None], m.eval_rgb(0.1, 0.2, th, ph),
                               rtol=1e-12, atol=1e-300)
    # its luminance stand-in has one scale, the blended one: eval_f's to the slices' difference
    np.testing.assert_allclose(b.eval_param(th, ph) / jac, m.eval_f(0.1, 0.2, th, ph), rtol=2e-3)
    # the earned uniform share: the file's per slice, blended with the blend weights
    info = bsdfmix.mixture_info(str(DATA / "mixture.h5"))
    assert [s.defensive for s in m.slices] == list(info["defensive"])
    assert all(0 <= s.defensive <= 0.1 for s in m.slices)
    assert m.defensive(grid[2], 0.7) == pytest.approx(sum(w * m.slices[i].defensive for i, w in zip(slices, weights)))
    old = bsdfmix.load_mixture(str(ROOT / "tests" / "data" / "mixture_before_rgb.h5"))  # written before the share
    assert all(s.defensive == 0.1 for s in old.slices) and old.defensive(old.grid_theta_o[0], 0.0) == pytest.approx(0.1)


def test_displacement():
    blend = bsdfmix.load_mixture(str(DATA / "mixture.h5"))
    moved = bsdfmix.load_mixture(str(DATA / "mixture_displace.h5"))
    assert blend.interpolation == "blend" and moved.interpolation == "displace"
    th, ph = np.meshgrid(np.linspace(-1.5, 1.5, 17), np.linspace(-3.1, 3.1, 19), indexing="ij")
    grid = moved.grid_theta_o
    # at a fitted slice both are the slice; between them at() is the set's pdf and stand-in
    at_slice = blend.pdf_param(grid[1], 0.4, th, ph)
    np.testing.assert_allclose(moved.pdf_param(grid[1], 0.4, th, ph), at_slice, rtol=1e-12, atol=1e-12 * at_slice.max())
    a = moved.at(grid[2], 0.4)
    np.testing.assert_allclose(a.pdf_param(th, ph), moved.pdf_param(grid[2], 0.4, th, ph), rtol=1e-12, atol=1e-300)
    jac = bsdfmix.jacobian("fiber", th)
    np.testing.assert_allclose(a.eval_param(th, ph) / jac, moved.eval_f(grid[2], 0.4, th, ph), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(blend.at(grid[2], 0.4).pdf_param(th, ph), blend.blended(grid[2], 0.4).pdf_param(th, ph))


def test_product_with_lighting():
    m = bsdfmix.load_mixture(str(DATA / "mixture.h5"))
    light = bsdfmix.SliceMixture([0.6, 0.4], [[0.2, 1.0], [-0.5, -2.0]], [[0.3, 0.05, 0.8], [0.1, 0.0, 2.0]], map=m.map)
    b = m.blended(0.1, 0.2)
    p, mass, kept = m.product_with(0.1, 0.2, light, keep=1.0, max_components=100000)
    q, mass2, kept2 = bsdfmix.product(b, 0.0, light, keep=1.0, max_components=100000)
    assert kept == kept2 == pytest.approx(1.0) and mass == mass2 > 0
    x, y = np.meshgrid(np.linspace(-0.99, 0.99, 23), np.linspace(-3.1, 3.1, 29), indexing="ij")
    # unpruned, the product is a * b / mass in the map's plane, to rounding (images within 9 sigma kept)
    want = b.pdf_map(x, y) * light.pdf_map(x, y) / mass
    np.testing.assert_allclose(p.pdf_map(x, y), want, rtol=1e-6, atol=1e-9 * want.max())
    np.testing.assert_array_equal(q.pdf_map(x, y), p.pdf_map(x, y))
    th, ph = np.meshgrid(np.linspace(-1.5, 1.5, 23), np.linspace(-3.1, 3.1, 29), indexing="ij")
    # its samples are its own: pdf_omega of each valid sample is what sample() reports
    t, f, d, v = p.sample("fiber", bsdfmix.uniforms(3, 5, 500)[:, 1:])
    np.testing.assert_allclose(d[v], p.pdf_omega("fiber", t[v], f[v]), rtol=1e-12)


def test_table_is_h5py(table):
    with h5py.File(DATA / "table.h5", "r") as f:
        np.testing.assert_array_equal(table.theta_i, f["table/theta_i"][()])
        np.testing.assert_array_equal(table.slice(3), f["table/values"][3, 0])
        np.testing.assert_array_equal(table.slice_rgb(2), f["table/rgb"][2, 0])
        assert table.slice(3).dtype == np.float32 and table.rgb and table.azimuthal


def test_errors():
    with pytest.raises(bsdfmix.Error, match="missing.h5"):
        bsdfmix.load_mixture(str(DATA / "missing.h5"))
    with pytest.raises(ValueError, match="positive definite"):
        bsdfmix.SliceMixture([1.0], [[0.0, 0.0]], [[1.0, 2.0, 1.0]])
    with pytest.raises(ValueError, match=r"\[n, 4\]"):
        bsdfmix.load_mixture(str(DATA / "mixture.h5")).sample(0.0, 0.0, np.zeros((3, 3)))
