"""Kelemen & Szirmay-Kalos (2001) coupled specular-matte model: reference values from the paper's formulas
with the specular albedo integrated independently here, energy balance, grazing, and the sampler."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from core.brdf import get_model
from core.geometry import degrees_to_dir
from core.kernels import pdf_batch, sample_batch
from core.models._kelemen_albedo import albedo_tables, interpolate

MODEL = get_model("coupled")


def _spec(wi, wo, m, r0):
    """f_s = P(H) F(L.H) / |L + V|^2, Beckmann P normalized over projected area, Schlick F."""
    h = wi + wo
    hn = h / np.linalg.norm(h, axis=-1, keepdims=True)
    c = hn[..., 2]
    tan2 = (1.0 - c * c) / (c * c)
    p = np.exp(-tan2 / m**2) / (np.pi * m**2 * c**4)
    f = r0 + (1.0 - r0) * (1.0 - np.sum(wi * hn, axis=-1)) ** 5
    return p * f / np.sum(h * h, axis=-1)


def _spec_albedo(theta_v, m, r0):
    """a(V) = int f_s(L, V) cos(theta_L) d omega_L by adaptive quadrature (scipy) over the halfway vector:
    d omega_L = 4 (V.H) d omega_H, so a = int P(H) F (N.L) / (V.H) d omega_H over the H with N.L > 0."""
    sv, cv = math.sin(theta_v), math.cos(theta_v)

    def inner(th):
        ch, sh = math.cos(th), math.sin(th)
        dens = math.exp(-(math.tan(th) ** 2) / m**2) / (math.pi * m * m * ch**4) * sh

        def g(phi):
            vh = sv * sh * math.cos(phi) + cv * ch
            cl = 2 * vh * ch - cv
            if cl <= 0 or vh <= 0:
                return 0.0
            return dens * (r0 + (1 - r0) * (1 - vh) ** 5) * cl / vh

        if theta_v == 0.0:
            top = math.pi
        else:  # N.L > 0 for |phi| < phi_max: breakpoint for quad
            c = -cv * math.cos(2 * th) / (sv * math.sin(2 * th))
            top = math.acos(min(1.0, max(-1.0, c)))
        return 2 * integrate.quad(g, 0, top, epsabs=1e-13, epsrel=1e-11, limit=200)[0]

    lo = 0.5 * (math.pi / 2 - theta_v)
    hi = 0.5 * (math.pi / 2 + theta_v)
    pts = sorted({0.0, min(10 * m, lo), lo, hi})
    return sum(
        integrate.quad(inner, a, b, epsabs=1e-13, epsrel=1e-11, limit=200)[0]
        for a, b in zip(pts, pts[1:], strict=False)
        if b > a
    )


def _reference(wi, wo, m, r0, rm):
    """The model from its formulas: f_s + R_m (1 - a(L))(1 - a(V)) / (pi (1 - a_avg)), with a() and
    a_avg = 2 int a(mu) mu dmu integrated here (24-point Gauss-Legendre in mu over the adaptive a)."""
    a_i = _spec_albedo(math.acos(wi[2]), m, r0)
    a_o = _spec_albedo(math.acos(wo[2]), m, r0)
    x, w = np.polynomial.legendre.leggauss(24)
    mu = 0.5 * (x + 1.0)
    a_avg = sum(wk * mk * _spec_albedo(math.acos(mk), m, r0) for mk, wk in zip(mu, w, strict=True))
    return _spec(wi, wo, m, r0) + rm * (1 - a_i) * (1 - a_o) / (math.pi * (1 - a_avg))


@pytest.mark.parametrize(
    ("m", "r0", "rm", "wi_deg", "wo_deg"),
    [(1.0, 0.05, 1.0, (30.0, 0.0), (50.0, 160.0)), (0.35, 0.6, 0.7, (70.0, 20.0), (65.0, 200.0))],
)
def test_matches_the_paper_formulas(m, r0, rm, wi_deg, wo_deg):
    wi, wo = degrees_to_dir(*wi_deg), degrees_to_dir(*wo_deg)
    expected = _reference(wi, wo, m, r0, rm)
    got = MODEL.bind({"m": m, "r0": r0, "rm": rm}).eval(wo, wi)[0]
    np.testing.assert_allclose(got, expected, rtol=2e-5)


def test_reference_value_written_out():
    # Mirror configuration at 45 degrees, m = 0.35, R0 = 0.05, R_m = 0: only the specular term.
    # H = N: tan = 0, P = 1 / (pi m^2) = 1 / (pi 0.1225) = 2.598448; |L + V|^2 = (2 cos 45)^2 = 2;
    # F(L.H = cos 45 = 0.7071068) = 0.05 + 0.95 (0.2928932)^5 = 0.05 + 0.95 * 0.002155 = 0.0520477;
    # f = 2.598448 * 0.0520477 / 2 = 0.0676216.
    got = MODEL.bind({"m": 0.35, "rm": 0.0}).eval(degrees_to_dir(45.0, 180.0), degrees_to_dir(45.0, 0.0))[0]
    np.testing.assert_allclose(got, 0.0676216, rtol=2e-6)


def test_albedo_table_against_adaptive_quadrature():
    m = 0.1
    table_a, table_b = albedo_tables(m)
    for deg in (0.0, 60.0, 87.0, 89.7):
        th = math.radians(deg)
        for r0 in (0.0, 1.0):
            got = interpolate(r0 * table_a + table_b, math.cos(th))
            np.testing.assert_allclose(got, _spec_albedo(th, m, r0), atol=2e-6)


def _matte_albedo_of_kernel(brdf_full, brdf_spec, theta_v):
    """Albedo of the kernel's matte part (difference of R_m and R_m = 0 bindings): smooth in L, so
    Gauss-Legendre in mu = cos(theta_L) and the midpoint rule in phi."""
    v = degrees_to_dir(theta_v, 0.0)
    xm, wm = np.polynomial.legendre.leggauss(200)
    mu = 0.5 * (xm + 1.0)
    nphi = 16
    phi = (np.arange(nphi) + 0.5) * 2 * np.pi / nphi
    mg, pg = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - mg**2)
    wl = np.stack([s * np.cos(pg), s * np.sin(pg), mg], -1).reshape(-1, 3)
    vv = np.repeat(v[None], len(wl), 0)
    matte = brdf_full.eval(vv, wl) - brdf_spec.eval(vv, wl)
    wts = (np.broadcast_to((0.5 * wm * mu)[:, None], mg.shape) * (2 * np.pi / nphi)).ravel()
    return (matte * wts[:, None]).sum(0)


@pytest.mark.parametrize("m", [0.02, 0.35, 1.5])
def test_energy_balance_albedo_is_one_without_absorption(m):
    # Albedo = a(V) (specular, integrated here independently of the kernel's table) + the kernel's matte
    # albedo. For R_m = 1 the model promises a(V) + (1 - a(V)) = 1; the table and both quadratures are
    # accurate to ~1e-6, the tolerance.
    r0 = 0.3
    full = MODEL.bind({"m": m, "r0": r0})
    spec = MODEL.bind({"m": m, "r0": r0, "rm": 0.0})
    half = MODEL.bind({"m": m, "r0": r0, "rm": 0.5})
    for theta in (0.0, 60.0, 85.0, 89.5):
        a_v = _spec_albedo(math.radians(theta), m, r0)
        total = a_v + _matte_albedo_of_kernel(full, spec, theta)
        np.testing.assert_allclose(total, 1.0, atol=5e-6, err_msg=f"m={m} theta={theta}")
        # with absorption in the matte part: a(V) + R_m (1 - a(V)) < 1
        total_half = a_v + _matte_albedo_of_kernel(half, spec, theta)
        np.testing.assert_allclose(total_half, a_v + 0.5 * (1 - a_v), atol=5e-6)


def test_near_grazing_is_finite_and_has_a_limit_at_the_horizon():
    brdf = MODEL.bind({"m": 0.02, "r0": 0.04})
    for theta in (89.0, 89.9, 89.99, 89.9999):
        for phi in (0.0, 90.0, 180.0):
            f = brdf.eval(degrees_to_dir(theta, phi), degrees_to_dir(theta, 0.0))[0]
            assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    # The matte part towards a grazing light converges (1 - a(mu) ~ c + mu ln mu near the horizon): the steps
    # shrink as the angle approaches 90 degrees, and the value stays positive (a < 1 for R0 < 1).
    wo = degrees_to_dir(0.0)
    vals = [brdf.eval(wo, degrees_to_dir(t, 0.0))[0, 0] for t in (89.0, 89.9, 89.99, 89.999)]
    steps = np.abs(np.diff(vals))
    assert steps[2] < steps[1] < steps[0]
    assert vals[-1] > 0.0
    # exactly at the horizon the kernel returns 0 (the direction carries no energy)
    assert np.all(brdf.eval(wo, degrees_to_dir(90.0, 0.0)) == 0.0)


def test_sampler_pdf_is_the_density_of_its_samples():
    brdf = MODEL.bind({"m": 0.35, "r0": 0.3, "rm": 0.8})
    wo1 = degrees_to_dir(50.0, 30.0)
    n = 200_000
    u = np.random.default_rng(7).random((n, 3))
    wo = np.repeat(wo1[None], n, 0)
    wi, pdf = sample_batch(MODEL, wo, brdf.params, u)
    np.testing.assert_allclose(pdf, pdf_batch(MODEL, wo, wi, brdf.params), rtol=1e-12)
    # chi-square on a (cos theta, phi) grid over the whole sphere; expected counts from the pdf (midpoint
    # rule on a 4x finer grid); cells with expected < 5 pooled; significance 1e-3.
    nt, npf, r = 20, 40, 4
    ct = np.linspace(-1, 1, nt * r + 1)
    pf = np.linspace(0, 2 * np.pi, npf * r + 1)
    cm, pm = 0.5 * (ct[1:] + ct[:-1]), 0.5 * (pf[1:] + pf[:-1])
    cg, pg = np.meshgrid(cm, pm, indexing="ij")
    sg = np.sqrt(1 - cg**2)
    dirs = np.stack([sg * np.cos(pg), sg * np.sin(pg), cg], -1).reshape(-1, 3)
    dens = pdf_batch(MODEL, np.repeat(wo1[None], len(dirs), 0), dirs, brdf.params).reshape(cg.shape)
    cell = dens * (2.0 / (nt * r)) * (2 * np.pi / (npf * r))
    np.testing.assert_allclose(cell.sum(), 1.0, atol=5e-3)
    expected = cell.reshape(nt, r, npf, r).sum(axis=(1, 3)) * n
    th = np.clip(wi[:, 2], -1, 1)
    ph = np.mod(np.arctan2(wi[:, 1], wi[:, 0]), 2 * np.pi)
    observed, _, _ = np.histogram2d(
        th, ph, bins=[np.linspace(-1, 1, nt + 1), np.linspace(0, 2 * np.pi, npf + 1)]
    )
    e, o = expected.ravel(), observed.ravel()
    big = e >= 5
    chi2 = np.sum((o[big] - e[big]) ** 2 / e[big]) + (o[~big].sum() - e[~big].sum()) ** 2 / max(
        e[~big].sum(), 1
    )
    dof = big.sum()
    assert chi2 < stats.chi2.ppf(1 - 1e-3, dof), (chi2, dof)


@pytest.mark.parametrize("m", [0.01, 0.05, 0.2, 0.7, 1.5])
def test_specular_albedo_never_exceeds_one(m):
    # The simplified geometry keeps a(V) <= 1 even for a perfect reflector (R0 = 1, F = 1): with
    # w = (N.L)/((V.H)(N.H)) = 2 - cos(theta_V)/((V.H)(N.H)) <= 2 on the half of the facets that send L above
    # the horizon at grazing, and w = 2 - 1/cos^2(theta_H) <= 1 at normal incidence. The tables confirm it;
    # 1 - a >= 0 is what keeps the matte part non-negative.
    table_a, table_b = albedo_tables(m)
    a_max = np.max((table_a + table_b)[1:-1])  # without the ghost nodes
    assert a_max <= 1.0 + 1e-9
    mu = np.linspace(0.0, 1.0, 2001)
    assert np.all(interpolate(table_a + table_b, mu) <= 1.0 + 1e-9)
    # at normal incidence: a(0) = 2 P(theta_H < 45 deg) - E[1 + tan^2] there = 1 - m^2 + (1 + m^2) e^(-1/m^2)
    # (integrating (1 + m^2 ln u) du from u = e^(-1/m^2) to 1)
    np.testing.assert_allclose(
        interpolate(table_a + table_b, 1.0), 1 - m**2 + m**2 * np.exp(-1 / m**2), atol=1e-9
    )
