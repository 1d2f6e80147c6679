"""The sampling interface every registered strategy implements (core.sampling): shapes, unit directions, the
pdf and BRDF value returned with a sample equal ``pdf(wo, wi)`` and ``eval(wo, wi)``, reproducibility for a
seed, user errors for bad input."""

from __future__ import annotations

import numpy as np
import pytest

from core.brdf import make_brdf
from core.errors import ParameterError, UnknownNameError
from core.geometry import degrees_to_dir
from core.sampling import SampleBatch, applicable_samplers, make_sampler, sampler_names

BRDFS = [("lambert", None), ("phong", {"n": 30})]
F_BRDFS = BRDFS + [("ward", {"sx": 0.1, "sy": 0.3})]
"""For the check of the returned ``f``: an anisotropic model too (its value depends on the azimuths)."""


@pytest.fixture(autouse=True)
def _private_cache(private_tables):
    """Every test gets its own table cache folder and an empty in-memory cache (tests/core/conftest.py)."""


def _cases(brdfs=BRDFS):
    out = []
    for model, params in brdfs:
        brdf = make_brdf(model, params)
        for name in applicable_samplers(brdf):
            out.append(pytest.param(model, params, name, id=f"{model}-{name}"))
    return out


@pytest.mark.parametrize(("model", "params", "name"), _cases())
def test_interface_contract(model, params, name):
    sampler = make_sampler(name, make_brdf(model, params))
    wo = degrees_to_dir(35.0, 20.0)
    drawn = sampler.sample(wo, 2000, seed=4)
    assert isinstance(drawn, SampleBatch)
    wi, pdf = drawn.wi, drawn.pdf
    assert wi.shape == (2000, 3) and pdf.shape == (2000,) and drawn.f.shape == (2000, 3)
    assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-9)
    np.testing.assert_allclose(sampler.pdf(np.broadcast_to(wo, wi.shape), wi), pdf, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(sampler.sample(wo, 2000, seed=4).wi, wi)
    many = np.stack([degrees_to_dir(t, p) for t, p in [(0, 0), (20, 40), (60, 200), (85, 300)]] * 50)
    each = sampler.sample_each(many, seed=1)
    assert each.wi.shape == many.shape and each.pdf.shape == (len(many),) and each.f.shape == many.shape
    np.testing.assert_allclose(sampler.pdf(many, each.wi), each.pdf, rtol=1e-12, atol=0)
    assert sampler.eval(np.broadcast_to(wo, wi.shape), wi).shape == (2000, 3)
    info = sampler.info()
    assert info["sampler"] == name and info["memory_bytes"] >= 0 and info["build_seconds"] >= 0.0
    with pytest.raises(ParameterError):
        sampler.sample(wo, 0)


@pytest.mark.parametrize(("model", "params", "name"), _cases(F_BRDFS))
def test_a_draw_returns_the_brdf_value_and_the_pdf_at_its_directions(model, params, name):
    """``f`` is the BRDF's value at the drawn directions (0 below the horizon, and 0 where no draw was made:
    ``pdf = 0``), exactly as ``brdf.eval`` gives it, and ``pdf`` is ``sampler.pdf`` there; for one ``wo`` and for one ``wo`` per row. (The pdf to 1e-9: the
    factored sampler's half-vector density is recomputed from ``wi + wo`` by ``pdf``, which rounds
    differently inside a sharp lobe.)"""
    brdf = make_brdf(model, params)
    sampler = make_sampler(name, brdf)
    wo = degrees_to_dir(50.0, 110.0)
    drawn = sampler.sample(wo, 3000, seed=8)
    np.testing.assert_array_equal(drawn.f, np.where(drawn.pdf[:, None] > 0, brdf.eval(wo, drawn.wi), 0.0))
    np.testing.assert_allclose(sampler.pdf(wo, drawn.wi), drawn.pdf, rtol=1e-9, atol=0)
    many = np.stack([degrees_to_dir(t, p) for t, p in [(0, 0), (30, 70), (70, 190), (89, 320)]] * 250)
    each = sampler.sample_each(many, seed=2)
    np.testing.assert_array_equal(each.f, np.where(each.pdf[:, None] > 0, brdf.eval(many, each.wi), 0.0))
    np.testing.assert_allclose(sampler.pdf(many, each.wi), each.pdf, rtol=1e-9, atol=0)
    assert np.all(each.f[each.wi[:, 2] <= 0.0] == 0.0)
    assert np.any(each.f > 0.0)


@pytest.mark.parametrize(("model", "params", "name"), _cases(F_BRDFS))
def test_the_renderers_calls_write_into_its_buffers(model, params, name):
    """What a renderer calls on a slice of its buffers: ``sample_into`` writes ``sample_each``'s draws (same
    seed, same bits) and ``eval_pdf_where`` writes ``eval`` and ``pdf`` at the masked rows only; every row
    outside the slice, and every unmasked row, keeps what it held (NaN here)."""
    brdf = make_brdf(model, params)
    sampler = make_sampler(name, brdf)
    rng = np.random.default_rng(5)
    n, lo, hi = 700, 100, 600
    wo = rng.normal(size=(n, 3))
    wo[:, 2] = np.abs(wo[:, 2])
    wo[7, 2] = -0.2  # a view below the horizon: no draw, pdf 0, f 0
    wo /= np.linalg.norm(wo, axis=1)[:, None]
    wi, pdf, f = np.full((n, 3), np.nan), np.full(n, np.nan), np.full((n, 3), np.nan)
    sampler.sample_into(wo[lo:hi], 11, wi[lo:hi], pdf[lo:hi], f[lo:hi])
    each = sampler.sample_each(wo[lo:hi], seed=11)
    np.testing.assert_array_equal(wi[lo:hi], each.wi)
    np.testing.assert_array_equal(pdf[lo:hi], each.pdf)
    np.testing.assert_array_equal(f[lo:hi], each.f)
    for a in (wi, pdf, f):
        assert np.all(np.isnan(a[:lo])) and np.all(np.isnan(a[hi:]))

    light = rng.normal(size=(n, 3))  # light directions in both hemispheres, as a renderer's can be
    light /= np.linalg.norm(light, axis=1)[:, None]
    mask = rng.random(n) < 0.7
    f_l, pdf_l = np.full((n, 3), np.nan), np.full(n, np.nan)
    sampler.eval_pdf_where(wo[lo:hi], light[lo:hi], mask[lo:hi], f_l[lo:hi], pdf_l[lo:hi])
    rows = lo + np.flatnonzero(mask[lo:hi])
    np.testing.assert_array_equal(f_l[rows], sampler.eval(wo[rows], light[rows]))
    np.testing.assert_allclose(pdf_l[rows], sampler.pdf(wo[rows], light[rows]), rtol=1e-12, atol=0)
    untouched = np.ones(n, dtype=bool)
    untouched[rows] = False
    assert np.all(np.isnan(f_l[untouched])) and np.all(np.isnan(pdf_l[untouched]))
    assert np.all(np.isfinite(f_l[rows])) and np.all(pdf_l[rows] >= 0.0)


@pytest.mark.parametrize(("model", "params", "name"), _cases())
def test_buffers_of_the_wrong_shape_or_type_are_refused(model, params, name):
    """The in-place calls hand the caller's arrays to compiled loops without bounds checks: a wrong shape, type
    or layout is a clear ParameterError, and nothing is written."""
    sampler = make_sampler(name, make_brdf(model, params))
    n = 8
    wo = np.tile(degrees_to_dir(30.0, 10.0), (n, 1))
    wi, pdf, f = np.zeros((n, 3)), np.zeros(n), np.zeros((n, 3))
    for bad in ({"wi": np.zeros((n, 2))}, {"pdf": np.zeros(n + 1)}, {"f": np.zeros((n, 3), np.float32)},
                {"wi": np.zeros((3, n)).T}):  # fmt: skip
        args = {"wi": wi, "pdf": pdf, "f": f} | bad
        with pytest.raises(ParameterError, match="must be a C-contiguous"):
            sampler.sample_into(wo, 1, args["wi"], args["pdf"], args["f"])
    with pytest.raises(ParameterError, match="mask must be"):
        sampler.eval_pdf_where(wo, wo, np.ones(n, dtype=np.int64), f, pdf)
    assert not wi.any() and not pdf.any() and not f.any()


def test_unknown_sampler_is_a_user_error():
    assert "adaptive_exact" in sampler_names()
    with pytest.raises(UnknownNameError, match="unknown sampler 'nope'"):
        make_sampler("nope", make_brdf("lambert"))
