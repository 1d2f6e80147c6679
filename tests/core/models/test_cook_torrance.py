"""Cook-Torrance (1982): reference values from the paper's formula written here with angles and complex
Snell's law, the V-cavity masking regimes, the hard case m = 0.01, and the Beckmann sampler (chi-square at
significance 0.01 with 1e6 samples per case: one case per setting and per angle in the default run, the full
settings x angles sweep with ``-m slow``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from tests.core.models._checks import (
    albedo_estimate,
    assert_sampler_exact,
    fresnel_reference,
    hard_case_grid_is_finite,
    sampler_sweep,
)

CT = get_model("cook_torrance")


def ct_reference(wi, wo, m, n, k, ks, kd):
    """Cook & Torrance: R = kd/pi + ks F D G / (pi (N.L)(N.V)), with alpha = angle(N, H),
    D = exp(-(tan(alpha)/m)^2) / (4 m^2 cos^4(alpha)) (SIGGRAPH '81 normalization),
    G = min(1, 2 (N.H)(N.V)/(V.H), 2 (N.H)(N.L)/(V.H)), F at cos = V.H."""
    h = np.add(wi, wo)
    h /= np.linalg.norm(h)
    alpha = math.acos(h[2])
    d = math.exp(-((math.tan(alpha) / m) ** 2)) / (4.0 * m * m * math.cos(alpha) ** 4)
    vh = float(np.dot(wo, h))
    g = min(1.0, 2.0 * h[2] * wo[2] / vh, 2.0 * h[2] * wi[2] / vh)
    f = fresnel_reference(vh, n, k)
    return kd / math.pi + ks * f * d * g / (math.pi * wi[2] * wo[2]), g


def test_reference_normal_incidence_defaults():
    # wi = wo = n: alpha = 0, D = 1 / (4 m^2), G = 1, F = ((n-1)^2 + k^2) / ((n+1)^2 + k^2); (N.L)(N.V) = 1.
    n, k, m = 0.617, 2.63, 0.35
    f0 = ((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k)
    expected = 0.3 / math.pi + 0.7 * f0 / (4.0 * m * m) / math.pi
    z = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(CT.bind().eval(z, z), [[expected] * 3], rtol=1e-12)


@pytest.mark.parametrize(
    ("wi_deg", "wo_deg", "masked"),
    [
        ((30.0, 0.0), (45.0, 160.0), False),  # near the specular direction: G = 1
        ((80.0, 0.0), (70.0, 120.0), True),  # oblique, out of plane: shadowing/masking active
        ((85.0, 10.0), (60.0, 10.0), True),  # same azimuth: strong masking
    ],
)
def test_reference_values(wi_deg, wo_deg, masked):
    m, n, k, ks, kd = 0.3, 1.2, 3.5, (0.9, 0.6, 0.3), (0.1, 0.2, 0.05)
    wi, wo = degrees_to_dir(*wi_deg), degrees_to_dir(*wo_deg)
    got = CT.bind(m=m, n_real=n, n_imag=k, ks=ks, kd=kd).eval(wo, wi)[0]
    for c in range(3):
        expected, g = ct_reference(wi, wo, m, n, k, ks[c], kd[c])
        assert got[c] == pytest.approx(expected, rel=1e-10)
        assert (g < 1.0) == masked


def test_hard_case_m_001():
    brdf = CT.bind(m=0.01)
    hard_case_grid_is_finite(brdf)
    # Peak at the mirror direction (h = n, V.H = N.V = c): D = 1 / (4 m^2) = 2500, G = min(1, 2 c / c) = 1,
    # so f = kd/pi + ks F(c) 2500 / (pi c^2): large at grazing incidence, but finite.
    for theta in (0.0, 45.0, 89.9):
        wo, wi = degrees_to_dir(theta, 0.0), degrees_to_dir(theta, 180.0)
        c = wo[2]
        n, k = 0.617, 2.63
        f = 0.3 / math.pi + 0.7 * fresnel_reference(c, n, k) * 2500.0 / (math.pi * c * c)
        assert brdf.eval(wo, wi)[0, 0] == pytest.approx(f, rel=1e-9)
    for theta in (89.9, 90.0):
        f = brdf.eval(
            degrees_to_dir(theta, 0.0), np.stack([degrees_to_dir(theta, 180.0), degrees_to_dir(89.9, 3.0)])
        )
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0)


def test_specular_albedo_is_the_fresnel_reflectance_for_smooth_surfaces():
    # With the SIGGRAPH '81 normalization the specular term is F D_B G / (4 cos cos), whose albedo for a
    # smooth surface (m = 0.05, G ~ 1) at moderate incidence equals F(cos theta_o) to about 1 %.
    n, k = 0.617, 2.63
    for theta in (0.0, 40.0):
        wo = degrees_to_dir(theta, 0.0)
        albedo, err = albedo_estimate(CT.bind(m=0.05, ks=1.0, kd=0.0), wo)
        assert albedo[0] == pytest.approx(fresnel_reference(wo[2], n, k), rel=0.015)


def test_traits():
    assert CT.reciprocal and CT.isotropic and not CT.energy_conserving


SAMPLER_SETTINGS = [{}, {"m": 0.1, "ks": 1.0, "kd": 0.05}, {"m": 0.8, "kd": (0.9, 0.2, 0.1)}]


@pytest.mark.parametrize(
    ("values", "theta"),
    sampler_sweep(SAMPLER_SETTINGS, [0.0, 50.0, 85.0], fast={(0, 50.0), (1, 85.0), (2, 0.0)}),
)
def test_sampler_is_exact(values, theta):
    assert_sampler_exact(CT.bind(values), theta)
