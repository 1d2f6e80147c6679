"""GGX (Walter et al. 2007) with separable Smith masking and an exact conductor Fresnel: reference values
from the paper's tangent form written here, grazing and tiny-roughness cases, and the visible-normal sampler
(Heitz 2018): chi-square at significance 0.01 with 1e6 samples per case, one case per setting and per angle
in the default run, the full settings x angles sweep with ``-m slow``. The cross-check against Mitsuba 3 is in
tests/core/test_mitsuba_crosscheck.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from core.sampling import make_sampler
from tests.core.models._checks import (
    albedo_estimate,
    assert_sampler_exact,
    fresnel_reference,
    hard_case_grid_is_finite,
    sampler_sweep,
)

GGX = get_model("ggx")
COPPER_ETA = (0.200, 0.924, 1.102)
COPPER_K = (3.912, 2.452, 2.142)


def smith_g1(v, alpha):
    """Walter et al. eq. 34: G1(v) = 2 / (1 + sqrt(1 + alpha^2 tan^2(theta_v)))."""
    theta = math.acos(v[2])
    return 2.0 / (1.0 + math.sqrt(1.0 + alpha**2 * math.tan(theta) ** 2))


def ggx_reference(wi, wo, alpha, eta, k, kd):
    """Walter et al. eq. 20 with eq. 33: D(m) = alpha^2 / (pi cos^4(theta_m) (alpha^2 + tan^2(theta_m))^2),
    f = kd/pi + F(i.m) G1(i) G1(o) D(m) / (4 |i.n| |o.n|), m the normalized half vector."""
    m = np.add(wi, wo)
    m /= np.linalg.norm(m)
    theta_m = math.acos(m[2])
    d = alpha**2 / (math.pi * math.cos(theta_m) ** 4 * (alpha**2 + math.tan(theta_m) ** 2) ** 2)
    g = smith_g1(wi, alpha) * smith_g1(wo, alpha)
    f = fresnel_reference(float(np.dot(wi, m)), eta, k)
    return kd / math.pi + f * g * d / (4.0 * wi[2] * wo[2])


def test_reference_normal_incidence_defaults():
    # wi = wo = n: D(n) = 1 / (pi alpha^2), G1 = 1, F = F0 per channel: f = F0 / (4 pi alpha^2).
    z = np.array([0.0, 0.0, 1.0])
    f0 = [
        ((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k) for n, k in zip(COPPER_ETA, COPPER_K, strict=True)
    ]
    np.testing.assert_allclose(GGX.bind().eval(z, z)[0], np.array(f0) / (4.0 * math.pi * 0.04), rtol=1e-12)


@pytest.mark.parametrize(
    ("wi_deg", "wo_deg"),
    [((30.0, 0.0), (45.0, 160.0)), ((75.0, 40.0), (20.0, 300.0)), ((88.0, 10.0), (85.0, 95.0))],
)
def test_reference_values(wi_deg, wo_deg):
    alpha, eta, k, kd = 0.35, (1.5, 0.3, 2.0), (0.0, 3.0, 7.0), (0.2, 0.1, 0.0)
    wi, wo = degrees_to_dir(*wi_deg), degrees_to_dir(*wo_deg)
    got = GGX.bind(alpha=alpha, eta=eta, k=k, kd=kd).eval(wo, wi)[0]
    expected = [ggx_reference(wi, wo, alpha, eta[c], k[c], kd[c]) for c in range(3)]
    np.testing.assert_allclose(got, expected, rtol=1e-10)


@pytest.mark.parametrize("alpha", [0.001, 0.005])
def test_hard_case_tiny_roughness_and_grazing(alpha):
    brdf = GGX.bind(alpha=alpha, kd=0.2)
    hard_case_grid_is_finite(brdf)
    # Mirror direction at 89.9 deg: D = 1 / (pi alpha^2), G1(v) -> 2 / (1 + sqrt(1 + alpha^2 tan^2)), finite.
    wo = degrees_to_dir(89.9, 0.0)
    wi = degrees_to_dir(89.9, 180.0)
    expected = ggx_reference(wi, wo, alpha, COPPER_ETA[0], COPPER_K[0], 0.2)
    assert brdf.eval(wo, wi)[0, 0] == pytest.approx(expected, rel=1e-9)
    f = brdf.eval(
        degrees_to_dir(90.0, 0.0), np.stack([degrees_to_dir(90.0, 180.0), wi, degrees_to_dir(30.0, 0.0)])
    )
    assert np.all(f == 0.0)


def test_visible_normal_weight_is_fresnel_times_shadowing():
    # With kd = 0 the estimator weight f cos(theta_i) / pdf is F(wi.h) G1(wi): the whole point of sampling
    # visible normals (D and G1(wo) cancel). Checked against G1 and F computed here.
    alpha = 0.4
    brdf = GGX.bind(alpha=alpha)
    sampler = make_sampler("analytic", brdf)
    wo = degrees_to_dir(70.0, 30.0)
    drawn = sampler.sample(wo, 2000, 11)
    wi, pdf = drawn.wi, drawn.pdf
    up = wi[:, 2] > 0.0
    weights = drawn.f[up, 0] * wi[up, 2] / pdf[up]
    h = wi[up] + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    expected = [
        fresnel_reference(float(np.dot(w, hh)), COPPER_ETA[0], COPPER_K[0]) * smith_g1(w, alpha)
        for w, hh in zip(wi[up], h, strict=True)
    ]
    np.testing.assert_allclose(weights, expected, rtol=1e-9)
    assert np.all(weights <= 1.0)


def test_single_scattering_albedo_at_most_one():
    for alpha in (0.05, 0.5, 1.0):
        for theta in (0.0, 60.0, 89.0):
            albedo, err = albedo_estimate(GGX.bind(alpha=alpha, eta=0.01, k=10.0), degrees_to_dir(theta, 0.0))
            assert np.all(albedo <= 1.0 + 4.0 * err)


def test_traits():
    assert GGX.reciprocal and GGX.isotropic and not GGX.energy_conserving


SAMPLER_SETTINGS = [
    {},
    {"alpha": 0.6, "kd": (0.5, 0.4, 0.3)},
    {"alpha": 0.08, "kd": 0.1, "eta": 1.5, "k": 0.0},
]


@pytest.mark.parametrize(
    ("values", "theta"),
    sampler_sweep(
        SAMPLER_SETTINGS, [0.0, 50.0, 85.0, 90.0], fast={(0, 50.0), (1, 90.0), (2, 85.0), (1, 0.0)}
    ),
)
def test_sampler_is_exact(values, theta):
    assert_sampler_exact(GGX.bind(values), theta)


def test_sampler_below_the_horizon_falls_back_to_the_cosine_hemisphere():
    sampler = make_sampler("analytic", GGX.bind(kd=0.5))
    wo = np.array([0.6, 0.0, -0.8])
    drawn = sampler.sample(wo, 1000, 2)
    wi, pdf = drawn.wi, drawn.pdf
    assert np.all(wi[:, 2] >= 0.0)
    np.testing.assert_allclose(pdf, wi[:, 2] / math.pi, rtol=1e-12)
    np.testing.assert_allclose(pdf, sampler.pdf(wo, wi), rtol=1e-12)


def _masses_by_half_vectors(density, wo: np.ndarray, n: int) -> tuple[float, float]:
    """Integrals of ``density(wi (m, 3)) -> (m,)`` (per unit solid angle) over the upper and the lower
    hemisphere of ``wi``, in the variable ``h`` of ``wi = 2 (wo.h) h - wo``: every ``wi`` but ``-wo`` comes from
    exactly one ``h`` of the upper hemisphere, and ``d(omega_i) = 4 |wo.h| d(omega_h)``. In ``h`` the visible-
    normal density is smooth and has no singular point (in ``wi`` it jumps to 0 on ``wi.z = -wo.z`` and the
    Jacobian is singular at ``-wo``). Gauss-Legendre in ``cos(theta_h)`` (``n`` nodes) x midpoint in ``phi_h``
    (``n``)."""
    x, w = np.polynomial.legendre.leggauss(n)
    cos_h = np.repeat(0.5 * (x + 1.0), n)
    phi_h = np.tile((np.arange(n) + 0.5) * (2.0 * math.pi / n), n)
    weights = np.repeat(0.5 * w, n) * (2.0 * math.pi / n)
    sin_h = np.sqrt(1.0 - cos_h**2)
    h = np.stack([sin_h * np.cos(phi_h), sin_h * np.sin(phi_h), cos_h], axis=1)
    wo_h = h @ wo
    wi = 2.0 * wo_h[:, None] * h - wo
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    values = density(wi) * 4.0 * np.abs(wo_h) * weights
    below = wi[:, 2] < 0.0
    return float(values[~below].sum()), float(values[below].sum())


@pytest.mark.parametrize(
    ("values", "theta"),
    [
        ({}, 45.0),
        ({}, 89.5),
        ({"alpha": 1.0}, 45.0),
        ({"alpha": 1.0}, 89.5),
        ({"alpha": 0.5, "kd": 0.3}, 85.0),
    ],
)
def test_visible_normal_draws_below_the_horizon_are_in_the_pdf(values, theta):
    """Visible normals reflect ``wo`` below the horizon (up to ``wi.z = -wo.z``, where ``(wi + wo).z``, hence the
    half vector, reaches the horizon). ``pdf`` must account for those draws: it integrates to 1 over the whole
    sphere within 1e-5 (quadrature in the half vector with 400 x 400 nodes; its error, estimated by the change
    from 200 x 200, is below 1e-6 for the whole sphere and about 1e-4 for the lower hemisphere, whose edge cuts
    across the cells), the fraction of 1e6 draws (seed 5) below the horizon is its mass there within 5 binomial
    standard deviations plus that error (a chance failure has probability 6e-7 per case), and every such draw
    carries ``pdf(wo, wi) > 0``, returned exactly by ``sample`` (1e-12 relative)."""
    sampler = make_sampler("analytic", GGX.bind(values))
    wo = degrees_to_dir(theta, 30.0)

    def density(wi):
        return sampler.pdf(np.broadcast_to(wo, wi.shape), wi)

    upper, lower = _masses_by_half_vectors(density, wo, 400)
    upper_coarse, lower_coarse = _masses_by_half_vectors(density, wo, 200)
    assert abs(upper + lower - 1.0) < 1e-5
    lower_error = abs(lower - lower_coarse)

    n = 1_000_000
    drawn = sampler.sample(wo, n, 5)
    wi, pdf = drawn.wi, drawn.pdf
    below = wi[:, 2] < 0.0
    assert below.any()
    assert np.all(wi[:, 2] + wo[2] > 0.0)  # the density is 0 beyond; nothing is drawn there
    again = sampler.pdf(np.broadcast_to(wo, wi[below].shape), wi[below])
    assert np.all(again > 0.0)
    np.testing.assert_allclose(pdf[below], again, rtol=1e-12, atol=0.0)
    sigma = math.sqrt(lower * (1.0 - lower) / n)
    assert abs(below.mean() - lower) <= 5.0 * sigma + lower_error, (below.mean(), lower, sigma)
