"""Blinn (1977), the Blinn-Phong BRDF: f = kd/pi + ks (n . h)^n with h the half vector of wi and wo.
Reference values are worked out here from that formula, independently of the kernel."""

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

MODEL = get_model("blinn")


def test_declaration_matches_the_seed():
    assert MODEL.defaults() == {"n": 100.0, "ks": (1.0, 1.0, 1.0), "kd": (0.67, 0.67, 0.67)}
    assert MODEL.isotropic and MODEL.reciprocal and not MODEL.energy_conserving


def test_reference_value_at_normal_incidence():
    # wo = wi = n: h = n, (n . h)^n = 1, so f = kd/pi + ks = 0.67/pi + 1 = 1.2132676...
    np.testing.assert_allclose(
        eval_degrees(MODEL.bind(), (0, 0), (0, 0)), [0.67 / math.pi + 1.0] * 3, rtol=1e-12
    )


def test_reference_value_in_the_plane_of_incidence():
    # wo at theta 30 deg (phi 0) and wi at theta 50 deg on the other side (phi 180) lie in the x-z plane at
    # +30 and -50 deg from the normal; their bisector is at (30 - 50)/2 = -10 deg, so n . h = cos(10 deg):
    # f = kd/pi + ks cos^100(10 deg). With ks = (0.2, 0.5, 0.9), kd = (0.3, 0.1, 0.05).
    ks = np.array([0.2, 0.5, 0.9])
    kd = np.array([0.3, 0.1, 0.05])
    brdf = MODEL.bind(n=100, ks=tuple(ks), kd=tuple(kd))
    expected = kd / math.pi + ks * math.cos(math.radians(10)) ** 100
    np.testing.assert_allclose(eval_degrees(brdf, (30, 0), (50, 180)), expected, rtol=1e-12)


def test_reference_value_out_of_the_plane():
    # wo = (theta 60, phi 0), wi = (theta 60, phi 90): wi + wo = (sin60, sin60, 2 cos60) = (0.866, 0.866, 1),
    # of length sqrt(0.75 + 0.75 + 1) = sqrt(2.5), so n . h = 1 / sqrt(2.5) = 0.63246.
    # With n = 10, ks = 1, kd = 0: f = 2.5^-5 = 0.01024.
    brdf = MODEL.bind(n=10, ks=1.0, kd=0.0)
    np.testing.assert_allclose(eval_degrees(brdf, (60, 0), (60, 90)), [2.5**-5] * 3, rtol=1e-12)


def test_sharp_lobe_peak_grazing_and_90_degrees():
    brdf = MODEL.bind(n=1e4)
    # Peak: any mirror configuration has h = n, f = kd/pi + ks, also at 89.9 deg.
    for theta in (0.0, 45.0, 89.9):
        np.testing.assert_allclose(
            eval_degrees(brdf, (theta, 0), (theta, 180)), [0.67 / math.pi + 1.0] * 3, rtol=1e-9
        )
    # wo = wi at 89.9 deg: h = wo, (n . h)^1e4 = cos(89.9 deg)^1e4 underflows to 0: only the diffuse part.
    np.testing.assert_allclose(eval_degrees(brdf, (89.9, 0), (89.9, 0)), [0.67 / math.pi] * 3, rtol=1e-12)
    # Exactly 90 deg: zero.
    assert np.all(eval_degrees(brdf, (90, 0), (90, 180)) == 0.0)
    thetas = [0.0, 30.0, 60.0, 85.0, 89.0, 89.9, 90.0]
    w = np.array([degrees_to_dir(t, p) for t in thetas for p in (0.0, 90.0, 180.0, 271.0)])
    values = brdf.eval(np.repeat(w, len(w), axis=0), np.tile(w, (len(w), 1)))
    assert np.all(np.isfinite(values)) and np.all(values >= 0.0)


def test_sharp_lobe_half_a_degree_off():
    # wo at 45 deg, wi at 46 deg on the other side: the bisector is 0.5 deg off the normal;
    # cos(0.5 deg)^1e4 = exp(1e4 ln cos(0.5 deg)) = 0.6833.
    brdf = MODEL.bind(n=1e4, kd=0.0)
    expected = math.cos(math.radians(0.5)) ** 1e4
    np.testing.assert_allclose(eval_degrees(brdf, (45, 0), (46, 180)), [expected] * 3, rtol=1e-9)


@pytest.mark.parametrize("n", [1.0, 1e4])
def test_sampler_at_the_exponent_bounds(n):
    brdf = MODEL.bind(n=n)
    assert_sample_matches_pdf(brdf, thetas=(0.0, 60.0, 89.0, 89.9, 90.0))


def test_half_vector_sampler_with_a_wide_lobe():
    brdf = MODEL.bind(n=2.0, ks=(0.9, 0.5, 0.1), kd=(0.05, 0.2, 0.3))
    assert_pdf_integrates_to_one(brdf, thetas=(0.0, 60.0))
    assert_albedo_estimate_matches(brdf, seed=21)
