"""Every model's analytic sampler (``Model.sample`` / ``Model.pdf``), checked against its own declaration.

For each model that has one, at its default parameters and at the defaults with every colour set to a
distinct RGB value (so a mixture whose default weight is 0, e.g. Lewis' ``kd = 0``, is exercised too):

- the density returned by ``sample`` equals ``pdf`` at the returned direction (1e-9 relative), is finite
  and non-negative, and the directions are unit vectors; over outgoing directions up to and at 90 degrees;
- ``pdf`` integrates to 1 over the sphere (Gauss-Legendre x trapezoid quadrature);
- the Monte Carlo estimate of the directional albedo, the mean of ``f cos(theta_i) / pdf`` over 2e5
  samples (fixed seed), matches the albedo by dense quadrature within 5 standard errors plus twice the
  quadrature's own error estimate (the difference between two resolutions). Under the central limit theorem
  one comparison fails by chance with probability 5.7e-7; with a few hundred comparisons (models x settings x
  3 directions x 3 channels) the suite fails by chance with probability below 1e-3.
"""

from __future__ import annotations

import numpy as np
import pytest

from core.geometry import spherical_to_dir
from core.kernels import pdf_batch, sample_batch
from core.model import all_models

MODELS = [m for m in all_models() if m.sample is not None]
IDS = [m.name for m in MODELS]
DISTINCT_RGB = (0.55, 0.3, 0.12)
N_MC = 200_000


def _settings(model):
    """Defaults, and defaults with every colour parameter set to a distinct RGB (clipped to its bounds)."""
    coloured = {}
    for p in model.params:
        if p.kind == "color":
            coloured[p.name] = tuple(float(np.clip(c, p.lo, p.hi)) for c in DISTINCT_RGB)
    out = [("defaults", model.bind())]
    if coloured:
        out.append(("rgb", model.bind(coloured)))
    return out


def _cases():
    for m in MODELS:
        for label, brdf in _settings(m):
            yield pytest.param(brdf, id=f"{m.name}-{label}")


CASES = list(_cases())


def _grid(n_theta, n_phi, theta_lo, theta_hi):
    """Quadrature nodes on the zone ``theta_lo <= theta <= theta_hi``: directions ``(k, 3)`` and weights
    ``(k,)`` for d(omega) (Gauss-Legendre in theta with the sin(theta) Jacobian, periodic midpoint in phi)."""
    x, w = np.polynomial.legendre.leggauss(n_theta)
    half = 0.5 * (theta_hi - theta_lo)
    theta = theta_lo + half * (x + 1.0)
    w_theta = half * w * np.sin(theta)
    phi = (np.arange(n_phi) + 0.5) * (2.0 * np.pi / n_phi)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    dirs = spherical_to_dir(t.ravel(), p.ravel())
    weights = np.repeat(w_theta, n_phi) * (2.0 * np.pi / n_phi)
    return dirs, weights


QUADRATURE_LEVELS = ((96, 192), (192, 384), (384, 768))


def _quadrature(integrand, theta_lo, theta_hi):
    """Integral of ``integrand(dirs (k, 3)) -> (k, ...)`` over a zone of the sphere, and an error estimate:
    the difference between two successive resolutions (the finer one is returned, so the estimate is
    conservative). Stops refining once that difference is below 1e-5 relative."""
    prev = None
    for n_theta, n_phi in QUADRATURE_LEVELS:
        dirs, weights = _grid(n_theta, n_phi, theta_lo, theta_hi)
        value = np.tensordot(weights, integrand(dirs), axes=(0, 0))
        if prev is not None:
            err = np.abs(value - prev)
            if np.all(err <= 1e-5 * np.maximum(np.abs(value), 1e-3)):
                break
        prev = value
    return value, err


def direction(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    """A unit vector ``(3,)``; exactly grazing (z = 0) at 90 degrees."""
    w = spherical_to_dir(np.radians(theta_deg), np.radians(phi_deg))
    if theta_deg == 90.0:
        w[2] = 0.0
    return w


def albedo_by_quadrature(brdf, wo):
    """Directional albedo ``int f(wi, wo) cos(theta_i) d(omega_i)`` per channel, and its error estimate."""

    def f_cos(dirs):
        return brdf.eval(wo, dirs) * np.maximum(dirs[:, 2], 0.0)[:, None]

    return _quadrature(f_cos, 0.0, 0.5 * np.pi)


def assert_sample_matches_pdf(brdf, thetas=(0.0, 1.0, 30.0, 60.0, 85.0, 89.9, 90.0), n=20_000, seed=7):
    """``sample`` gives unit vectors and a finite, non-negative density equal to ``pdf`` (1e-9 relative)."""
    rng = np.random.default_rng(seed)
    model = brdf.model
    for theta in thetas:
        wo = np.repeat(direction(theta)[None, :], n, axis=0)
        wi, pdf = sample_batch(model.sample, wo, brdf.params, rng.random((n, 3)))
        assert np.all(np.isfinite(wi)), f"theta_o={theta}: non-finite directions"
        np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-9, err_msg=f"theta_o={theta}")
        assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0), f"theta_o={theta}: pdf {pdf.min()}"
        again = pdf_batch(model.pdf, wo, wi, brdf.params)
        np.testing.assert_allclose(again, pdf, rtol=1e-9, atol=0.0, err_msg=f"theta_o={theta}")


def assert_pdf_integrates_to_one(brdf, thetas=(0.0, 45.0, 80.0)):
    """``pdf`` integrates to 1 over the sphere, within 1e-3 plus twice the quadrature's error estimate."""
    model = brdf.model
    for theta in thetas:
        wo = direction(theta)

        def density(dirs, wo=wo):
            wos = np.ascontiguousarray(np.repeat(wo[None, :], len(dirs), axis=0))
            return pdf_batch(model.pdf, wos, np.ascontiguousarray(dirs), brdf.params)

        # Upper and lower hemispheres apart: densities with a diffuse part jump at the horizon.
        upper, err_upper = _quadrature(density, 0.0, 0.5 * np.pi)
        lower, err_lower = _quadrature(density, 0.5 * np.pi, np.pi)
        total, err = upper + lower, err_upper + err_lower
        assert abs(total - 1.0) <= 1e-3 + 2.0 * err, f"theta_o={theta}: integral of pdf {total} (+- {err})"


def assert_albedo_estimate_matches(brdf, thetas=(0.0, 45.0, 80.0), n=N_MC, seed=1000):
    """Mean of ``f cos / pdf`` over ``n`` samples equals the quadrature albedo within 5 standard errors
    (plus twice the quadrature's error estimate), in every channel."""
    model = brdf.model
    for k, theta in enumerate(thetas):
        wo = direction(theta)
        albedo, err = albedo_by_quadrature(brdf, wo)
        rng = np.random.default_rng(seed + k)
        wos = np.repeat(wo[None, :], n, axis=0)
        wi, pdf = sample_batch(model.sample, wos, brdf.params, rng.random((n, 3)))
        fc = brdf.eval(wos, wi) * np.maximum(wi[:, 2], 0.0)[:, None]
        assert not np.any((pdf == 0.0)[:, None] & (fc > 0.0)), "a sample with pdf 0 where f > 0"
        weight = np.where(pdf[:, None] > 0.0, fc / np.where(pdf > 0.0, pdf, 1.0)[:, None], 0.0)
        mean = weight.mean(axis=0)
        se = weight.std(axis=0, ddof=1) / np.sqrt(n)
        tol = 5.0 * se + 2.0 * err + 1e-9 * np.maximum(np.abs(albedo), 1.0)
        assert np.all(np.abs(mean - albedo) <= tol), (
            f"theta_o={theta}: MC {mean} +- {se} vs quadrature {albedo} +- {err}"
        )


@pytest.mark.parametrize("brdf", CASES)
def test_sample_returns_its_pdf_and_unit_vectors(brdf):
    assert_sample_matches_pdf(brdf)


@pytest.mark.parametrize("brdf", CASES)
def test_pdf_integrates_to_one_over_the_sphere(brdf):
    assert_pdf_integrates_to_one(brdf)


@pytest.mark.parametrize("brdf", CASES)
def test_monte_carlo_albedo_matches_quadrature(brdf):
    assert_albedo_estimate_matches(brdf)
