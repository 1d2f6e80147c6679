"""He-Torrance-Sillion-Greenberg (1991): reference values recomputed here from the paper's formulas with
independent tools (scipy's brentq and erfc, a brute-force series, explicit polarization vectors), the
smooth and rough limits, normal and grazing incidence."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import erfc

from core.brdf import get_model
from core.geometry import degrees_to_dir
from core.models._he_series import (
    TABLE_A_MAX,
    TABLE_G_MAX,
    TABLE_G_MID,
    TABLE_G_MIN,
    TABLE_STEP,
    TABLE_TOL,
    diffuse_series,
    direction_k,
    effective_roughness_ratio,
    log_k,
    log_roughness_ratio_of_k,
    shadow_over_cos,
    tabulated_series,
)
from core.models.he import specular_weight
from tests.core.models._checks import fresnel_reference

MODEL = get_model("he")


def _shadow(theta: float, sigma: float, tau: float) -> float:
    """He et al.'s S(theta) = (1 - erfc(mu)/2) / (Lambda + 1), mu = tau cot(theta) / (2 sigma)."""
    if theta == 0.0:
        return 1.0
    mu = tau / math.tan(theta) / (2.0 * sigma)
    lam = 0.5 * ((2.0 / math.sqrt(math.pi)) * (sigma / tau) * math.tan(theta) * math.exp(-mu * mu) - erfc(mu))
    return (1.0 - 0.5 * erfc(mu)) / (lam + 1.0)


def _sigma0(theta_i: float, theta_r: float, sigma: float, tau: float) -> float:
    """Effective roughness: root z0 of sqrt(pi/2) z0 = sigma/4 (K_i + K_r) exp(-z0^2/(2 sigma^2)) by brentq."""

    def big_k(t):
        return 0.0 if t == 0.0 else math.tan(t) * erfc(tau / math.tan(t) / (2.0 * sigma))

    kk = big_k(theta_i) + big_k(theta_r)
    if kk == 0.0:
        return sigma
    z0 = brentq(
        lambda z: math.sqrt(math.pi / 2) * z - sigma / 4 * kk * math.exp(-(z * z) / (2 * sigma * sigma)),
        0.0,
        10.0 * sigma + kk * sigma,
        xtol=1e-15 * sigma,
        rtol=1e-15,
    )
    return sigma / math.sqrt(1.0 + (z0 / sigma) ** 2)


def _series(g: float, a: float) -> float:
    """sum_{m>=1} g^m e^-g / (m! m) exp(-a/m), every term up to far beyond the Poisson peak (fsum)."""
    top = int(g + 40.0 * math.sqrt(g) + 60.0 + math.sqrt(a))
    lg = math.log(g)
    return math.fsum(math.exp(m * lg - g - math.lgamma(m + 1.0) - math.log(m) - a / m) for m in range(1, top))


def _he_dd(wi, wo, sigma, tau, lam_nm, n, k):
    """rho_dd of the paper with G written with the polarization vectors s, p of both beams (not simplified)."""
    lam = lam_nm * 1e-3
    kw = 2.0 * math.pi / lam
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    ki, kr = -wi, wo  # propagation directions: incident travels towards the surface
    nrm = np.array([0.0, 0.0, 1.0])
    ti, tr = math.acos(wi[2]), math.acos(wo[2])
    # The paper's v = k_r - k_i carries the wave number k in the exponent (tau v_xy is dimensionless there);
    # in G, a ratio of lengths of v, the wave number cancels: G is dimensionless.
    v = kr - ki
    vxy2 = kw**2 * (v[0] ** 2 + v[1] ** 2)

    def sp(kv):
        s = np.cross(kv, nrm)
        s /= np.linalg.norm(s)
        return s, np.cross(s, kv)

    s_i, p_i = sp(ki)
    s_r, p_r = sp(kr)
    cr = np.linalg.norm(np.cross(kr, ki))
    geom = (
        (v @ v / v[2]) ** 2
        / cr**4
        * ((s_r @ ki) ** 2 + (p_r @ ki) ** 2)
        * ((s_i @ kr) ** 2 + (p_i @ kr) ** 2)
    )
    s0 = _sigma0(ti, tr, sigma, tau)
    g = (2.0 * math.pi * s0 / lam * (wi[2] + wo[2])) ** 2
    d = math.pi**2 * tau**2 / (4.0 * lam**2) * _series(g, tau**2 * vxy2 / 4.0)
    cos_b = np.linalg.norm(kr - ki) / 2.0
    shadow = _shadow(ti, sigma, tau) * _shadow(tr, sigma, tau)
    return fresnel_reference(cos_b, n, k) / math.pi * geom * shadow * d / (wi[2] * wo[2]), g


def _f(values, wi, wo):
    return MODEL.bind(values).eval(np.asarray(wo), np.asarray(wi))[0]


@pytest.mark.parametrize(
    ("values", "wi_deg", "wo_deg"),
    [
        # The seed's setting (sigma = 0.5 um, tau = 3 um, lambda = 800 nm), off the plane of incidence.
        ({}, (30.0, 0.0), (40.0, 150.0)),
        # A smooth dielectric in green light, forward scattering at 60 -> 20 degrees (g ~ 0.1).
        (
            {"sigma": 0.05, "tau": 1.0, "wavelength": 500.0, "n": (1.5, 1.5, 1.5), "k": 0.0},
            (60.0, 10.0),
            (20.0, 200.0),
        ),
        # Intermediate roughness (g ~ 40, the exact-sum regime) near grazing, coloured index.
        (
            {"sigma": 0.3, "tau": 1.5, "wavelength": 400.0, "n": (0.2, 0.6, 1.2), "k": (3.0, 2.5, 2.0)},
            (75.0, 0.0),
            (70.0, 170.0),
        ),
    ],
)
def test_matches_the_paper_formulas(values, wi_deg, wo_deg):
    wi, wo = degrees_to_dir(*wi_deg), degrees_to_dir(*wo_deg)
    full = MODEL.resolve(values)
    n = np.broadcast_to(full["n"], 3)
    k = np.broadcast_to(full["k"], 3)
    expected = [
        _he_dd(wi, wo, full["sigma"], full["tau"], full["wavelength"], n[c], k[c])[0] for c in range(3)
    ]
    np.testing.assert_allclose(_f(values, wi, wo), expected, rtol=1e-8)


def test_reference_value_written_out():
    # Normal incidence and normal viewing, seed roughness, lambda = 800 nm, n = 2.8, k = 8.4, kd = 0:
    # K_i = K_r = 0 -> sigma_0 = sigma = 0.5 um; v_xy = 0; k = 2 pi / 0.8 = 7.853982 /um;
    # g = (k sigma_0 * 2)^2 = 7.853982^2 = 61.68503; S = 1; G = (|2 z|^2 / 2)^2 = 4; cos_b = 1;
    # F(0) = ((n-1)^2 + k^2) / ((n+1)^2 + k^2) = (3.24 + 70.56) / (14.44 + 70.56) = 0.8682353;
    # D = tau^2 k^2 / 16 * sum = 9 * 61.68503 / 16 * sum = 34.69783 * sum,
    # sum_{m>=1} g^m e^-g / (m! m) = 0.016484... (brute force below).
    # rho = F / pi * G * D / (1 * 1) = 0.8682353 / pi * 4 * 34.69783 * sum
    s = _series(61.68503, 0.0)
    expected = 0.8682353 / math.pi * 4.0 * 34.69783 * s
    np.testing.assert_allclose(_f({}, degrees_to_dir(0.0), degrees_to_dir(0.0)), expected, rtol=1e-6)


def test_series_against_brute_force_in_every_regime():
    for g in (1e-9, 1e-3, 0.3, 2.0, 12.0, 15.0, 25.0, 40.0, 62.0, 95.0, 150.0, 400.0, 3000.0, 5e4):
        for a in (0.0, 0.01, 2.0, 50.0, 600.0):
            np.testing.assert_allclose(diffuse_series(g, a), _series(g, a), rtol=1e-9, err_msg=f"{g} {a}")


def test_effective_roughness_against_brentq():
    sigma, tau = 0.5, 3.0
    for ti, tr in ((0.0, 0.0), (0.3, 1.2), (1.3, 1.3), (1.5, 0.2), (1.5707, 1.5707)):
        lk = [log_k(math.cos(t), math.sin(t), tau / (2 * sigma)) for t in (ti, tr)]
        np.testing.assert_allclose(
            sigma * effective_roughness_ratio(lk[0], lk[1]), _sigma0(ti, tr, sigma, tau), rtol=1e-10
        )


def test_tiny_g_is_the_first_term_of_the_series():
    # sigma = 5 nm, lambda = 3 um: g <= (2 pi 0.005/3 * 2)^2 = 4.4e-4, so the sum is g e^-g e^-a (1 + O(g)).
    values = {"sigma": 0.005, "tau": 0.5, "wavelength": 3000.0, "n": 1.5, "k": 0.0}
    wi, wo = degrees_to_dir(40.0, 0.0), degrees_to_dir(35.0, 180.0)
    ref, g = _he_dd(wi, wo, 0.005, 0.5, 3000.0, 1.5, 0.0)
    assert g < 5e-4
    np.testing.assert_allclose(_f(values, wi, wo), ref, rtol=1e-8)
    assert np.all(np.isfinite(_f(values, degrees_to_dir(0.0), degrees_to_dir(0.0))))


def test_large_g_tends_to_the_rough_surface_limit():
    # sigma = 8 um >> lambda = 0.4 um: g ~ 6e4 at normal incidence. The paper's rough approximation
    # sum ~ exp(-a/g)/g turns rho_dd into F D_Beckmann S / (4 cos_i cos_r), Beckmann slope m = 2 sigma_0/tau;
    # the exact sum differs by O(1/g) (relative).
    sigma, tau, lam = 8.0, 40.0, 400.0
    values = {"sigma": sigma, "tau": tau, "wavelength": lam, "n": 1.5, "k": 0.0}
    for (ti, pi_), (tr, pr) in (((20.0, 0.0), (25.0, 170.0)), ((10.0, 0.0), (15.0, 200.0))):
        wi, wo = degrees_to_dir(ti, pi_), degrees_to_dir(tr, pr)
        h = wi + wo
        hn = h / np.linalg.norm(h)
        tan2 = (hn[0] ** 2 + hn[1] ** 2) / hn[2] ** 2
        m = 2.0 * _sigma0(math.radians(ti), math.radians(tr), sigma, tau) / tau
        d_beck = math.exp(-tan2 / m**2) / (math.pi * m**2 * hn[2] ** 4)
        shadow = _shadow(math.radians(ti), sigma, tau) * _shadow(math.radians(tr), sigma, tau)
        limit = fresnel_reference(float(wi @ hn), 1.5, 0.0) * d_beck * shadow / (4.0 * wi[2] * wo[2])
        got = _f(values, wi, wo)[0]
        np.testing.assert_allclose(got, limit, rtol=2e-3)


def test_normal_and_grazing_incidence_are_finite_and_continuous():
    brdf = MODEL.bind()
    # normal incidence: the limit of nearby directions (sigma_0 -> sigma, S -> 1 smoothly)
    at = brdf.eval(degrees_to_dir(20.0, 180.0), degrees_to_dir(0.0))[0]
    near = brdf.eval(degrees_to_dir(20.0, 180.0), degrees_to_dir(1e-7, 33.0))[0]
    np.testing.assert_allclose(at, near, rtol=1e-8)
    # grazing: finite, non-negative and vanishing as both directions reach the horizon (S -> 0, g -> 0)
    for theta in (89.0, 89.9, 89.999, 89.99999):
        for phi in (0.0, 90.0, 180.0):
            f = brdf.eval(degrees_to_dir(theta, phi), degrees_to_dir(theta, 0.0))[0]
            assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    tiny = brdf.eval(degrees_to_dir(89.99999, 180.0), degrees_to_dir(89.99999, 0.0))[0]
    assert np.all(tiny < 1e-6)
    wi = np.array([1.0, 0.0, 1e-300])
    assert np.all(np.isfinite(brdf.eval(wi, wi)))


def test_uniform_diffuse_term_adds_kd_over_pi():
    wi, wo = degrees_to_dir(30.0, 0.0), degrees_to_dir(50.0, 90.0)
    base = _f({}, wi, wo)
    with_kd = _f({"kd": (0.1, 0.2, 0.3)}, wi, wo)
    np.testing.assert_allclose(with_kd - base, np.array([0.1, 0.2, 0.3]) / math.pi, rtol=1e-12)


def test_specular_weight_of_the_left_out_delta_term():
    # Normal incidence: S = 1, sigma_0 = sigma, weight = F(0) exp(-(2 k sigma)^2).
    brdf = MODEL.bind({"sigma": 0.05, "wavelength": 500.0})
    f0 = ((2.8 - 1) ** 2 + 8.4**2) / ((2.8 + 1) ** 2 + 8.4**2)
    g = (2.0 * 2.0 * math.pi / 0.5 * 0.05) ** 2
    np.testing.assert_allclose(specular_weight(brdf.params, 0.0), f0 * math.exp(-g), rtol=1e-12)
    # At 60 degrees the weight is F e^-g S^2 with the effective roughness.
    t = math.radians(60.0)
    s0 = _sigma0(t, t, 0.05, 3.0)
    g = (2.0 * math.pi / 0.5 * s0 * 2.0 * math.cos(t)) ** 2
    expected = fresnel_reference(math.cos(t), 2.8, 8.4) * math.exp(-g) * _shadow(t, 0.05, 3.0) ** 2
    np.testing.assert_allclose(specular_weight(brdf.params, t), expected, rtol=1e-9)


@pytest.mark.parametrize("values", [{"sigma": 0.1}, {"sigma": 0.05, "wavelength": 500.0}])
def test_normal_incidence_energy_split_between_delta_and_directional_diffuse(values):
    # For gentle slopes (sigma/tau small, no shadowing at normal incidence) the Kirchhoff model splits the
    # Fresnel reflectance F(0) between the coherent specular beam (weight F e^-g) and the directional-diffuse
    # lobe (the rest, F (1 - e^-g) up to the small-slope approximation): their sum is F(0). Here the lobe's
    # albedo is integrated numerically (Gauss-Legendre in cos(theta), midpoint in phi). Slopes 2 sigma/tau =
    # 0.067 and 0.033 here; at the seed's 0.33 the sum is 0.7 % lower (shadowing and Fresnel off the normal).
    brdf = MODEL.bind(values)
    x, w = np.polynomial.legendre.leggauss(300)
    mu = 0.5 * (x + 1.0)
    nphi = 90  # the lobe is rotationally symmetric about the normal at normal incidence
    phi = (np.arange(nphi) + 0.5) * 2 * np.pi / nphi
    mg, pg = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - mg**2)
    wl = np.stack([s * np.cos(pg), s * np.sin(pg), mg], -1).reshape(-1, 3)
    weights = (np.broadcast_to((0.5 * w * mu)[:, None], mg.shape) * (2 * np.pi / nphi)).ravel()
    v = degrees_to_dir(0.0)
    albedo = brdf.eval(np.repeat(v[None], len(wl), 0), wl)[:, 0] @ weights
    f0 = ((2.8 - 1) ** 2 + 8.4**2) / ((2.8 + 1) ** 2 + 8.4**2)
    np.testing.assert_allclose(albedo + specular_weight(brdf.params, 0.0)[0], f0, rtol=3e-3)


@pytest.mark.slow
def test_matches_the_paper_formulas_on_random_settings(rng):
    # A sweep over the parameter box and the hemisphere (directions within 88 degrees of the normal).
    for _ in range(40):
        sigma = float(np.exp(rng.uniform(np.log(0.005), np.log(10.0))))
        tau = float(np.exp(rng.uniform(np.log(0.05), np.log(100.0))))
        lam = float(rng.uniform(200.0, 3000.0))
        n, k = float(rng.uniform(0.1, 5.0)), float(rng.uniform(0.0, 10.0))
        wi = degrees_to_dir(rng.uniform(0.0, 88.0), rng.uniform(0.0, 360.0))
        wo = degrees_to_dir(rng.uniform(0.0, 88.0), rng.uniform(0.0, 360.0))
        values = {"sigma": sigma, "tau": tau, "wavelength": lam, "n": n, "k": k}
        ref, _ = _he_dd(wi, wo, sigma, tau, lam, n, k)
        np.testing.assert_allclose(_f(values, wi, wo)[0], ref, rtol=1e-7, atol=1e-300, err_msg=str(values))


# ------------------------------------------------------------------------------ the faster kernel's values
def _directions(rng, n: int, cos_hi: float = 1.0, cos_lo: float = 0.0) -> np.ndarray:
    c = rng.uniform(cos_lo, cos_hi, n)
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    s = np.sqrt(1.0 - c * c)
    return np.stack([s * np.cos(phi), s * np.sin(phi), c], axis=1)


@pytest.mark.parametrize(
    ("values", "rtol"),
    [
        # g from 0 to 62 (0.1 <= g <= 128 and a <= 1024 are read from the series' tables: within TABLE_TOL)
        ({}, TABLE_TOL),
        ({"sigma": 0.3, "tau": 1.5, "wavelength": 400.0, "n": (0.2, 0.6, 1.2), "k": (3.0, 2.5, 2.0), "kd": 0.1}, TABLE_TOL),
        ({"sigma": 0.05, "tau": 1.0, "wavelength": 500.0, "n": (1.5, 1.5, 1.5), "k": 0.0}, TABLE_TOL),
        # g below 0.1: the sum itself (only the effective roughness is tabulated: 4e-15 of its logarithm)
        ({"sigma": 0.01, "tau": 80.0, "wavelength": 2500.0, "n": (2.8, 2.8, 3.0)}, 1e-12),
        # g up to 3e4 (the tables for g <= 128): both formulations sum every k-th term by logarithms of order
        # 1e5 and are within 5e-12 of a 40-digit sum; a rounding of the effective roughness moves them by up to
        # 1e-11
        ({"sigma": 4.0, "tau": 20.0, "wavelength": 300.0}, TABLE_TOL),
    ],
)  # fmt: skip
def test_the_kernel_matches_the_reference_formulation(values, rtol, rng):
    """The series read from its tables (the sum itself outside them), the effective roughness's logarithm from
    its table, one ``erfc`` a direction and one Fresnel term for channels of the same index give the values
    of the reference formulation (``_he_reference``: each term's logarithm, Newton's method) within the tables'
    tolerance (``TABLE_TOL``, 2e-9; the largest error measured on 3 million pairs of six settings is 8.5e-10)
    or to rounding where nothing is tabulated: random pairs, grazing pairs (``cos`` down to 1e-12 on either
    side), normal incidence and mirror pairs."""
    from tests.core.models._he_reference import eval_he_reference

    brdf = MODEL.bind(values)
    wi = np.concatenate([_directions(rng, 300), _directions(rng, 100, 1e-3), _directions(rng, 100)])
    wo = np.concatenate([_directions(rng, 300), _directions(rng, 100), _directions(rng, 100, 1e-3)])
    graze = np.array([1e-12, 1e-9, 1e-6, 1e-4])
    for c in graze:
        s = math.sqrt(1.0 - c * c)
        wi = np.concatenate([wi, [[s, 0.0, c], [0.0, 0.0, 1.0], [-s, 0.0, c], [s * 0.6, s * 0.8, c]]])
        wo = np.concatenate([wo, [[-s, 0.0, c], [s, 0.0, c], [-s, 0.0, c], [0.0, 0.0, 1.0]]])
    mirror = wo * np.array([-1.0, -1.0, 1.0])
    wi = np.concatenate([wi, mirror, [[0.0, 0.0, 1.0]]])
    wo = np.concatenate([wo, wo, [[0.0, 0.0, 1.0]]])
    got = brdf.eval(wi, wo)
    want = np.array([eval_he_reference(a, b, brdf.params) for a, b in zip(wi, wo, strict=True)])
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, want, rtol=rtol, atol=1e-300)


def test_the_series_matches_the_reference_formulation_to_1e_12():
    """The series by term ratios (every ``k``-th term by the ratio of ``k`` steps) against the reference
    summation by each term's logarithm, over ``g`` from 1e-9 to 1e4 and ``a`` from 0 to 1e6 (the ratio is used
    up to ``a = 1e4``; beyond, both sum the logarithms)."""
    from tests.core.models._he_reference import diffuse_series as reference

    for g in np.exp(np.linspace(math.log(1e-9), math.log(1e4), 37)):
        for a in np.concatenate([[0.0], np.exp(np.linspace(math.log(1e-3), math.log(1e6), 19))]):
            np.testing.assert_allclose(diffuse_series(g, a), reference(g, a), rtol=1e-12, err_msg=f"{g} {a}")


def test_halleys_effective_roughness_matches_newtons():
    from tests.core.models._he_reference import effective_roughness_ratio as reference

    logs = np.concatenate([[-np.inf], np.linspace(-70.0, 35.0, 211)])
    for a in logs:
        for b in logs[::7]:
            np.testing.assert_allclose(effective_roughness_ratio(a, b), reference(a, b), rtol=2e-15)


def test_the_series_tables_are_within_their_tolerance(rng):
    """``tabulated_series`` against the sum: random points of the tabulated domain, the centres of a sample of
    the cells of both tables (where a Lagrange interpolant's error is largest), the region of the largest
    error (``g`` near 1, ``a`` near 5) and the domain's edges; outside, the sum itself."""
    from numba import njit

    @njit(cache=False)
    def ratios(g, a):
        out = np.empty(g.size)
        for n in range(g.size):
            out[n] = tabulated_series(g[n], a[n]) / diffuse_series(g[n], a[n])
        return out

    n = 20000
    log_g = rng.uniform(math.log(TABLE_G_MIN), math.log(TABLE_G_MAX), n)
    y = rng.uniform(0.0, math.log1p(TABLE_A_MAX), n)
    cells_x = math.log(TABLE_G_MIN) + TABLE_STEP * (rng.integers(0, 160, 4000) + 0.5)
    cells_y = (TABLE_STEP / 2.0) * (rng.integers(0, 440, 4000) + 0.5)
    near = rng.uniform(-0.1, 0.1, 2000), rng.uniform(1.6, 2.0, 2000)
    g = np.exp(np.concatenate([log_g, cells_x, near[0]]))
    a = np.expm1(np.concatenate([y, cells_y, near[1]]))
    edges_g = np.array(
        [TABLE_G_MIN, TABLE_G_MID, TABLE_G_MAX, 0.0999, 0.9999999, 1.0000001, 128.01, 1e-3, 500.0]
    )
    edges_a = np.array([0.0, 1e-12, 0.5, TABLE_A_MAX, 1024.5, 2000.0])
    g = np.concatenate([g, np.repeat(edges_g, len(edges_a))])
    a = np.concatenate([a, np.tile(edges_a, len(edges_g))])
    np.testing.assert_allclose(ratios(g, a), 1.0, rtol=TABLE_TOL, atol=0.0)
    assert tabulated_series(0.0, 3.0) == 0.0
    assert tabulated_series(500.0, 10.0) == diffuse_series(500.0, 10.0)  # outside: the sum itself


def test_the_roughness_table_matches_the_iteration():
    """``log_roughness_ratio_of_k(K_i + K_r)`` against the logarithm of ``effective_roughness_ratio`` of the two
    logarithms: within 1e-14 on the table (``ln C`` from -20 to 32), to rounding below and above."""
    for x in np.concatenate([np.linspace(-80.0, 40.0, 4801), [-20.0, 32.0, 31.999]]):
        k = math.exp(x) * 2.0 * math.sqrt(2.0 * math.pi)
        lk = math.log(k / 3.0)
        want = math.log(effective_roughness_ratio(lk, lk + math.log(2.0)))
        assert abs(log_roughness_ratio_of_k(k) - want) < 1e-14 + 1e-15 * abs(want), x
    assert log_roughness_ratio_of_k(0.0) == 0.0


def test_direction_k_is_log_k_and_shadow_over_cos():
    for tau_2s, sig_tau in ((3.0, 1.0 / 6.0), (0.5, 1.0), (400.0, 1e-4)):
        for t in np.concatenate([np.linspace(0.0, 1.5707, 60), [1.5707963, 1.0e-3]]):
            c, s = max(math.cos(t), 1e-12), math.sin(t)
            k, shadow = direction_k(c, s, tau_2s, sig_tau)
            np.testing.assert_allclose(k, math.exp(log_k(c, s, tau_2s)) if k > 0.0 else 0.0, rtol=1e-13)
            if k == 0.0:  # mu >= 25: K below 1e-270
                assert s == 0.0 or math.exp(log_k(c, s, tau_2s)) < 1e-260
            np.testing.assert_allclose(shadow, shadow_over_cos(c, s, tau_2s, sig_tau), rtol=1e-15)


def test_the_shipped_tables_are_the_code_s():
    """The tables read from ``_he_series.npz`` at import are, bit for bit, the ones the code builds now (the
    guard that the shipped file and the code agree: regenerate it with ``python -m core.models._he_tables``)."""
    from core.models import _he_series

    built = _he_series.build_tables()
    assert set(built) == {"ratio", "rough", "smooth"}
    assert np.array_equal(_he_series.RATIO_TABLE, built["ratio"])
    assert np.array_equal(_he_series.ROUGH_TABLE, built["rough"])
    assert np.array_equal(_he_series.SMOOTH_TABLE, built["smooth"])
    stored = _he_series.load_tables()  # the file itself, not a fallback: no warning (an error under pytest)
    assert all(np.array_equal(stored[name], built[name]) for name in built)


def test_a_written_tables_file_reads_back_the_same_bytes(tmp_path):
    """``write_tables`` writes atomically (no temporary file left) and the same tables make the same bytes."""
    from core.models import _he_series

    path = _he_series.write_tables(tmp_path / "tables.npz")
    assert [p.name for p in tmp_path.iterdir()] == ["tables.npz"]
    assert path.read_bytes() == _he_series.TABLES_FILE.read_bytes()
    stored = _he_series.load_tables(path)
    assert all(np.array_equal(stored[n], getattr(_he_series, f"{n.upper()}_TABLE")) for n in stored)


@pytest.mark.parametrize(
    "damage", ["missing", "garbage", "truncated", "one bit flipped", "other grid", "no table"]
)
def test_an_unusable_tables_file_warns_and_the_tables_are_built(tmp_path, damage):
    """A missing or damaged file: a ``RuntimeWarning`` naming the file and the command that writes it again,
    and the tables built in memory (the same values), not a traceback from numpy."""
    from core.models import _he_series

    path = tmp_path / "tables.npz"
    shipped = _he_series.TABLES_FILE.read_bytes()
    if damage == "garbage":
        path.write_bytes(b"not a zip file at all")
    elif damage == "truncated":
        path.write_bytes(shipped[: len(shipped) // 2])
    elif damage == "one bit flipped":  # in a table's values: the zip's CRC-32 catches it
        flipped = bytearray(shipped)
        flipped[len(shipped) // 2] ^= 1
        path.write_bytes(bytes(flipped))
    elif damage == "other grid":
        tables = {n: getattr(_he_series, f"{n.upper()}_TABLE") for n in ("ratio", "rough", "smooth")}
        np.savez(path, grid=_he_series._grid_key() + 1.0, **tables)
    elif damage == "no table":
        np.savez(path, grid=_he_series._grid_key(), ratio=_he_series.RATIO_TABLE)
    with pytest.warns(RuntimeWarning) as record:
        tables = _he_series.load_tables(path)
    message = str(record[0].message)
    assert str(path) in message and _he_series.REGENERATE in message, message
    assert _he_series.REGENERATE == "python -m core.models._he_tables"
    assert all(np.array_equal(tables[n], getattr(_he_series, f"{n.upper()}_TABLE")) for n in tables)


def test_the_check_command_reads_the_file_itself(tmp_path, monkeypatch, capsys):
    """``python -m core.models._he_tables --check`` passes on the shipped file and fails on a damaged one
    (it must not compare freshly built tables with the tables a damaged file falls back to)."""
    from core.models import _he_series, _he_tables

    assert _he_tables.main(["--check"]) == 0
    bad = tmp_path / "_he_series.npz"
    bad.write_bytes(b"not a zip archive")
    monkeypatch.setattr(_he_series, "TABLES_FILE", bad)
    assert _he_tables.main(["--check"]) == 1
    assert "not an .npz (zip) archive" in capsys.readouterr().out
