"""The compiled switch of core.dispatch: every model has its own id, and the switch reaches exactly the model's
own kernels (bit for bit) for evaluation, sampling and density.

Each test runs every model through one compiled loop (core.kernels' batch drivers, called with each id in
turn), so numba compiles a loop once, not once per model; the reference is each model's kernel called from
Python, pair by pair.
"""

from __future__ import annotations

import numpy as np

from core import dispatch
from core.brdf import BRDF, Model, all_models
from core.kernels import eval_batch, pdf_batch, sample_batch
from core.merl import MERL, MERL_NEAREST, measured_brdf
from core.rgl.material import RGL, RGL_ANISOTROPIC, RGL_GENERAL
from tests.conftest import direction_grid

MODELS = all_models()
SAMPLED = [m for m in MODELS if m.sample is not None]
UNSAMPLED = [m for m in MODELS if m.sample is None]
N_RANDOM = 2000


def _random_values(model: Model, rng: np.random.Generator) -> dict:
    """One parameter setting drawn inside each parameter's bounds (log-uniform where declared)."""
    values: dict = {}
    for p in model.params:
        if p.kind == "bool":
            values[p.name] = float(rng.integers(0, 2))
            continue
        if p.log and p.lo > 0:
            draws = np.exp(rng.uniform(np.log(p.lo), np.log(p.hi), 3))
        else:
            draws = rng.uniform(p.lo, p.hi, 3)
        values[p.name] = tuple(float(v) for v in draws) if p.kind == "color" else float(draws[0])
    return values


def _settings(model: Model, rng: np.random.Generator) -> list[BRDF]:
    return [model.bind(), model.bind(_random_values(model, rng))]


def _sphere(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` directions uniform over the whole sphere (both hemispheres)."""
    z = rng.uniform(-1.0, 1.0, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def _pairs(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``(wi, wo)`` each ``(n, 3)``: random pairs over the sphere, then pairs of the dense grid's grazing and
    exactly-90-degree directions with random partners."""
    grid = direction_grid()
    edge = grid[grid[:, 2] < np.cos(np.radians(80.0))]
    partners = _sphere(rng, len(edge))
    wi = np.concatenate([_sphere(rng, N_RANDOM), edge, partners, edge])
    wo = np.concatenate([_sphere(rng, N_RANDOM), partners, edge, edge[::-1]])
    return np.ascontiguousarray(wi), np.ascontiguousarray(wo)


def _tuples(d: np.ndarray) -> list[tuple[float, float, float]]:
    """Rows of ``d (n, 3)`` as the 3-tuples the kernels take (the reference calls them from Python)."""
    return [tuple(map(float, w)) for w in d]


def test_every_model_has_a_distinct_id():
    models = [*MODELS, MERL, MERL_NEAREST, RGL, RGL_ANISOTROPIC, RGL_GENERAL]
    ids = [m.id for m in models]
    assert len(set(ids)) == len(ids)
    assert {m.name: m.id for m in models} == dispatch.MODEL_IDS
    assert all(isinstance(i, int) and i >= 0 for i in ids)


def test_eval_model_is_each_models_eval(rng):
    wi, wo = _pairs(rng)
    for model in MODELS:
        for brdf in _settings(model, rng):
            got = eval_batch(model.id, wi, wo, brdf.params)
            p = brdf.params
            want = np.asarray([model.eval(a, b, p) for a, b in zip(_tuples(wi), _tuples(wo), strict=True)])
            np.testing.assert_array_equal(got, want, err_msg=f"{model.name} {brdf.values}")


def test_eval_model_of_measured_brdfs(bundled_merl_brdf, rng):
    wi, wo = _pairs(rng)
    nearest = measured_brdf(bundled_merl_brdf.path, interpolate=False)
    for brdf in (bundled_merl_brdf, nearest):
        got = eval_batch(brdf.model.id, wi, wo, brdf.params)
        p, kernel = brdf.params, brdf.model.eval
        want = np.asarray([kernel(a, b, p) for a, b in zip(_tuples(wi), _tuples(wo), strict=True)])
        np.testing.assert_array_equal(got, want)
        assert np.any(got > 0.0)
    assert bundled_merl_brdf.model is MERL and nearest.model is MERL_NEAREST


def test_sample_and_pdf_model_are_each_models_sampler(rng):
    wi_any, wo = _pairs(rng)
    wo_t = _tuples(wo)
    u = rng.random((len(wo), 3))
    for model in SAMPLED:
        for brdf in _settings(model, rng):
            label = f"{model.name} {brdf.values}"
            p = brdf.params
            wi, pdf = sample_batch(model.id, wo, p, u)
            want = np.asarray([model.sample(w, p, *map(float, r)) for w, r in zip(wo_t, u, strict=True)])
            np.testing.assert_array_equal(np.column_stack([wi, pdf]), want, err_msg=label)
            for dirs in (wi, wi_any):
                got = pdf_batch(model.id, wo, dirs, p)
                want = np.asarray([model.pdf(a, b, p) for a, b in zip(wo_t, _tuples(dirs), strict=True)])
                np.testing.assert_array_equal(got, want, err_msg=label)


def test_models_without_a_sampler_have_density_zero(bundled_merl_brdf, rng):
    wi, wo = _pairs(rng)
    u = rng.random((len(wo), 3))
    for brdf in [m.bind() for m in UNSAMPLED] + [bundled_merl_brdf]:
        assert np.all(pdf_batch(brdf.model.id, wo, wi, brdf.params) == 0.0), brdf.name
        assert np.all(sample_batch(brdf.model.id, wo, brdf.params, u).pdf == 0.0), brdf.name
