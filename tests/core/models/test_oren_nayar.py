"""Oren-Nayar (1994), full model: reference values from the paper's equations, normal incidence, bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir, spherical_to_dir
from core.models.oren_nayar import SIGMA_MAX


def _paper(theta_i, theta_o, dphi, sigma, rho):
    """Oren & Nayar 1994, eqs. for L1 (C1, C2, C3) and L2, divided by E0 cos(theta_i); angles in radians."""
    s2 = sigma * sigma
    alpha, beta = max(theta_i, theta_o), min(theta_i, theta_o)
    c = math.cos(dphi)
    c1 = 1 - 0.5 * s2 / (s2 + 0.33)
    if c >= 0:
        c2 = 0.45 * s2 / (s2 + 0.09) * math.sin(alpha)
    else:
        c2 = 0.45 * s2 / (s2 + 0.09) * (math.sin(alpha) - (2 * beta / math.pi) ** 3)
    c3 = 0.125 * s2 / (s2 + 0.09) * (4 * alpha * beta / math.pi**2) ** 2
    l1 = rho / math.pi * (c1 + c * c2 * math.tan(beta) + (1 - abs(c)) * c3 * math.tan((alpha + beta) / 2))
    l2 = 0.17 * rho**2 / math.pi * s2 / (s2 + 0.13) * (1 - c * (2 * beta / math.pi) ** 2)
    return l1 + l2


def _f(values, wi, wo):
    return get_model("oren_nayar").bind(values).eval(np.asarray(wo), np.asarray(wi))[0]


def test_reference_value_in_plane_backward():
    # sigma = 0.3, rho = 0.8, theta_i = 30, theta_o = 60, same azimuth (cos_phi = 1, C3 term drops):
    # C1 = 1 - 0.5*0.09/0.42 = 0.8928571; C2 = 0.45*0.09/0.18*sin 60 = 0.225*0.8660254 = 0.1948557;
    # direct = C1 + C2 tan 30 = 0.8928571 + 0.1948557*0.5773503 = 1.0053571;
    # L2 factor = 0.17*0.09/0.22*(1 - (1/3)^2) = 0.0695455*0.8888889 = 0.0618182;
    # f = 0.8/pi * (1.0053571 + 0.8*0.0618182) = 0.2546479*1.0548117 = 0.2686057.
    f = _f({"sigma": 0.3, "rho": 0.8}, degrees_to_dir(30.0, 25.0), degrees_to_dir(60.0, 25.0))
    np.testing.assert_allclose(f, 0.2686057, rtol=2e-6)
    np.testing.assert_allclose(f, _paper(math.radians(30), math.radians(60), 0.0, 0.3, 0.8), rtol=1e-12)


def test_reference_value_forward_branch_and_colour():
    # cos_phi = -1 selects C2 = 0.45 s2/(s2+0.09) (sin alpha - (2 beta/pi)^3) and adds (2 beta/pi)^2 to L2.
    # sigma = 0.5, rho = (0.2, 0.5, 0.9), theta_i = 70, theta_o = 45, azimuths 10 and 190:
    # s2 = 0.25: C1 = 1 - 0.125/0.58 = 0.7844828; g = 0.1125/0.34 = 0.3308824;
    # C2 = g (sin 70 - 0.5^3) = 0.3308824*(0.9396926 - 0.125) = 0.2695674; tan 45 = 1;
    # direct = 0.7844828 - 0.2695674 = 0.5149153; L2 = 0.17*0.25/0.38*(1 + 0.25) = 0.1398026.
    rho = np.array([0.2, 0.5, 0.9])
    expected = rho / math.pi * (0.5149153 + rho * 0.1398026)
    f = _f({"sigma": 0.5, "rho": tuple(rho)}, degrees_to_dir(70.0, 10.0), degrees_to_dir(45.0, 190.0))
    np.testing.assert_allclose(f, expected, rtol=2e-6)


def test_matches_the_paper_on_random_directions(rng):
    model = get_model("oren_nayar")
    for _ in range(3):
        sigma = float(rng.uniform(0.0, SIGMA_MAX))
        rho = float(rng.uniform(0.05, 1.0))
        ti, to = rng.uniform(0.0, 0.5 * math.pi, size=(2, 50))
        pi_, po = rng.uniform(0.0, 2 * math.pi, size=(2, 50))
        f = model.bind(sigma=sigma, rho=rho).eval(spherical_to_dir(to, po), spherical_to_dir(ti, pi_))[:, 0]
        ref = [_paper(a, b, c - d, sigma, rho) for a, b, c, d in zip(ti, to, po, pi_, strict=True)]
        np.testing.assert_allclose(f, ref, rtol=1e-10)


def test_sigma_zero_is_lambert():
    w = spherical_to_dir(np.radians([0.0, 20.0, 55.0, 89.9]), np.radians([0.0, 90.0, 200.0, 10.0]))
    f = get_model("oren_nayar").bind(sigma=0.0, rho=0.7).eval(w, w[::-1])
    np.testing.assert_allclose(f, 0.7 / math.pi, rtol=1e-14)


@pytest.mark.parametrize("which", ["wo", "wi"])
def test_normal_incidence_is_continuous(which):
    # At wo = n (or wi = n) the azimuth is undefined; the value must be the limit from nearby directions,
    # whatever their azimuth.
    brdf = get_model("oren_nayar").bind(sigma=0.6, rho=0.9)
    other = degrees_to_dir(50.0, 30.0)
    normal = np.array([0.0, 0.0, 1.0])

    def f(a):
        return brdf.eval(a, other) if which == "wo" else brdf.eval(other, a)

    at_normal = f(normal)[0]
    assert np.all(np.isfinite(at_normal))
    for eps in (1e-3, 1e-6, 1e-9, 1e-200):
        for phi in np.radians([0.0, 30.0, 77.0, 180.0, 210.0, 300.0]):
            near = np.array([eps * math.cos(phi), eps * math.sin(phi), math.sqrt(1.0 - eps * eps)])
            np.testing.assert_allclose(f(near)[0], at_normal, rtol=5.0 * eps + 1e-12)
    # Both directions at the normal: the Lambert-like constant C1 plus the interreflection term.
    s2 = 0.36
    expected = 0.9 / math.pi * (1 - 0.5 * s2 / (s2 + 0.33) + 0.9 * 0.17 * s2 / (s2 + 0.13))
    np.testing.assert_allclose(brdf.eval(normal, normal)[0], expected, rtol=1e-12)


def test_grazing_is_finite_and_non_negative_at_the_bound():
    # The worst case for the sign: sigma at its bound, forward azimuth, both directions near the horizon.
    brdf = get_model("oren_nayar").bind(sigma=SIGMA_MAX, rho=0.0001)
    zs = np.array([1e-2, 1e-4, 1e-8, 1e-300])
    wo = np.stack([np.sqrt(1 - zs**2), np.zeros_like(zs), zs], axis=1)
    wi = wo * np.array([-1.0, 1.0, 1.0])
    for f in (brdf.eval(wo, wi), brdf.eval(wi, wo)):
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    f = brdf.eval(wo, wo)  # retro-reflection at grazing: large but finite
    assert np.all(np.isfinite(f))


def test_formula_turns_negative_just_above_the_bound():
    # Why sigma stops at 0.66: just past the root 0.6644 of C1 = 0.45 s2/(s2+0.09) * 6/pi, the published
    # formula is negative for forward grazing pairs with a small albedo.
    beta = math.pi / 2 - 1e-7
    assert _paper(beta, beta, math.pi, 0.70, 1e-4) < 0.0
    assert _paper(beta, beta, math.pi, SIGMA_MAX, 1e-4) > 0.0
