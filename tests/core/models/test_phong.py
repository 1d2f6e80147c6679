"""Phong (1975) as a BRDF: f = kd/pi + ks cos^n(alpha) / cos(theta_i), alpha the angle between wo and the
mirror direction of wi. Reference values are worked out here from that formula, independently of the kernel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from tests.core.models._checks import (
    albedo_by_quadrature,
    assert_albedo_estimate_matches,
    assert_sample_matches_pdf,
    eval_degrees,
)

MODEL = get_model("phong")


def test_declaration_matches_the_seed():
    assert MODEL.defaults() == {"n": 100.0, "ks": (0.4, 0.4, 0.4), "kd": (0.6, 0.6, 0.6)}
    assert MODEL.isotropic and not MODEL.reciprocal and not MODEL.energy_conserving


def test_reference_value_at_normal_incidence():
    # wo = wi = n: the mirror of wi is n, so alpha = 0 and cos(theta_i) = 1:
    # f = kd/pi + ks * 1^n / 1 = 0.6/pi + 0.4 = 0.5909859...
    expected = 0.6 / math.pi + 0.4
    np.testing.assert_allclose(eval_degrees(MODEL.bind(), (0, 0), (0, 0)), [expected] * 3, rtol=1e-12)


def test_reference_value_near_the_mirror_direction():
    # wo at theta 30 deg, phi 0; wi at theta 40 deg, phi 180: both in the x-z plane, on opposite sides of
    # the normal. The mirror of wi is at 40 deg on wo's side, so alpha = 40 - 30 = 10 deg, and
    # f = kd/pi + ks cos^n(10 deg) / cos(40 deg). With n = 100, ks = (0.2, 0.5, 0.9), kd = (0.3, 0.1, 0.05).
    ks = np.array([0.2, 0.5, 0.9])
    kd = np.array([0.3, 0.1, 0.05])
    brdf = MODEL.bind(n=100, ks=tuple(ks), kd=tuple(kd))
    expected = kd / math.pi + ks * math.cos(math.radians(10)) ** 100 / math.cos(math.radians(40))
    np.testing.assert_allclose(eval_degrees(brdf, (30, 0), (40, 180)), expected, rtol=1e-12)


def test_reference_value_out_of_the_plane():
    # wo = (theta 60, phi 0) = (sin60, 0, cos60); wi = (theta 45, phi 90) = (0, sin45, cos45).
    # Mirror of wi: (0, -sin45, cos45); cos(alpha) = wo . mirror(wi) = cos60 cos45 = 0.5 * 0.7071 = 0.35355.
    # With n = 2: f = kd/pi + ks * 0.125 / cos45 = kd/pi + ks * 0.17678.
    brdf = MODEL.bind(n=2, ks=1.0, kd=0.0)
    expected = (0.5 * math.sqrt(0.5)) ** 2 / math.sqrt(0.5)
    np.testing.assert_allclose(eval_degrees(brdf, (60, 0), (45, 90)), [expected] * 3, rtol=1e-12)


def test_not_reciprocal_exactly_by_the_cosine_ratio():
    # The specular part times cos(theta_i) is symmetric (cos(alpha) is), so swapping wi and wo scales the
    # specular part by cos(theta_i) / cos(theta_o).
    brdf = MODEL.bind(kd=0.0, n=20)
    a = eval_degrees(brdf, (20, 0), (50, 170))  # wo at 20 deg, wi at 50 deg
    b = eval_degrees(brdf, (50, 170), (20, 0))
    np.testing.assert_allclose(a * math.cos(math.radians(50)), b * math.cos(math.radians(20)), rtol=1e-12)
    assert not np.allclose(a, b)


def test_albedo_at_normal_incidence():
    # wo = n: the lobe's axis is n, alpha = theta_i, and f cos(theta_i) = kd/pi cos(theta_i) + ks cos^n(theta_i)
    # integrates to kd + ks * 2 pi / (n + 1) over the hemisphere.
    brdf = MODEL.bind(n=30, ks=0.5, kd=0.25)
    albedo, err = albedo_by_quadrature(brdf, np.array([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(albedo, 0.25 + 0.5 * 2 * math.pi / 31, rtol=1e-6)


@pytest.mark.parametrize("theta", [0.0, 45.0, 89.0, 89.9])
def test_sharp_lobe_peak_is_finite_and_exact(theta):
    # n = 1e4 at the exact mirror configuration: cos(alpha) = 1, f = kd/pi + ks / cos(theta).
    brdf = MODEL.bind(n=1e4)
    value = eval_degrees(brdf, (theta, 0), (theta, 180))
    expected = 0.6 / math.pi + 0.4 / math.cos(math.radians(theta))
    np.testing.assert_allclose(value, [expected] * 3, rtol=1e-9)


def test_sharp_lobe_grazing_and_exactly_90_degrees():
    brdf = MODEL.bind(n=1e4)
    thetas = [0.0, 30.0, 60.0, 85.0, 89.0, 89.9, 90.0]
    w = np.array([degrees_to_dir(t, p) for t in thetas for p in (0.0, 90.0, 180.0, 271.0)])
    wo, wi = np.repeat(w, len(w), axis=0), np.tile(w, (len(w), 1))
    values = brdf.eval(wo, wi)
    assert np.all(np.isfinite(values)) and np.all(values >= 0.0)
    at_90 = (wo[:, 2] == 0.0) | (wi[:, 2] == 0.0)
    assert np.all(values[at_90] == 0.0)
    # One degree off the mirror direction: cos(1 deg)^1e4 = exp(1e4 ln cos(1 deg)) = 0.2180.
    off = eval_degrees(brdf, (45, 0), (46, 180))
    expected = 0.6 / math.pi + 0.4 * math.cos(math.radians(1)) ** 1e4 / math.cos(math.radians(46))
    np.testing.assert_allclose(off, [expected] * 3, rtol=1e-9)


def test_cosine_floor_keeps_grazing_incidence_finite():
    # cos(theta_i) = 1e-9, below the documented floor 1e-6: the specular part is ks cos^n(alpha) / 1e-6.
    brdf = MODEL.bind(n=1e4, kd=0.0, ks=1.0)
    s = math.sqrt(1.0 - 1e-18)
    wi = np.array([s, 0.0, 1e-9])
    wo = np.array([-s, 0.0, 1e-9])  # the mirror direction of wi: cos(alpha) = 1
    value = brdf.eval(wo, wi)[0]
    np.testing.assert_allclose(value, [1e6] * 3, rtol=1e-9)


def test_sampler_with_a_sharp_lobe_at_grazing_angles():
    assert_sample_matches_pdf(MODEL.bind(n=1e4), thetas=(0.0, 60.0, 89.0, 89.9, 90.0))


def test_sampler_estimates_the_albedo_with_a_wide_lobe():
    assert_albedo_estimate_matches(MODEL.bind(n=3.0, ks=(0.9, 0.5, 0.1), kd=(0.1, 0.2, 0.3)), seed=11)
