"""Ashikhmin-Shirley (2000): reference values from the paper's equations written here with angles, the
0/0 exponent at h = n with nu != nv, grazing angles, and the paper's half-vector sampler (chi-square at
significance 0.01 with 1e6 samples per case: one case per setting and per angle in the default run, the full
settings x angles sweep with ``-m slow``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from tests.core.models._checks import assert_sampler_exact, hard_case_grid_is_finite, sampler_sweep

AS = get_model("ashikhmin_shirley")


def as_reference(wi, wo, nu, nv, ks, kd):
    """The paper's eq. 4 (specular) and eq. 5 (diffuse), with phi_h the azimuth of h:
    rho_s = sqrt((nu+1)(nv+1))/(8 pi) (n.h)^(nu cos^2 phi_h + nv sin^2 phi_h) / ((h.k) max(n.k1, n.k2)) F(k.h),
    F = ks + (1 - ks)(1 - k.h)^5,
    rho_d = 28 kd/(23 pi) (1 - ks) (1 - (1 - n.k1/2)^5)(1 - (1 - n.k2/2)^5)."""
    h = np.add(wi, wo)
    h /= np.linalg.norm(h)
    phi_h = math.atan2(h[1], h[0])
    expo = nu * math.cos(phi_h) ** 2 + nv * math.sin(phi_h) ** 2
    kh = float(np.dot(wi, h))
    fresnel = ks + (1.0 - ks) * (1.0 - kh) ** 5
    spec = (
        math.sqrt((nu + 1.0) * (nv + 1.0))
        / (8.0 * math.pi)
        * h[2] ** expo
        / (kh * max(wi[2], wo[2]))
        * fresnel
    )
    diff = (
        28.0
        * kd
        / (23.0 * math.pi)
        * (1.0 - ks)
        * (1.0 - (1.0 - wi[2] / 2.0) ** 5)
        * (1.0 - (1.0 - wo[2] / 2.0) ** 5)
    )
    return spec + diff


@pytest.mark.parametrize(
    ("wi_deg", "wo_deg"),
    [((30.0, 10.0), (50.0, 170.0)), ((70.0, 45.0), (20.0, 300.0)), ((85.0, 120.0), (80.0, 290.0))],
)
def test_reference_values_anisotropic(wi_deg, wo_deg):
    nu, nv, ks, kd = 10.0, 400.0, (0.39, 0.2, 0.05), (0.6, 0.3, 0.9)
    wi, wo = degrees_to_dir(*wi_deg), degrees_to_dir(*wo_deg)
    got = AS.bind(nu=nu, nv=nv, ks=ks, kd=kd).eval(wo, wi)[0]
    expected = [as_reference(wi, wo, nu, nv, ks[c], kd[c]) for c in range(3)]
    np.testing.assert_allclose(got, expected, rtol=1e-10)


@pytest.mark.parametrize("theta", [0.0, 30.0, 75.0, 89.9])
def test_h_equal_n_with_nu_different_from_nv(theta):
    # wo mirrored about n: h = n exactly, so (n.h)^(0/0) -> 1 (every exponent between nu and nv gives 1^E = 1),
    # k.h = n.k = cos(theta) and F = ks + (1 - ks)(1 - cos)^5:
    # rho_s = sqrt((nu+1)(nv+1)) / (8 pi) / cos^2(theta) * F.
    nu, nv, ks, kd = 1.0, 1e4, 0.39, 0.6
    wo = degrees_to_dir(theta, 25.0)
    wi = wo * np.array([-1.0, -1.0, 1.0])
    c = wo[2]
    spec = math.sqrt((nu + 1.0) * (nv + 1.0)) / (8.0 * math.pi) / (c * c) * (ks + (1.0 - ks) * (1.0 - c) ** 5)
    diff = 28.0 * kd / (23.0 * math.pi) * (1.0 - ks) * (1.0 - (1.0 - c / 2.0) ** 5) ** 2
    brdf = AS.bind(nu=nu, nv=nv, ks=ks, kd=kd)
    got = brdf.eval(wo, wi)[0]
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, spec + diff, rtol=1e-9)
    # Continuity: approaching h = n from any side gives the same value (no 0/0 artefact).
    for eps_dir in ((1e-7, 0.0, 0.0), (0.0, 1e-7, 0.0), (7e-8, -7e-8, 0.0)):
        wi2 = wi + np.array(eps_dir)
        wi2 /= np.linalg.norm(wi2)
        np.testing.assert_allclose(brdf.eval(wo, wi2)[0], spec + diff, rtol=1e-4)


def test_normal_incidence_both_directions():
    # wi = wo = n: h = n, k.h = 1, F = ks: rho_s = sqrt((nu+1)(nv+1))/(8 pi) ks, and n.k = 1 in the diffuse term.
    nu, nv, ks, kd = 25.0, 300.0, 0.39, 0.6
    z = np.array([0.0, 0.0, 1.0])
    expected = (
        math.sqrt(26.0 * 301.0) / (8.0 * math.pi) * ks
        + 28.0 * kd / (23.0 * math.pi) * (1.0 - ks) * (1.0 - 0.5**5) ** 2
    )
    np.testing.assert_allclose(AS.bind(nu=nu, nv=nv, ks=ks, kd=kd).eval(z, z), [[expected] * 3], rtol=1e-12)


@pytest.mark.parametrize(("nu", "nv"), [(1.0, 1e4), (1e5, 0.1), (1e5, 1e5)])
def test_hard_cases_finite_on_the_dense_grid(nu, nv):
    hard_case_grid_is_finite(AS.bind(nu=nu, nv=nv))
    for theta in (89.9, 90.0):
        wo = degrees_to_dir(theta, 0.0)
        f = AS.bind(nu=nu, nv=nv).eval(
            wo, np.stack([degrees_to_dir(theta, 180.0), wo, degrees_to_dir(89.9, 90.0)])
        )
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0)


def test_rotating_by_a_quarter_turn_swaps_the_exponents():
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    wo = np.stack([degrees_to_dir(t, p) for t in (10.0, 45.0, 80.0) for p in (0.0, 70.0, 200.0)])
    wi = np.stack([degrees_to_dir(t, p) for t in (60.0, 30.0, 5.0) for p in (150.0, 260.0, 20.0)])
    a = AS.bind(nu=5.0, nv=500.0).eval(wo @ rot.T, wi @ rot.T)
    b = AS.bind(nu=500.0, nv=5.0).eval(wo, wi)
    np.testing.assert_allclose(a, b, rtol=1e-9)


def test_traits():
    assert AS.reciprocal and not AS.isotropic and not AS.energy_conserving


SAMPLER_SETTINGS = [{}, {"nu": 10.0, "nv": 1000.0, "ks": 0.8, "kd": 0.1}, {"nu": 2.0, "nv": 2.0}]


@pytest.mark.parametrize(
    ("values", "theta"),
    sampler_sweep(SAMPLER_SETTINGS, [0.0, 50.0, 85.0], fast={(0, 50.0), (1, 85.0), (2, 0.0)}),
)
def test_sampler_is_exact(values, theta):
    assert_sampler_exact(AS.bind(values), theta)
