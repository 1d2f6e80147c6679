"""Strauss (1990): reference values from the paper's formulas, grazing light and view, honest traits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from core.models.strauss import COS_FLOOR


def _paper(theta_i, theta_o, dphi, s, m, t, colour, kd=1.0, ks=1.0):
    """Strauss 1990 intensity for a unit light, divided by pi cos(theta_i); angles in radians."""
    kf, kg, kj = 1.12, 1.01, 0.1

    def fresnel(x):
        return (1 / (x - kf) ** 2 - 1 / kf**2) / (1 / (1 - kf) ** 2 - 1 / kf**2)

    def shadow(x):
        return (1 / (1 - kg) ** 2 - 1 / (x - kg) ** 2) / (1 / (1 - kg) ** 2 - 1 / kg**2)

    colour = np.asarray(colour, dtype=float)
    d = 1 - m * s
    rd = (1 - s**3) * (1 - t)
    rn = (1 - t) - rd
    h = 3 / (1 - s)
    xi, xo = theta_i / (math.pi / 2), theta_o / (math.pi / 2)
    j = fresnel(xi) * shadow(xi) * shadow(xo)
    rj = min(1.0, rn + (rn + kj) * j)
    cs = 1 + m * (1 - fresnel(xi)) * (colour - 1)
    # Mirror of the light direction (theta_i, phi_i) is (theta_i, phi_i + pi).
    r_dot_v = math.cos(theta_i) * math.cos(theta_o) - math.sin(theta_i) * math.sin(theta_o) * math.cos(dphi)
    q_d = math.cos(theta_i) * d * rd * colour
    q_s = max(r_dot_v, 0.0) ** h * rj * cs
    return (kd * q_d + ks * q_s) / (math.pi * math.cos(theta_i))


def _f(values, wi, wo):
    return get_model("strauss").bind(values).eval(np.asarray(wo), np.asarray(wi))[0]


PUBLISHED = {"kd": 1.0, "ks": 1.0}


def test_reference_value_at_normal_incidence():
    # Strauss as published (kd = ks = 1), C = (0.9, 0.5, 0.2), s = 0.5, m = 0.5, t = 0, light and view
    # along the normal: d = 0.75, r_d = 0.875, r_n = 0.125, F(0) = 0 so j = 0 and r_j = 0.125; the mirror
    # direction is the view, so the lobe is 1; C_s = 1 + 0.5 (C - 1) = (0.95, 0.75, 0.6).
    # f = (0.65625 C + 0.125 C_s) / pi = (0.709375, 0.421875, 0.20625) / pi.
    values = dict(PUBLISHED, s=0.5, m=0.5, t=0.0, color=(0.9, 0.5, 0.2))
    n = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(
        _f(values, n, n), np.array([0.709375, 0.421875, 0.20625]) / math.pi, rtol=1e-12
    )


def test_reference_value_seed_defaults_off_normal():
    # Seed defaults s = 0.76, m = 0.91, kd = 0.5, ks = 0.64, white, opaque; light at 60 deg, view at 40 deg in
    # the plane of incidence on the mirror side (azimuth difference 180 deg): R.V = cos(20 deg).
    # h = 3/0.24 = 12.5; r_d = (1 - 0.438976) = 0.561024; d = 1 - 0.6916 = 0.3084; r_n = 0.438976;
    # x_i = 2/3, x_o = 4/9: F(2/3) = 0.0592700, G(2/3) = 0.9992496, G(4/9) = 0.9997854 -> j = 0.0592128,
    # r_j = 0.438976 + 0.538976*0.0592128 = 0.4708903; lobe = 0.9396926^12.5 = 0.4595393;
    # f = 0.5*0.3084*0.561024/pi + 0.64*0.4595393*0.4708903/(pi*0.5) = 0.0275370 + 0.0881663 = 0.1157032.
    f = _f({}, degrees_to_dir(60.0, 0.0), degrees_to_dir(40.0, 180.0))
    np.testing.assert_allclose(f, 0.1157032, rtol=2e-6)
    ref = _paper(math.radians(60), math.radians(40), math.pi, 0.76, 0.91, 0.0, (1, 1, 1), 0.5, 0.64)
    np.testing.assert_allclose(f, ref, rtol=1e-12)


def test_matches_the_paper_on_random_settings(rng):
    model = get_model("strauss")
    for _ in range(4):
        s, m, t = rng.uniform(0.0, 0.99), rng.uniform(0, 1), rng.uniform(0, 1)
        colour = tuple(rng.uniform(0, 1, 3))
        kd, ks = tuple(rng.uniform(0, 1, 3)), tuple(rng.uniform(0, 1, 3))
        brdf = model.bind(s=s, m=m, t=t, color=colour, kd=kd, ks=ks)
        for _ in range(20):
            ti, to = rng.uniform(0, math.radians(89.0), 2)
            pi_, po = rng.uniform(0, 2 * math.pi, 2)
            wi = np.array([math.sin(ti) * math.cos(pi_), math.sin(ti) * math.sin(pi_), math.cos(ti)])
            wo = np.array([math.sin(to) * math.cos(po), math.sin(to) * math.sin(po), math.cos(to)])
            ref = _paper(ti, to, po - pi_, s, m, t, colour, np.asarray(kd), np.asarray(ks))
            np.testing.assert_allclose(brdf.eval(wo, wi)[0], ref, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("values", [{}, {"s": 0.999, "m": 0.0}, {"s": 0.0, "m": 1.0, "t": 0.5}])
def test_grazing_light_and_view(values):
    brdf = get_model("strauss").bind(values)
    model_values = get_model("strauss").resolve(values)
    wo = degrees_to_dir(30.0, 180.0)
    # 89.9 deg is well above the floor: the formula holds exactly.
    ref = _paper(
        math.radians(89.9),
        math.radians(30.0),
        math.pi,
        model_values["s"],
        model_values["m"],
        model_values["t"],
        model_values["color"],
        np.asarray(model_values["kd"]),
        np.asarray(model_values["ks"]),
    )
    np.testing.assert_allclose(brdf.eval(wo, degrees_to_dir(89.9))[0], ref, rtol=1e-9)
    # Exactly 90 deg: on the horizon, 0. Just above it: finite, and f cos_i stays bounded.
    assert np.all(brdf.eval(wo, degrees_to_dir(90.0)) == 0.0)
    zs = np.array([1e-3, 1e-6, 1e-12, 1e-300])
    wi = np.stack([np.sqrt(1 - zs**2), np.zeros_like(zs), zs], axis=1)
    for a, b in ((wo, wi), (wi, wo), (wi * np.array([-1.0, 1.0, 1.0]), wi), (wi, wi)):
        f = brdf.eval(a, b)
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    # f cos_i = (kd d r_d C cos_i + ks r_j C_s lobe) / pi <= 2 / pi: each factor is at most 1.
    f_cos = brdf.eval(wi * np.array([-1.0, 1.0, 1.0]), wi) * np.maximum(zs, COS_FLOOR)[:, None]
    assert np.all(f_cos <= 2.0 / math.pi + 1e-12)


def test_not_reciprocal_as_declared():
    brdf = get_model("strauss").bind()
    a, b = degrees_to_dir(20.0, 0.0), degrees_to_dir(70.0, 180.0)
    fa, fb = brdf.eval(a, b)[0], brdf.eval(b, a)[0]
    assert not np.allclose(fa, fb, rtol=1e-3)
    assert not get_model("strauss").reciprocal
