"""Schlick (1994), single and double layer: reference values from the paper's formulas, the two seed
settings, grazing directions, and the analytic sampler (normalization and a chi-square fit)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from core.brdf import get_model
from core.geometry import degrees_to_dir, spherical_to_dir
from core.kernels import pdf_batch, sample_batch


def _layer(t, v, vp, w, r, p):
    """Schlick's a/pi + b/(4 pi v v') [G G' Z A + 1 - G G'] (no impulse); w = None means h = n (A = 1)."""
    b = 4 * r * (1 - r)
    a = 0.0 if r < 0.5 else 1 - b
    if b == 0:
        return a / math.pi
    g = (v / (r - r * v + v)) * (vp / (r - r * vp + vp))
    z = r / (1 + r * t * t - t * t) ** 2
    az = 1.0 if w is None else math.sqrt(p / (p * p - p * p * w * w + w * w))
    return a / math.pi + b / (4 * math.pi * v * vp) * (g * z * az + 1 - g)


def _paper(wi, wo, sc, sr, sp, ly, dc, dr, dp):
    h = (wi + wo) / np.linalg.norm(wi + wo)
    t, u = h[2], float(wi @ h)
    w = None if math.hypot(h[0], h[1]) == 0 else h[0] / math.hypot(h[0], h[1])
    d_top = _layer(t, wo[2], wi[2], w, sr, sp)
    s = np.asarray(sc) + (1 - np.asarray(sc)) * (1 - u) ** 5
    if not ly:
        return s * d_top
    s2 = np.asarray(dc) + (1 - np.asarray(dc)) * (1 - u) ** 5
    return s * d_top + (1 - s) * s2 * _layer(t, wo[2], wi[2], w, dr, dp)


def _f(name, values, wi, wo):
    return get_model(name).bind(values).eval(np.asarray(wo), np.asarray(wi))[0]


def test_reference_value_single_layer_at_the_mirror_direction():
    # Schlick (S) seed settings: C = 0.7, r = 0.31, p = 1. Mirror pair at 30 deg: h = n, t = 1, u = v = v'.
    # b = 4*0.31*0.69 = 0.8556, a = 0; G(v) = v/(r - r v + v) = 0.8660254/0.9075575 = 0.9542375, G G' =
    # 0.9105692; Z(1) = 1/r = 3.2258065; A = 1; B = 0.9105692*3.2258065 + 1 - 0.9105692 = 3.0267507;
    # D = b B / (4 pi v^2) = 0.8556*3.0267507/(3 pi) = 0.2747744; S(u) = 0.7 + 0.3 (1 - 0.8660254)^5 =
    # 0.7000129; f = S D = 0.1923457.
    f = _f("schlick_s", {}, degrees_to_dir(30.0, 40.0), degrees_to_dir(30.0, 220.0))
    np.testing.assert_allclose(f, 0.1923457, rtol=1e-6)


def test_reference_value_double_layer_over_a_lambertian_base():
    # Same top layer over a Lambertian base (r' = 1: b' = 0, a' = 1, so D' = 1/pi) of colour C' = 0.5:
    # f = S D + (1 - S) S'(u) / pi with S' = 0.5 + 0.5 (1 - 0.8660254)^5 = 0.5000216:
    # f = 0.1923457 + 0.2999871*0.5000216/pi = 0.1923457 + 0.0477465 = 0.2400921.
    f = _f("schlick_d", {"dr": 1.0, "dc": 0.5}, degrees_to_dir(30.0, 40.0), degrees_to_dir(30.0, 220.0))
    np.testing.assert_allclose(f, 0.2400921, rtol=1e-6)


@pytest.mark.parametrize("name", ["schlick_s", "schlick_d"])
def test_matches_the_paper_on_random_settings(name, rng):
    model = get_model(name)
    for _ in range(4):
        values = {
            "sc": tuple(rng.uniform(0, 1, 3)),
            "sr": float(rng.uniform(0, 1)),
            "sp": float(rng.uniform(0.01, 1)),
            "dc": tuple(rng.uniform(0, 1, 3)),
            "dr": float(rng.uniform(0, 1)),
            "dp": float(rng.uniform(0.01, 1)),
        }
        brdf = model.bind(values)
        ly = model.resolve(values)["ly"] > 0.5
        ti, to = rng.uniform(0, math.radians(89), (2, 25))
        pi_, po = rng.uniform(0, 2 * math.pi, (2, 25))
        wi, wo = spherical_to_dir(ti, pi_), spherical_to_dir(to, po)
        f = brdf.eval(wo, wi)
        for k in range(25):
            ref = _paper(wi[k], wo[k], ly=ly, **values)
            np.testing.assert_allclose(f[k], ref, rtol=1e-9)


def test_seed_settings_and_the_mirror_base():
    d, s = get_model("schlick_d"), get_model("schlick_s")
    assert d.defaults()["ly"] == 1.0 and s.defaults()["ly"] == 0.0
    assert d.defaults()["dr"] == 0.0 and d.defaults()["sr"] == s.defaults()["sr"] == 0.31
    w = spherical_to_dir(np.radians([10.0, 40.0, 70.0, 85.0]), np.radians([0.0, 90.0, 200.0, 300.0]))
    wo, wi = np.repeat(w, 4, axis=0), np.tile(w, (4, 1))
    # dr = 0: the base layer is Schlick's perfect mirror, an impulse eval cannot hold (module docstring).
    np.testing.assert_array_equal(d.bind().eval(wo, wi), s.bind().eval(wo, wi))
    assert np.all(d.bind(dr=0.5).eval(wo, wi) > s.bind().eval(wo, wi))


def test_anisotropy_follows_the_tangent():
    # p < 1: A(w) is largest for w = 0, half vectors perpendicular to the tangent x.
    brdf = get_model("schlick_s").bind(sp=0.1, sr=0.2)
    wo = degrees_to_dir(40.0, 0.0)
    h_along_y = np.array([0.0, math.sin(0.2), math.cos(0.2)])
    h_along_x = np.array([math.sin(0.2), 0.0, math.cos(0.2)])
    for h in (h_along_y, h_along_x):
        assert h @ wo > 0
    wi_y = 2 * (wo @ h_along_y) * h_along_y - wo
    wo2 = degrees_to_dir(40.0, 90.0)
    wi_x = 2 * (wo2 @ h_along_x) * h_along_x - wo2
    f_y = brdf.eval(wo, wi_y)[0, 0]
    f_x = brdf.eval(wo2, wi_x)[0, 0]
    # The two pairs are the same configuration rotated by 90 deg (same t, u, v, v'): only A differs,
    # A(w = 0) = sqrt(1/p) = 3.16 for the first and A(w = 1) = sqrt(p) = 0.32 for the second.
    np.testing.assert_allclose(wi_y[2], wi_x[2], rtol=1e-12)
    assert f_y > 2.0 * f_x
    values = {"sc": 0.7, "sr": 0.2, "sp": 0.1, "ly": False, "dc": 1.0, "dr": 0.0, "dp": 1.0}
    np.testing.assert_allclose(f_y, _paper(wi_y, wo, **values), rtol=1e-9)
    np.testing.assert_allclose(f_x, _paper(wi_x, wo2, **values), rtol=1e-9)


@pytest.mark.parametrize("name", ["schlick_s", "schlick_d"])
def test_grazing_is_finite(name):
    brdf = get_model(name).bind(dr=0.4, dp=0.05, sp=0.05)
    zs = np.array([1e-3, 1e-6, 1e-9, 1e-300])
    w = np.stack([np.sqrt(1 - zs**2), np.zeros_like(zs), zs], axis=1)
    for a, b in ((w, w), (w, w * np.array([-1.0, 1.0, 1.0])), (w, np.tile([0.0, 0.0, 1.0], (4, 1)))):
        f = brdf.eval(a, b)
        assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    # Exactly at the normal the azimuth is undefined: A = 1 there, finite and continuous for p = 1.
    n = np.array([0.0, 0.0, 1.0])
    iso = get_model(name).bind(dr=0.4)
    near = np.array([1e-9, 0.0, math.sqrt(1 - 1e-18)])
    np.testing.assert_allclose(iso.eval(n, n), iso.eval(near, near), rtol=1e-8)


SAMPLER_CASES = [
    ("schlick_s", {}, 30.0),
    ("schlick_s", {"sr": 0.05, "sp": 0.2}, 60.0),
    ("schlick_d", {"dr": 0.7, "dp": 0.5, "sr": 0.1}, 10.0),
    ("schlick_d", {"sr": 0.9, "dr": 0.2}, 85.0),
]


def _sphere_grid(n_z=400, n_phi=800):
    z = -1 + (np.arange(n_z) + 0.5) * (2 / n_z)
    phi = (np.arange(n_phi) + 0.5) * (2 * np.pi / n_phi)
    zz, pp = np.meshgrid(z, phi, indexing="ij")
    s = np.sqrt(1 - zz**2)
    w = np.stack([s * np.cos(pp), s * np.sin(pp), zz], axis=-1).reshape(-1, 3)
    return w, (2 / n_z) * (2 * np.pi / n_phi)


@pytest.mark.parametrize(("name", "values", "theta_o"), SAMPLER_CASES)
def test_pdf_integrates_to_one_over_the_sphere(name, values, theta_o):
    model = get_model(name)
    p = model.kernel_params(values)
    wi, cell = _sphere_grid()
    wo = np.repeat(degrees_to_dir(theta_o, 25.0)[None, :], len(wi), axis=0)
    pdf = pdf_batch(model, wo, wi, p)
    assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0)
    # Midpoint rule in (z, phi) (uniform in solid angle); the sharpest lobe here (r = 0.05) is resolved.
    np.testing.assert_allclose(pdf.sum() * cell, 1.0, atol=5e-3)


@pytest.mark.parametrize(("name", "values", "theta_o"), SAMPLER_CASES)
def test_samples_follow_the_pdf(name, values, theta_o):
    """Pearson chi-square on a (z, phi) grid over the sphere, cells with expected count < 5 pooled;
    200 000 samples, fixed seed, significance 0.01 (Sidak-corrected over the 4 cases)."""
    model = get_model(name)
    p = model.kernel_params(values)
    n = 200_000
    rng = np.random.default_rng(1994)
    wo1 = degrees_to_dir(theta_o, 25.0)
    wo = np.repeat(wo1[None, :], n, axis=0)
    wi, pdf = sample_batch(model, wo, p, rng.random((n, 3)))
    assert np.all(np.isfinite(wi)) and np.all(pdf > 0)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-9)
    np.testing.assert_allclose(pdf, pdf_batch(model, wo, wi, p), rtol=1e-12)

    n_z, n_phi, sub = 24, 48, 8
    z_idx = np.clip(((wi[:, 2] + 1) / 2 * n_z).astype(int), 0, n_z - 1)
    phi = np.mod(np.arctan2(wi[:, 1], wi[:, 0]), 2 * np.pi)
    p_idx = np.clip((phi / (2 * np.pi) * n_phi).astype(int), 0, n_phi - 1)
    observed = np.bincount(z_idx * n_phi + p_idx, minlength=n_z * n_phi).astype(float)
    # Expected counts: the pdf integrated over each cell with sub x sub midpoints (area-preserving (z, phi)).
    fine, cell = _sphere_grid(n_z * sub, n_phi * sub)
    dens = pdf_batch(model, np.repeat(wo1[None, :], len(fine), axis=0), fine, p) * cell
    expected = dens.reshape(n_z, sub, n_phi, sub).sum(axis=(1, 3)).ravel() * n
    assert not np.any((expected == 0) & (observed > 0))
    order = np.argsort(expected)
    exp_sorted, obs_sorted = expected[order], observed[order]
    small = np.cumsum(exp_sorted) < 5 * 20  # pool the smallest cells into one bin of >= 100 expected
    pooled_e = np.append(exp_sorted[~small], exp_sorted[small].sum())
    pooled_o = np.append(obs_sorted[~small], obs_sorted[small].sum())
    keep = pooled_e >= 5
    pooled_o = pooled_o[keep]
    pooled_e = pooled_e[keep] * pooled_o.sum() / pooled_e[keep].sum()
    chi2 = float(np.sum((pooled_o - pooled_e) ** 2 / pooled_e))
    p_value = stats.chi2.sf(chi2, len(pooled_e) - 1)
    alpha = 1 - (1 - 0.01) ** (1 / len(SAMPLER_CASES))
    assert p_value > alpha, f"chi2 = {chi2:.1f}, dof = {len(pooled_e) - 1}, p = {p_value:.2e}"
