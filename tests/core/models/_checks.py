"""Checks shared by the model tests (``tests/core/models/``) and the registry-wide sampler tests
(``tests/core/test_analytic_samplers.py``): each asserts one property of a bound model and states its tolerance
or significance.

- :func:`eval_degrees`: one BRDF value for directions in degrees.
- :func:`hard_case_grid_is_finite`: finite and non-negative on the dense direction grid (up to and at 90 deg).
- :func:`assert_sample_matches_pdf`: ``sample`` returns unit vectors and exactly ``pdf`` (1e-9 relative).
- :func:`assert_sampler_exact`: the same, plus a chi-square fit of the samples to the pdf.
- :func:`assert_pdf_integrates_to_one`: ``pdf`` integrates to 1 over the sphere (quadrature).
- :func:`assert_albedo_estimate_matches`: the Monte Carlo albedo with the sampler equals the quadrature albedo.
- :func:`albedo_estimate`, :func:`albedo_by_quadrature`: directional albedo, with its error.
- :func:`fresnel_reference`: the Fresnel equations written out (an independent reference for the kernels).
"""

from __future__ import annotations

import cmath
import functools
import math

import numpy as np
import pytest

from core.brdf import BRDF
from core.chi2 import Variable, chi2_test, sampler_functions
from core.geometry import degrees_to_dir, spherical_to_dir
from core.kernels import pdf_batch, sample_batch
from core.sampling import make_sampler
from tests.conftest import all_pairs, direction_grid

# ----------------------------------------------------------------------------------------------------------
# Reference formulas
# ----------------------------------------------------------------------------------------------------------


def fresnel_reference(cos_i: float, n: float, k: float) -> float:
    """Unpolarized Fresnel reflectance of a medium ``n + ik`` seen from air (Born & Wolf), with the refraction
    angle from Snell's law in complex form: ``sin_t = sin_i / eta``, ``cos_t = sqrt(1 - sin_t^2)`` (principal
    root), ``r_s = (cos_i - eta cos_t) / (cos_i + eta cos_t)``, ``r_p = (eta cos_i - cos_t) / (eta cos_i +
    cos_t)``, ``F = (|r_s|^2 + |r_p|^2) / 2``."""
    eta = complex(n, k)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_i * cos_i)) / eta
    cos_t = cmath.sqrt(1.0 - sin_t * sin_t)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)


# ----------------------------------------------------------------------------------------------------------
# Directions and quadrature
# ----------------------------------------------------------------------------------------------------------


def direction(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    """A unit vector ``(3,)``; exactly grazing (z = 0) at 90 degrees."""
    w = spherical_to_dir(np.radians(theta_deg), np.radians(phi_deg))
    if theta_deg == 90.0:
        w[2] = 0.0
    return w


@functools.lru_cache(maxsize=16)
def _grid(n_theta: int, n_phi: int, theta_lo: float, theta_hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature nodes on the zone ``theta_lo <= theta <= theta_hi``: directions ``(k, 3)`` and weights
    ``(k,)`` for d(omega) (Gauss-Legendre in theta with the sin(theta) Jacobian, periodic midpoint in phi).
    Cached (callers must not modify the arrays): every model and direction integrates over the same few zones."""
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


def quadrature(integrand, theta_lo: float, theta_hi: float):
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


def albedo_by_quadrature(brdf: BRDF, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directional albedo ``int f(wi, wo) cos(theta_i) d(omega_i)`` per channel ``(3,)``, and its error
    estimate ``(3,)``."""

    def f_cos(dirs):
        return brdf.eval(wo, dirs) * np.maximum(dirs[:, 2], 0.0)[:, None]

    return quadrature(f_cos, 0.0, 0.5 * np.pi)


def albedo_estimate(
    brdf: BRDF, wo: np.ndarray, n: int = 200_000, seed: int = 3
) -> tuple[np.ndarray, np.ndarray]:
    """Directional albedo (RGB) by importance sampling with the model's analytic sampler, and its standard
    error: mean of ``f cos / pdf`` (samples below the horizon contribute 0)."""
    sampler = make_sampler("analytic", brdf)
    drawn = sampler.sample(np.asarray(wo, dtype=np.float64), n, seed)
    wi, pdf, f = drawn.wi, drawn.pdf, drawn.f
    up = (wi[:, 2] > 0.0) & (pdf > 0.0)
    w = np.zeros_like(f)
    w[up] = f[up] * wi[up, 2:3] / pdf[up, None]
    return w.mean(axis=0), w.std(axis=0) / math.sqrt(n)


# ----------------------------------------------------------------------------------------------------------
# Evaluation
# ----------------------------------------------------------------------------------------------------------


def eval_degrees(brdf: BRDF, wo_deg: tuple[float, float], wi_deg: tuple[float, float]) -> np.ndarray:
    """The BRDF value ``(3,)`` for directions given as ``(theta, phi)`` in degrees."""
    return brdf.eval(degrees_to_dir(*wo_deg), degrees_to_dir(*wi_deg))[0]


def hard_case_grid_is_finite(brdf: BRDF) -> None:
    """Finite and non-negative for every ordered pair of the dense direction grid (grazing and 90 deg)."""
    wo, wi = all_pairs(direction_grid())
    f = brdf.eval(wo, wi)
    assert np.all(np.isfinite(f)) and np.all(f >= 0.0)


# ----------------------------------------------------------------------------------------------------------
# Samplers
# ----------------------------------------------------------------------------------------------------------


def assert_sample_matches_pdf(brdf: BRDF, thetas=(0.0, 1.0, 30.0, 60.0, 85.0, 89.9, 90.0), n=20_000, seed=7):
    """``sample`` gives unit vectors and a finite, non-negative density equal to ``pdf`` (1e-9 relative)."""
    rng = np.random.default_rng(seed)
    model = brdf.model
    for theta in thetas:
        wo = np.repeat(direction(theta)[None, :], n, axis=0)
        wi, pdf = sample_batch(model, wo, brdf.params, rng.random((n, 3)))
        assert np.all(np.isfinite(wi)), f"theta_o={theta}: non-finite directions"
        np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-9, err_msg=f"theta_o={theta}")
        assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0), f"theta_o={theta}: pdf {pdf.min()}"
        again = pdf_batch(model, wo, wi, brdf.params)
        np.testing.assert_allclose(again, pdf, rtol=1e-9, atol=0.0, err_msg=f"theta_o={theta}")


def assert_sampler_exact(
    brdf: BRDF,
    theta_deg: float,
    phi_deg: float = 20.0,
    n: int = 1_000_000,
    seed: int = 7,
    variable: Variable = "cos",
) -> None:
    """For the outgoing direction ``(theta_deg, phi_deg)``: the model's analytic sampler returns, with each
    direction, exactly ``pdf(wo, wi)`` (to rounding), and its samples follow that pdf: :func:`core.chi2.chi2_test`
    (pdf integral within 1e-3 of 1, Pearson chi-square at significance 0.01 with ``n`` samples; on the sphere
    grid, or on the disk grid beyond 60 degrees, where it resolves lobes at grazing angles better).
    ``variable="theta"``: the cell integrals' nodes even in ``theta``, for lobes far narrower than a cell at
    the pole."""
    sampler = make_sampler("analytic", brdf)
    wo = degrees_to_dir(theta_deg, phi_deg)
    drawn = sampler.sample(wo, 20_000, seed)
    wi, pdf = drawn.wi, drawn.pdf
    assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
    np.testing.assert_allclose(pdf, sampler.pdf(wo, wi), rtol=1e-9, atol=0.0)
    sample, density = sampler_functions(sampler, wo)
    domain = "disk" if theta_deg > 60.0 else "sphere"
    result = chi2_test(sample, density, n_samples=n, domain=domain, seed=seed, alpha=0.01, variable=variable)
    assert result.passed, result.reason


def assert_pdf_integrates_to_one(brdf: BRDF, thetas=(0.0, 45.0, 80.0)) -> None:
    """``pdf`` integrates to 1 over the sphere, within 1e-3 plus twice the quadrature's error estimate."""
    model = brdf.model
    for theta in thetas:
        wo = direction(theta)

        def density(dirs, wo=wo):
            wos = np.ascontiguousarray(np.repeat(wo[None, :], len(dirs), axis=0))
            return pdf_batch(model, wos, np.ascontiguousarray(dirs), brdf.params)

        # Upper and lower hemispheres apart: densities with a diffuse part jump at the horizon.
        upper, err_upper = quadrature(density, 0.0, 0.5 * np.pi)
        lower, err_lower = quadrature(density, 0.5 * np.pi, np.pi)
        total, err = upper + lower, err_upper + err_lower
        assert abs(total - 1.0) <= 1e-3 + 2.0 * err, f"theta_o={theta}: integral of pdf {total} (+- {err})"


def assert_albedo_estimate_matches(brdf: BRDF, thetas=(0.0, 45.0, 80.0), n=200_000, seed=1000) -> None:
    """Mean of ``f cos / pdf`` over ``n`` samples equals the quadrature albedo within 5 standard errors
    (plus twice the quadrature's error estimate), in every channel. Under the central limit theorem one
    comparison fails by chance with probability 5.7e-7."""
    model = brdf.model
    for k, theta in enumerate(thetas):
        wo = direction(theta)
        albedo, err = albedo_by_quadrature(brdf, wo)
        rng = np.random.default_rng(seed + k)
        wos = np.repeat(wo[None, :], n, axis=0)
        wi, pdf = sample_batch(model, wos, brdf.params, rng.random((n, 3)))
        fc = brdf.eval(wos, wi) * np.maximum(wi[:, 2], 0.0)[:, None]
        assert not np.any((pdf == 0.0)[:, None] & (fc > 0.0)), "a sample with pdf 0 where f > 0"
        weight = np.where(pdf[:, None] > 0.0, fc / np.where(pdf > 0.0, pdf, 1.0)[:, None], 0.0)
        mean = weight.mean(axis=0)
        se = weight.std(axis=0, ddof=1) / np.sqrt(n)
        tol = 5.0 * se + 2.0 * err + 1e-9 * np.maximum(np.abs(albedo), 1.0)
        assert np.all(np.abs(mean - albedo) <= tol), (
            f"theta_o={theta}: MC {mean} +- {se} vs quadrature {albedo} +- {err}"
        )


def sampler_sweep(settings: list[dict], thetas: list[float], fast: set[tuple[int, float]]) -> list:
    """``pytest.param(values, theta)`` for every setting x outgoing polar angle, for a chi-square sweep of a
    sampler. The pairs ``(setting index, theta)`` in ``fast`` run in the default suite (chosen so that every
    setting and every angle appears at least once); the rest carry ``@pytest.mark.slow``."""
    covered_settings = {i for i, _ in fast}
    covered_thetas = {t for _, t in fast}
    assert covered_settings == set(range(len(settings))) and covered_thetas == set(thetas), (
        "fast must cover all"
    )
    return [
        pytest.param(
            values, theta, id=f"{theta}-values{i}", marks=() if (i, theta) in fast else pytest.mark.slow
        )
        for i, values in enumerate(settings)
        for theta in thetas
    ]
