"""Lafortune et al. (1997), one generalized cosine lobe plus Lambert:
f = kd/pi + kp max(0, cx wi.x wo.x + cy wi.y wo.y + cz wi.z wo.z)^n. Reference values are worked out here."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from tests.core.models._checks import (
    assert_albedo_estimate_matches,
    assert_pdf_integrates_to_one,
    assert_sample_matches_pdf,
    eval_degrees,
)

MODEL = get_model("lafortune")


def test_declaration_matches_the_seed():
    d = MODEL.defaults()
    assert (d["cx"], d["cy"], d["cz"], d["n"], d["kp"]) == (-1.0, -1.0, 1.0, 100.0, (0.96, 0.96, 0.96))
    assert d["kd"] == (0.0, 0.0, 0.0)  # not in the seed's table: the seed's model is the lobe alone
    assert MODEL.reciprocal and not MODEL.isotropic and not MODEL.energy_conserving


def test_reference_value_at_normal_incidence():
    # wo = wi = n = (0, 0, 1): the base is cz * 1 * 1 = 1, so f = kd/pi + kp = 0.96 at the seed's values.
    np.testing.assert_allclose(eval_degrees(MODEL.bind(), (0, 0), (0, 0)), [0.96] * 3, rtol=1e-12)


def test_reference_value_of_the_phong_like_lobe():
    # C = (-1, -1, 1), wo = (sin30, 0, cos30), wi = (-sin40, 0, cos40) (theta 40, phi 180):
    # base = -sin30 * (-sin40) + cos30 cos40 = cos(40 - 30 deg) = cos(10 deg); f = kp cos^100(10 deg) + kd/pi.
    kp = np.array([0.9, 0.5, 0.2])
    kd = np.array([0.1, 0.2, 0.3])
    brdf = MODEL.bind(kp=tuple(kp), kd=tuple(kd))
    expected = kd / math.pi + kp * math.cos(math.radians(10)) ** 100
    np.testing.assert_allclose(eval_degrees(brdf, (30, 0), (40, 180)), expected, rtol=1e-12)


def test_reference_value_of_an_anisotropic_off_specular_lobe():
    # C = (-0.8, -1.05, 0.6), n = 3.5. wo = (theta 45, phi 30), wi = (theta 60, phi 200), componentwise:
    # wo = (sin45 cos30, sin45 sin30, cos45) = (0.61237, 0.35355, 0.70711)
    # wi = (sin60 cos200, sin60 sin200, cos60) = (-0.81380, -0.29620, 0.5)
    # base = -0.8 * 0.61237 * -0.81380 - 1.05 * 0.35355 * -0.29620 + 0.6 * 0.70711 * 0.5
    #      = 0.39868 + 0.10996 + 0.21213 = 0.72077
    wo = [math.sin(math.radians(45)) * math.cos(math.radians(30)), math.sin(math.radians(45)) * 0.5]
    wo.append(math.cos(math.radians(45)))
    wi = [math.sin(math.radians(60)) * math.cos(math.radians(200))]
    wi += [math.sin(math.radians(60)) * math.sin(math.radians(200)), 0.5]
    base = -0.8 * wo[0] * wi[0] - 1.05 * wo[1] * wi[1] + 0.6 * wo[2] * wi[2]
    assert abs(base - 0.72077) < 1e-5
    brdf = MODEL.bind(cx=-0.8, cy=-1.05, cz=0.6, n=3.5, kp=(1.0, 0.5, 0.25), kd=0.0)
    np.testing.assert_allclose(
        eval_degrees(brdf, (45, 30), (60, 200)), np.array([1.0, 0.5, 0.25]) * base**3.5, rtol=1e-12
    )
    # Anisotropic: rotating both directions about the normal changes the value.
    assert not np.allclose(eval_degrees(brdf, (45, 30), (60, 200)), eval_degrees(brdf, (45, 75), (60, 245)))


def test_retro_reflective_lobe_and_its_negative_base():
    # C = (1, 1, 1): the base is wo . wi. Retro-reflection wi = wo gives base 1: f = kd/pi + kp.
    brdf = MODEL.bind(cx=1.0, cy=1.0, cz=1.0, n=2.5, kp=0.8, kd=0.2)
    np.testing.assert_allclose(eval_degrees(brdf, (60, 0), (60, 0)), [0.2 / math.pi + 0.8] * 3, rtol=1e-12)
    # The mirror configuration at 60 deg: base = -sin^2(60) + cos^2(60) = -0.5 < 0; (-0.5)^2.5 is undefined,
    # the base is clamped at 0 and only the diffuse part is left.
    np.testing.assert_allclose(eval_degrees(brdf, (60, 0), (60, 180)), [0.2 / math.pi] * 3, rtol=1e-12)


@pytest.mark.parametrize("n", [0.1, 2.5, 100.0, 5000.0])
def test_negative_base_never_gives_nan(n):
    thetas = [0.0, 30.0, 60.0, 85.0, 89.0, 89.9, 90.0]
    w = np.array([degrees_to_dir(t, p) for t in thetas for p in (0.0, 90.0, 180.0, 271.0)])
    wo, wi = np.repeat(w, len(w), axis=0), np.tile(w, (len(w), 1))
    for c in [(1.0, 1.0, 1.0), (1.1, -1.1, 0.3), (-1.0, -1.0, -1.0), (1.1, 1.1, 1.1)]:
        values = MODEL.bind(cx=c[0], cy=c[1], cz=c[2], n=n).eval(wo, wi)
        assert np.all(np.isfinite(values)) and np.all(values >= 0.0), f"C={c}, n={n}"
        assert np.all(values[(wo[:, 2] == 0.0) | (wi[:, 2] == 0.0)] == 0.0)


def test_zero_base_with_a_tiny_exponent_is_zero():
    # cz = 0 and wo, wi in perpendicular vertical planes: the base is exactly 0, and the lobe is 0 at the
    # smallest exponent too (the bounds keep n > 0, so pow(0, 0) = 1 cannot appear).
    brdf = MODEL.bind(cz=0.0, n=0.1, kd=0.0)
    s = math.sqrt(0.5)
    value = brdf.eval(np.array([s, 0.0, s]), np.array([0.0, s, s]))[0]
    assert np.all(value == 0.0)


def test_largest_lobe_is_finite():
    # |C| = 1.1 and n = 5000 at retro-reflection, wo = wi = n: 1.1^5000 = exp(5000 ln 1.1) ~ 1.3e207.
    brdf = MODEL.bind(cx=1.1, cy=1.1, cz=1.1, n=5000.0, kp=1.0, kd=0.0)
    value = eval_degrees(brdf, (0, 0), (0, 0))
    np.testing.assert_allclose(value, [math.exp(5000 * math.log(1.1))] * 3, rtol=1e-9)


@pytest.mark.parametrize(
    "values",
    [
        {"cx": 1.0, "cy": 1.0, "cz": 1.0, "n": 8.0, "kd": (0.2, 0.1, 0.3)},  # retro-reflective
        {"cx": -0.8, "cy": -1.05, "cz": 0.6, "n": 12.0, "kd": (0.1, 0.1, 0.1)},  # anisotropic, off-specular
        {"cx": -1.0, "cy": -1.0, "cz": -0.5, "n": 5.0, "kd": (0.3, 0.2, 0.1)},  # lobe below the horizon
    ],
    ids=["retro", "anisotropic", "below"],
)
def test_sampler_for_other_lobe_shapes(values):
    brdf = MODEL.bind(values)
    assert_sample_matches_pdf(brdf, thetas=(0.0, 45.0, 89.9, 90.0))
    assert_pdf_integrates_to_one(brdf, thetas=(0.0, 60.0))
    assert_albedo_estimate_matches(brdf, thetas=(0.0, 60.0), seed=31)


def test_sampler_with_a_sharp_lobe():
    assert_sample_matches_pdf(MODEL.bind(n=5000.0, kd=0.2), thetas=(0.0, 60.0, 89.9, 90.0))
