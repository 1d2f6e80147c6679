"""Lewis (1994), the normalized Phong BRDF: f = kd/pi + ks (n+2)/(2 pi) cos^n(alpha), alpha the angle between
wi and the mirror direction of wo. Reference values are worked out here from that formula."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from tests.core.models._checks import (
    albedo_by_quadrature,
    assert_sample_matches_pdf,
    direction,
    eval_degrees,
)

MODEL = get_model("lewis")


def test_declaration_matches_the_seed():
    assert MODEL.defaults() == {"n": 100.0, "ks": (1.0, 1.0, 1.0), "kd": (0.0, 0.0, 0.0)}
    assert MODEL.isotropic and MODEL.reciprocal
    # kd + ks <= 1 is needed for energy conservation; the bounds allow kd + ks = 2.
    assert not MODEL.energy_conserving


def test_reference_value_at_normal_incidence():
    # wo = wi = n: alpha = 0, f = kd/pi + ks (n+2)/(2 pi) = 102 / (2 pi) = 16.2338... at the seed's values.
    np.testing.assert_allclose(
        eval_degrees(MODEL.bind(), (0, 0), (0, 0)), [102 / (2 * math.pi)] * 3, rtol=1e-12
    )


def test_reference_value_near_the_mirror_direction():
    # wo at theta 30 deg (phi 0), wi at theta 40 deg (phi 180): the mirror of wo is at 30 deg on wi's side,
    # so alpha = 10 deg: f = kd/pi + ks (n+2)/(2 pi) cos^n(10 deg); n = 50, ks = (0.2, 0.5, 0.7),
    # kd = (0.3, 0.1, 0.05).
    ks = np.array([0.2, 0.5, 0.7])
    kd = np.array([0.3, 0.1, 0.05])
    brdf = MODEL.bind(n=50, ks=tuple(ks), kd=tuple(kd))
    expected = kd / math.pi + ks * 52 / (2 * math.pi) * math.cos(math.radians(10)) ** 50
    np.testing.assert_allclose(eval_degrees(brdf, (30, 0), (40, 180)), expected, rtol=1e-12)


def test_specular_albedo_is_ks_at_normal_incidence_and_below_elsewhere():
    # At wo = n, alpha = theta_i: (n+2)/(2 pi) times the integral of cos^(n+1)(theta) over the hemisphere,
    # 2 pi / (n + 2), is exactly 1, so the albedo is kd + ks. Elsewhere part of the lobe is cut off by the
    # horizon and weighted by a smaller cosine: the albedo is lower (Lafortune & Willems 1994).
    brdf = MODEL.bind(n=20, ks=(0.7, 0.5, 0.2), kd=(0.3, 0.1, 0.0))
    albedo, err = albedo_by_quadrature(brdf, np.array([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(albedo, [1.0, 0.6, 0.2], rtol=1e-7)
    for theta in (10.0, 30.0, 60.0, 80.0, 89.0):
        other, _ = albedo_by_quadrature(brdf, direction(theta))
        assert np.all(other <= albedo + 1e-9), f"theta_o={theta}: {other} > {albedo}"


def test_sharp_lobe_peak_grazing_and_90_degrees():
    brdf = MODEL.bind(n=1e4)
    peak = (1e4 + 2) / (2 * math.pi)  # 1591.87
    for theta in (0.0, 45.0, 89.9):
        np.testing.assert_allclose(eval_degrees(brdf, (theta, 0), (theta, 180)), [peak] * 3, rtol=1e-9)
    # One degree off the mirror: (n+2)/(2 pi) cos(1 deg)^1e4 = 1591.87 * 0.2180.
    expected = peak * math.cos(math.radians(1)) ** 1e4
    np.testing.assert_allclose(eval_degrees(brdf, (45, 0), (46, 180)), [expected] * 3, rtol=1e-9)
    assert np.all(eval_degrees(brdf, (90, 0), (90, 180)) == 0.0)
    thetas = [0.0, 30.0, 60.0, 85.0, 89.0, 89.9, 90.0]
    w = np.array([degrees_to_dir(t, p) for t in thetas for p in (0.0, 90.0, 180.0, 271.0)])
    values = brdf.eval(np.repeat(w, len(w), axis=0), np.tile(w, (len(w), 1)))
    assert np.all(np.isfinite(values)) and np.all(values >= 0.0)
    assert values.max() <= peak * (1 + 1e-12)


@pytest.mark.parametrize("n", [1.0, 1e4])
def test_sampler_at_the_exponent_bounds(n):
    assert_sample_matches_pdf(MODEL.bind(n=n, kd=0.3), thetas=(0.0, 60.0, 89.0, 89.9, 90.0))
