"""Exact Fresnel reflectance (core/models/_fresnel.py) against closed forms written independently here."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.models._fresnel import fresnel_conductor, fresnel_dielectric, fresnel_schlick

COSINES = np.concatenate([[1e-6, 1e-3], np.linspace(0.01, 1.0, 60)])
CONDUCTORS = [(0.617, 2.63), (0.37, 2.82), (0.2, 3.0), (1.5, 0.0), (2.9, 3.1), (0.05, 0.5)]


def conductor_real_form(c: float, n: float, k: float) -> float:
    """Born & Wolf's real-valued form for an absorbing medium (the one pbrt-v2 and Cook-Torrance's followers
    quote). With s = sin, t = tan of the incidence angle:

        a^2 + b^2 = sqrt((n^2 - k^2 - s^2)^2 + 4 n^2 k^2),   a^2 = ((a^2 + b^2) + n^2 - k^2 - s^2) / 2
        R_s = (a^2 + b^2 - 2 a c + c^2) / (a^2 + b^2 + 2 a c + c^2)
        R_p = R_s (a^2 + b^2 - 2 a s t + s^2 t^2) / (a^2 + b^2 + 2 a s t + s^2 t^2)

    valid for c > 0 (t is infinite at grazing incidence)."""
    s2 = 1.0 - c * c
    s = math.sqrt(s2)
    t = s / c
    a2b2 = math.sqrt((n * n - k * k - s2) ** 2 + 4.0 * n * n * k * k)
    a = math.sqrt(0.5 * (a2b2 + n * n - k * k - s2))
    rs = (a2b2 - 2.0 * a * c + c * c) / (a2b2 + 2.0 * a * c + c * c)
    rp = rs * (a2b2 - 2.0 * a * s * t + s2 * t * t) / (a2b2 + 2.0 * a * s * t + s2 * t * t)
    return 0.5 * (rs + rp)


def dielectric_cook_torrance_form(c: float, eta: float) -> float:
    """Cook & Torrance (1982), eq. in sec. 2.4: g^2 = eta^2 + c^2 - 1,
    F = 1/2 (g - c)^2 / (g + c)^2 (1 + (c (g + c) - 1)^2 / (c (g - c) + 1)^2)."""
    g = math.sqrt(eta * eta + c * c - 1.0)
    return 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1.0 + (c * (g + c) - 1.0) ** 2 / (c * (g - c) + 1.0) ** 2)


@pytest.mark.parametrize(("n", "k"), CONDUCTORS)
def test_conductor_normal_incidence(n, k):
    expected = ((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k)
    assert fresnel_conductor(1.0, n, k) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize(("n", "k"), CONDUCTORS)
def test_conductor_grazing_is_one(n, k):
    assert fresnel_conductor(0.0, n, k) == 1.0
    # Continuity towards grazing: 1 - R is O(cos) there.
    assert 1.0 - fresnel_conductor(1e-9, n, k) < 1e-7


@pytest.mark.parametrize(("n", "k"), CONDUCTORS)
def test_conductor_matches_born_and_wolf_real_form(n, k):
    for c in COSINES:
        assert fresnel_conductor(float(c), n, k) == pytest.approx(
            conductor_real_form(float(c), n, k), rel=1e-9
        )


@pytest.mark.parametrize("eta", [1.0001, 1.33, 1.5, 2.4, 4.0])
def test_dielectric_matches_cook_torrance_form(eta):
    for c in COSINES:
        assert fresnel_dielectric(float(c), eta) == pytest.approx(
            dielectric_cook_torrance_form(float(c), eta), rel=1e-9, abs=1e-15
        )
    assert fresnel_dielectric(1.0, eta) == pytest.approx(((eta - 1.0) / (eta + 1.0)) ** 2, rel=1e-13)
    assert fresnel_dielectric(0.0, eta) == 1.0


def test_dielectric_is_a_conductor_without_absorption():
    for c in COSINES:
        assert fresnel_conductor(float(c), 1.5, 0.0) == pytest.approx(
            fresnel_dielectric(float(c), 1.5), rel=1e-13
        )


def test_dielectric_from_inside_total_internal_reflection():
    eta = 1.5
    critical_cos = math.sqrt(1.0 - 1.0 / eta**2)  # sin(theta_c) = 1 / eta seen from inside
    assert fresnel_dielectric(-(critical_cos * 0.99), eta) == pytest.approx(1.0, abs=1e-12)
    # Above the critical angle from inside: Stokes relation, same reflectance as the matching outside ray.
    c_in = 0.95
    s_out = eta * math.sqrt(1.0 - c_in * c_in)
    c_out = math.sqrt(1.0 - s_out * s_out)
    assert fresnel_dielectric(-c_in, eta) == pytest.approx(fresnel_dielectric(c_out, eta), rel=1e-12)


def test_no_interface_reflects_nothing():
    for c in (0.0, 0.3, 1.0):
        assert fresnel_dielectric(c, 1.0) == pytest.approx(0.0, abs=1e-15)


def test_values_in_unit_interval_and_sign_of_cosine():
    for n, k in CONDUCTORS:
        for c in np.linspace(-1.0, 1.0, 41):
            r = fresnel_conductor(float(c), n, k)
            assert 0.0 <= r <= 1.0
            assert r == fresnel_conductor(abs(float(c)), n, k)


def test_schlick_endpoints():
    assert fresnel_schlick(1.0, 0.04) == pytest.approx(0.04)
    assert fresnel_schlick(0.0, 0.04) == 1.0
    assert fresnel_schlick(0.5, 0.04) == pytest.approx(0.04 + 0.96 * 0.5**5)


def test_conductor_real_arithmetic_equals_the_complex_form():
    """``fresnel_conductor`` (real arithmetic, the fast path of the microfacet models) against the complex
    amplitude form it replaces, over indices from nearly-vacuum to strongly absorbing and cosines down to
    1e-12 (where the real form's ``a`` would cancel without its alternative expression). Relative agreement
    1e-10; where the reflectance is below ~1e-5 (an index within 1e-2 of vacuum) both forms cancel and agree
    to 1e-15 absolute."""
    from core.models._fresnel import _fresnel_complex

    ns = np.geomspace(0.01, 10.0, 13)
    ks = np.concatenate([[0.0, 1e-9, 1e-4], np.geomspace(0.01, 30.0, 12)])
    cs = np.concatenate([[0.0, 1e-12, 1e-9, 1e-6, 1e-3], np.linspace(0.01, 1.0, 25)])
    for n in ns:
        for k in ks:
            for c in cs:
                fast = fresnel_conductor(float(c), float(n), float(k))
                ref = _fresnel_complex(float(c), complex(float(n), float(k)))
                assert 0.0 <= fast <= 1.0 and math.isfinite(fast)
                assert abs(fast - ref) <= 1e-10 * ref + 1e-15, (n, k, c, fast, ref)
