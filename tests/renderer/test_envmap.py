"""Environment-map importance sampling: the pdf is normalized, matches the samples, and equals pdf(d)."""

from __future__ import annotations

import numpy as np

from renderer.envmap import EnvironmentMap


def _map(rng: np.random.Generator) -> EnvironmentMap:
    img = rng.random((16, 32, 3)) ** 4 * 5.0
    img[3, 7] = 200.0  # a sun
    img[10:, :5] = 0.0  # a black region: zero density there
    return EnvironmentMap(img, scale=1.5, rotate_deg=30.0)


def test_pdf_integrates_to_one(rng: np.random.Generator) -> None:
    env = _map(rng)
    # midpoint rule on a fine (theta, phi) grid, 16x finer than the map's pixels
    nt, npb = 256, 512
    t = (np.arange(nt) + 0.5) / nt * np.pi
    p = (np.arange(npb) + 0.5) / npb * 2 * np.pi
    T, P = np.meshgrid(t, p, indexing="ij")
    d = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3)
    integral = (env.pdf(d) * np.sin(T).ravel()).sum() * (np.pi / nt) * (2 * np.pi / npb)
    assert abs(integral - 1.0) < 1e-3


def test_sample_pdf_equals_pdf_and_radiance_lookup(rng: np.random.Generator) -> None:
    env = _map(rng)
    d, le, pdf = env.sample(rng.random((20000, 4)))
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.allclose(pdf, env.pdf(d), rtol=1e-9)
    assert np.allclose(le, env.eval(d))
    assert np.all(pdf > 0)  # never samples the black region


def test_estimator_is_unbiased(rng: np.random.Generator) -> None:
    """E[L(d) cos+(d.y) / pdf(d)] equals the irradiance integral computed on a fine grid (5 standard errors)."""
    env = _map(rng)
    d, le, pdf = env.sample(rng.random((400000, 4)))
    g = le[:, 1] * np.maximum(d[:, 1], 0.0) / pdf
    est, se = g.mean(), g.std() / np.sqrt(len(g))
    nt, npb = 512, 1024
    t = (np.arange(nt) + 0.5) / nt * np.pi
    p = (np.arange(npb) + 0.5) / npb * 2 * np.pi
    T, P = np.meshgrid(t, p, indexing="ij")
    dd = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3)
    truth = (
        (env.eval(dd)[:, 1] * np.maximum(dd[:, 1], 0) * np.sin(T).ravel()).sum()
        * (np.pi / nt)
        * (2 * np.pi / npb)
    )
    assert abs(est - truth) < 5 * se + 1e-3 * truth, (est, truth, se)
