"""The sampling interface every registered strategy implements (core.sampler): shapes, unit directions, the
pdf returned with a sample equals ``pdf(wo, wi)``, reproducibility for a seed, user errors for bad input."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ParameterError, UnknownNameError
from core.geometry import degrees_to_dir
from core.model import make_brdf
from core.sampler import applicable_samplers, make_sampler, sampler_names

BRDFS = [("lambert", None), ("phong", {"n": 30})]


@pytest.fixture(autouse=True)
def _private_cache(private_tables):
    """Every test gets its own table cache folder and an empty in-memory cache (tests/core/conftest.py)."""


def _cases():
    out = []
    for model, params in BRDFS:
        brdf = make_brdf(model, params)
        for name in applicable_samplers(brdf):
            out.append(pytest.param(model, params, name, id=f"{model}-{name}"))
    return out


@pytest.mark.parametrize(("model", "params", "name"), _cases())
def test_interface_contract(model, params, name):
    sampler = make_sampler(name, make_brdf(model, params))
    wo = degrees_to_dir(35.0, 20.0)
    wi, pdf = sampler.sample(wo, 2000, seed=4)
    assert wi.shape == (2000, 3) and pdf.shape == (2000,)
    assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-9)
    np.testing.assert_allclose(sampler.pdf(np.broadcast_to(wo, wi.shape), wi), pdf, rtol=1e-12, atol=0)
    again, _ = sampler.sample(wo, 2000, seed=4)
    np.testing.assert_array_equal(wi, again)
    many = np.stack([degrees_to_dir(t, p) for t, p in [(0, 0), (20, 40), (60, 200), (85, 300)]] * 50)
    wi2, pdf2 = sampler.sample_each(many, seed=1)
    assert wi2.shape == many.shape and pdf2.shape == (len(many),)
    np.testing.assert_allclose(sampler.pdf(many, wi2), pdf2, rtol=1e-12, atol=0)
    assert sampler.eval(np.broadcast_to(wo, wi.shape), wi).shape == (2000, 3)
    info = sampler.info()
    assert info["sampler"] == name and info["memory_bytes"] >= 0 and info["build_seconds"] >= 0.0
    with pytest.raises(ParameterError):
        sampler.sample(wo, 0)


def test_unknown_sampler_is_a_user_error():
    assert "adaptive" in sampler_names()
    with pytest.raises(UnknownNameError, match="unknown sampler 'nope'"):
        make_sampler("nope", make_brdf("lambert"))
