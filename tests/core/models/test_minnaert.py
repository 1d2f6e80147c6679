"""Minnaert (1941): reference values from the law itself, the horizon for k < 1, and the albedo formula."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir, spherical_to_dir
from core.models.minnaert import COS_FLOOR


def _f(values, wi, wo):
    return get_model("minnaert").bind(values).eval(np.asarray(wo), np.asarray(wi))[0]


def test_reference_value_seed_defaults():
    # Seed defaults k = 0.8, kd = 1; theta_i = 30, theta_o = 60 (any azimuths: the law has none).
    # f = 1/pi * (cos 30 cos 60)^(-0.2) = (0.8660254 * 0.5)^(-0.2) / pi = 0.4330127^(-0.2) / pi
    #   = exp(0.2 * 0.8369882) / pi = 1.1822200 / pi = 0.3763136.
    f = _f({}, degrees_to_dir(30.0, 10.0), degrees_to_dir(60.0, 200.0))
    np.testing.assert_allclose(f, 0.3763136, rtol=1e-6)


def test_reference_value_limb_darkening_colour():
    # k = 1.5 (limb darkening), kd = (0.2, 0.5, 0.9); theta_i = 0, theta_o = 45:
    # f = kd/pi * (1 * cos 45)^0.5 = kd/pi * 0.7071068^0.5 = kd/pi * 0.8408964 = kd * 0.2676656.
    f = _f({"k": 1.5, "kd": (0.2, 0.5, 0.9)}, degrees_to_dir(0.0), degrees_to_dir(45.0, 90.0))
    np.testing.assert_allclose(f, np.array([0.2, 0.5, 0.9]) * 0.2676656, rtol=1e-6)


def test_k_one_is_lambert():
    w = spherical_to_dir(np.radians([0.0, 33.0, 71.0, 89.0]), np.radians([0.0, 40.0, 170.0, 300.0]))
    f = get_model("minnaert").bind(k=1.0, kd=0.6).eval(w, w[::-1])
    np.testing.assert_allclose(f, 0.6 / math.pi, rtol=1e-12)


@pytest.mark.parametrize("k", [0.0, 0.3, 0.8])
def test_horizon_for_k_below_one(k):
    brdf = get_model("minnaert").bind(k=k, kd=1.0)
    wi = degrees_to_dir(20.0)
    # 89.9 degrees is far above the floor: the law holds exactly there.
    c = math.cos(math.radians(89.9))
    exact = (math.cos(math.radians(20.0)) * c) ** (k - 1.0) / math.pi
    np.testing.assert_allclose(brdf.eval(degrees_to_dir(89.9), wi)[0], exact, rtol=1e-9)
    # Exactly 90 degrees (z = 0) is on the horizon: 0, like every model; never NaN/Inf.
    assert np.all(brdf.eval(degrees_to_dir(90.0), wi)[0] == 0.0)
    # Just above the horizon the value is finite and grows monotonically toward it, then saturates at
    # the documented floor (the value at cos = COS_FLOOR).
    zs = np.array([1e-1, 1e-2, 1e-3, 1e-4, 1e-5, COS_FLOOR, 1e-9, 1e-300])
    wo = np.stack([np.sqrt(1 - zs**2), np.zeros_like(zs), zs], axis=1)
    f = brdf.eval(wo, wi)[:, 0]
    assert np.all(np.isfinite(f))
    if k < 1.0:
        assert np.all(np.diff(f[:6]) > 0.0)
    floor_value = (math.cos(math.radians(20.0)) * COS_FLOOR) ** (k - 1.0) / math.pi
    np.testing.assert_allclose(f[5:], floor_value, rtol=1e-9)
    # Both directions grazing at once (the worst case): still finite.
    g = brdf.eval(wo[-1], wo[-1])
    assert np.all(np.isfinite(g)) and np.all(g > 0.0)


@pytest.mark.parametrize(("k", "theta_o"), [(0.8, 0.0), (0.8, 60.0), (0.8, 89.0), (0.3, 75.0), (1.6, 40.0)])
def test_albedo_matches_the_closed_form(k, theta_o):
    # rho(theta_o) = int f cos_i dw_i = kd/pi cos_o^(k-1) * 2 pi int_0^1 mu^k dmu = 2 kd/(k+1) cos_o^(k-1).
    # Quadrature: mu = t^2 removes the mu^k kink at 0 (integrand 2 t^(2k+1) dt), Gauss-Legendre in t,
    # midpoint in azimuth (the law has no azimuth dependence, so this checks the kernel, not the rule).
    kd = 0.7
    t, wt = np.polynomial.legendre.leggauss(48)
    t = 0.5 * (t + 1.0)
    wt = 0.5 * wt
    mu = t * t
    phi = (np.arange(8) + 0.5) * (2 * np.pi / 8)
    m, ph = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - m**2)
    wi = np.stack([s * np.cos(ph), s * np.sin(ph), m], axis=-1).reshape(-1, 3)
    wo = degrees_to_dir(theta_o, 15.0)
    f = get_model("minnaert").bind(k=k, kd=kd).eval(wo, wi)[:, 0].reshape(m.shape)
    weight = (wt * 2.0 * t)[:, None] * (2 * np.pi / 8)  # d mu = 2 t dt
    rho = float(np.sum(f * m * weight))
    expected = 2.0 * kd / (k + 1.0) * math.cos(math.radians(theta_o)) ** (k - 1.0)
    np.testing.assert_allclose(rho, expected, rtol=1e-6)
