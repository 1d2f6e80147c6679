"""Beard-Maxwell (NEF form): reference values from the model's equation, shadowing limits, grazing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from tests.core.models._checks import fresnel_reference


def _model(wi, wo, omega, tau, n, k, rs, rd, rv, m):
    """Westlund & Meyer eq. 10 with rho_fs cos^2 = rs D_Beckmann / 4 (see the module docstring)."""
    h = (wi + wo) / np.linalg.norm(wi + wo)
    theta_n = math.acos(min(1.0, h[2]))
    beta = math.acos(min(1.0, float(wi @ h)))
    so = (1 + theta_n / omega * (math.exp(-2 * beta / tau) if tau > 0 else 0.0)) / (1 + theta_n / omega)
    d = math.exp(-(math.tan(theta_n) ** 2) / m**2) / (math.pi * m**2 * math.cos(theta_n) ** 4)
    ratio = fresnel_reference(math.cos(beta), n, k) / fresnel_reference(1.0, n, k)
    first = ratio * rs * d * so / (4 * wi[2] * wo[2])
    return first + rd / math.pi + 2 * rv / (math.pi * (wi[2] + wo[2]))


SEED = {"omega": 1.0, "tau": 0.0, "n": 0.37, "k": 2.82, "rs": 0.4, "rd": 0.75, "rv": 0.5, "m": 0.3}


def _f(values, wi, wo):
    return get_model("beard_maxwell").bind(values).eval(np.asarray(wo), np.asarray(wi))[0]


def test_reference_value_normal_incidence_and_view():
    # wi = wo = n: theta_N = 0, beta = 0, Fresnel ratio 1, SO = 1, D(0) = 1/(pi m^2) with m = 0.3.
    # f = rs/(4 pi m^2) + (rd + rv)/pi = 0.4/1.1309734 + 1.25/pi = 0.3536777 + 0.3978874 = 0.7515651.
    n = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(_f({}, n, n), 0.7515651, rtol=1e-6)


def test_reference_value_specular_geometry():
    # Mirror pair at 40 deg: h = n, theta_N = 0 so SO = 1 and D = 1/(pi m^2); beta = 40 deg.
    # R(40)/R(0) for n = 0.37 + 2.82i from the Born & Wolf formula (computed here, independently of the
    # kernel's Fresnel): f = ratio rs/(4 pi m^2 cos^2 40) + rd/pi + 2 rv/(pi 2 cos 40).
    c = math.cos(math.radians(40.0))
    ratio = fresnel_reference(c, 0.37, 2.82) / fresnel_reference(1.0, 0.37, 2.82)
    expected = ratio * 0.4 / (4 * math.pi * 0.09 * c * c) + 0.75 / math.pi + 2 * 0.5 / (math.pi * 2 * c)
    f = _f({}, degrees_to_dir(40.0, 30.0), degrees_to_dir(40.0, 210.0))
    np.testing.assert_allclose(f, expected, rtol=1e-9)
    # R(0) = ((n-1)^2 + k^2)/((n+1)^2 + k^2) = (0.3969 + 7.9524)/(1.8769 + 7.9524) = 8.3493/9.8293 = 0.8494298.
    np.testing.assert_allclose(fresnel_reference(1.0, 0.37, 2.82), 0.8494298, rtol=1e-6)


@pytest.mark.parametrize(
    ("angles", "values"),
    [
        (((30.0, 0.0), (50.0, 120.0)), {"omega": 0.2, "tau": 0.5, "m": 0.5}),
        (((70.0, 10.0), (20.0, 170.0)), {"omega": 3.0, "tau": 2.0, "n_real": 1.5, "n_imag": 0.0}),
        (((10.0, 45.0), (80.0, 300.0)), {"m": 0.05, "rs": (0.1, 0.5, 0.9)}),
        (((60.0, 0.0), (60.0, 0.0)), {"tau": 0.3}),  # retro-reflection: beta = 0, SO = 1
    ],
)
def test_matches_the_equation(angles, values):
    (ti, pi_), (to, po) = angles
    wi, wo = degrees_to_dir(ti, pi_), degrees_to_dir(to, po)
    bound = get_model("beard_maxwell").resolve(values)
    expected = [
        _model(
            wi,
            wo,
            bound["omega"],
            bound["tau"],
            bound["n_real"],
            bound["n_imag"],
            bound["rs"][c],
            bound["rd"][c],
            bound["rv"][c],
            bound["m"],
        )
        for c in range(3)
    ]
    np.testing.assert_allclose(_f(values, wi, wo), expected, rtol=1e-9)


def test_tau_zero_is_the_limit_of_small_tau():
    wi, wo = degrees_to_dir(35.0, 0.0), degrees_to_dir(55.0, 150.0)
    sharp = _f({"tau": 0.0}, wi, wo)
    np.testing.assert_allclose(_f({"tau": 1e-4}, wi, wo), sharp, rtol=1e-12)
    assert np.all(_f({"tau": 5.0}, wi, wo) > sharp)  # less shadowing with a broad tau


def test_grazing_is_finite():
    brdf = get_model("beard_maxwell").bind(m=0.01)
    zs = np.array([1e-3, 1e-6, 1e-9, 1e-300])
    w = np.stack([np.sqrt(1 - zs**2), np.zeros_like(zs), zs], axis=1)
    mirror = w * np.array([-1.0, 1.0, 1.0])
    for a, b in ((w, w), (w, mirror), (w, np.tile([0.0, 0.0, 1.0], (4, 1)))):
        f = brdf.eval(a, b)
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    assert np.all(brdf.eval(degrees_to_dir(90.0), degrees_to_dir(30.0)) == 0.0)
