"""He-Torrance-Sillion-Greenberg's ``eval`` written directly, in plain Python: the series summed by each
term's logarithm, Newton's method for the effective roughness, two ``erfc`` a direction, one Fresnel term a
channel. ``test_he.py`` compares the model's kernels (tables, term ratios, Halley's method) with it."""

from __future__ import annotations

import math

from core.models._fresnel import fresnel_conductor
from core.models.he import _D_PREFACTOR, _K, _KD, _N, _SIGMA, _SIGMA_TAU, _TAU, _TAU_2SIGMA, _WAVENUMBER

INV_PI = 0.3183098861837907
_fresnel = fresnel_conductor.py_func

INV_SQRT_PI = 0.5641895835477563
TWO_SQRT_TWO_PI = 5.0132565492620005  # 2 sqrt(2 pi)
SERIES_TOL = 1e-17
"""Relative size of the last term kept on either side of the series' peak."""
MAX_TERMS = 200000


def shadow_over_cos(c, s, tau_over_2sigma, sigma_over_tau):
    """``S(theta) / cos(theta)`` of He et al. (Smith's shadowing for a Gaussian surface), finite at grazing.

    With ``mu = tau cot(theta) / (2 sigma)``, ``S = (1 - erfc(mu)/2) / (Lambda + 1)`` and
    ``Lambda = (exp(-mu^2) / (sqrt(pi) mu) - erfc(mu)) / 2``. Multiplying through by ``cos`` gives
    ``S / cos = N / (cos N + (sigma/tau) sin exp(-mu^2) / sqrt(pi))`` with ``N = 1 - erfc(mu)/2``, which has
    no ``0/0`` at grazing (``c -> 0``) nor at normal incidence (``s = 0``, where ``S = 1``).
    """
    if s <= 0.0:
        return 1.0 / c
    mu = tau_over_2sigma * c / s
    n = 1.0 - 0.5 * math.erfc(mu)
    e = math.exp(-mu * mu) if mu < 40.0 else 0.0
    return n / (c * n + sigma_over_tau * s * e * INV_SQRT_PI)


def log_k(c, s, tau_over_2sigma):
    """``ln K(theta)`` with ``K = tan(theta) erfc(tau cot(theta) / (2 sigma))``; ``-inf`` at normal incidence."""
    if s <= 0.0:
        return -math.inf
    mu = tau_over_2sigma * c / s
    if mu < 25.0:
        le = math.log(math.erfc(mu))
    else:
        # erfc underflows: ln erfc(mu) = -mu^2 - ln(mu sqrt(pi)) + ln(1 - 1/(2 mu^2) + 3/(4 mu^4) - ...)
        x = 1.0 / (mu * mu)
        le = -mu * mu - math.log(mu) - 0.5723649429247001 + math.log1p(-0.5 * x + 0.75 * x * x)
    return math.log(s) - math.log(c) + le


def effective_roughness_ratio(log_ki, log_kr):
    """``sigma_0 / sigma = (1 + z0^2 / sigma^2)^(-1/2)`` from He et al.'s equation for ``z0``:

        sqrt(pi/2) z0 = (sigma/4) (K_i + K_r) exp(-z0^2 / (2 sigma^2)).

    With ``u = z0 / sigma`` this is ``u exp(u^2/2) = C = (K_i + K_r) / (2 sqrt(2 pi))``, solved by Newton's
    method on ``t = ln u``: ``psi(t) = t + exp(2t)/2 - ln C`` is increasing and convex, so Newton converges
    from any start (monotonically after the first step).
    """
    hi = max(log_ki, log_kr)
    if hi == -math.inf:
        return 1.0
    lo = min(log_ki, log_kr)
    log_c = hi + math.log1p(math.exp(lo - hi)) - math.log(TWO_SQRT_TWO_PI)
    if log_c < -60.0:
        u = math.exp(log_c)  # u exp(u^2/2) = C with u ~ C < 1e-26: u = C to double precision
        return 1.0 / math.sqrt(1.0 + u * u)
    t = log_c if log_c < 0.0 else 0.5 * math.log(2.0 * log_c + 1.0)
    for _ in range(100):
        e2 = math.exp(2.0 * t)
        step = (t + 0.5 * e2 - log_c) / (1.0 + e2)
        t -= step
        if abs(step) < 1e-15 * max(1.0, abs(t)):
            break
    u2 = math.exp(2.0 * t)
    return 1.0 / math.sqrt(1.0 + u2)


HALF_LOG_TWO_PI = 0.9189385332046728


def _log_term(m, log_g, g, a):
    """``ln(g^m e^-g / (m! m) exp(-a/m))``; Stirling's series for ``ln m!`` when ``m >= 10`` (error below
    1e-12, and it reuses ``ln m``), ``lgamma`` below."""
    lm = math.log(m)
    if m >= 10.0:
        r = 1.0 / m
        r2 = r * r
        log_fact = (
            (m + 0.5) * lm
            - m
            + HALF_LOG_TWO_PI
            + r * (1.0 / 12.0 - r2 * (1.0 / 360.0 - r2 * (1.0 / 1260.0 - r2 / 1680.0)))
        )
    else:
        log_fact = math.lgamma(m + 1.0)
    return m * log_g - g - log_fact - lm - a / m


def diffuse_series(g, a):
    """``sum_{m>=1} g^m e^{-g} / (m! m) * exp(-a/m)`` to full double precision, for any ``g >= 0, a >= 0``.

    The term sequence is log-concave (the ratio ``T(m+1)/T(m) = g m exp(a/(m(m+1))) / (m+1)^2`` decreases in
    ``m``), so it has one peak. We locate it (Newton on the log-ratio), then add terms outward on both sides
    until they fall below ``SERIES_TOL`` of the running sum (adaptive truncation).

    For large ``g`` the peak is about ``sqrt(g)`` terms wide; once the terms near ``m = 1`` are negligible we add every
    ``k``-th term only (``k <= width / 2``) and multiply by ``k``: the trapezoidal rule on a smooth, rapidly
    decaying sequence, whose relative error is of order ``exp(-2 pi^2 (width/k)^2) < 1e-34``. The cost is then
    a few dozen terms for any ``g`` (He et al. switch to the rough-surface limit ``exp(-a/g)/g`` instead, the
    leading term of this same sum; its relative error is ``O(1/g)``, so we keep the exact sum).
    """
    if g <= 0.0:
        return 0.0
    log_g = math.log(g)
    # Peak: F(m) = ln T(m+1) - ln T(m) = ln g + ln m - 2 ln(m+1) + a/(m(m+1)) is decreasing in m.
    m = max(1.0, g)
    for _ in range(60):
        f = log_g + math.log(m) - 2.0 * math.log(m + 1.0) + a / (m * (m + 1.0))
        mm1 = m * (m + 1.0)
        df = 1.0 / m - 2.0 / (m + 1.0) - a * (2.0 * m + 1.0) / (mm1 * mm1)
        if df >= 0.0:
            break
        m_new = max(1.0, m - f / df)
        if abs(m_new - m) < 0.25:
            m = m_new
            break
        m = m_new
    m0 = max(1.0, math.floor(m + 0.5))
    mm1 = m0 * (m0 + 1.0)
    curv = -(1.0 / m0 - 2.0 / (m0 + 1.0) - a * (2.0 * m0 + 1.0) / (mm1 * mm1))
    width = 1.0 / math.sqrt(curv) if curv > 0.0 else 1.0
    lt0 = _log_term(m0, log_g, g, a)
    if lt0 < -745.0:
        return 0.0  # the largest term underflows: so does the sum (< 1e-300 after the sqrt(g)-wide peak)
    step = 1.0
    # Every k-th term only when the peak is wide and the sequence is negligible (< e^-40) at m = 1, where the
    # sum is cut off (the trapezoidal rule needs a negligible boundary).
    if width >= 5.0 and _log_term(1.0, log_g, g, a) - lt0 < -40.0:
        step = math.floor(width / 2.0)
    total = 1.0
    if step == 1.0:
        # exact sum by the term ratio: T(m+1) = T(m) g m exp(a/(m(m+1))) / (m+1)^2
        t = 1.0
        mm = m0
        for _ in range(MAX_TERMS):
            t *= g * mm * math.exp(a / (mm * (mm + 1.0))) / ((mm + 1.0) * (mm + 1.0))
            mm += 1.0
            total += t
            if t < SERIES_TOL * total:
                break
        t = 1.0
        mm = m0
        while mm > 1.0:
            t /= g * (mm - 1.0) * math.exp(a / ((mm - 1.0) * mm)) / (mm * mm)
            mm -= 1.0
            total += t
            if t < SERIES_TOL * total:
                break
        return math.exp(lt0) * total
    mm = m0
    for _ in range(MAX_TERMS):
        mm += step
        t = math.exp(_log_term(mm, log_g, g, a) - lt0)
        total += t
        if t < SERIES_TOL * total:
            break
    mm = m0
    for _ in range(MAX_TERMS):
        mm -= step
        if mm < 1.0:
            break
        t = math.exp(_log_term(mm, log_g, g, a) - lt0)
        total += t
        if t < SERIES_TOL * total:
            break
    return math.exp(lt0) * total * step


def eval_he_reference(wi, wo, p):
    ci = wi[2]
    co = wo[2]
    if ci <= 0.0 or co <= 0.0:
        return 0.0, 0.0, 0.0
    kd_r = p[_KD] * INV_PI
    kd_g = p[_KD + 1] * INV_PI
    kd_b = p[_KD + 2] * INV_PI
    # Keep tan(theta) finite for directions a hair above the horizon (well below any measurable angle).
    ci = max(ci, 1e-12)
    co = max(co, 1e-12)
    si = math.sqrt(max(0.0, 1.0 - ci * ci))
    so = math.sqrt(max(0.0, 1.0 - co * co))
    sigma = p[_SIGMA]
    wave_k = p[_WAVENUMBER]
    tau_2s = p[_TAU_2SIGMA]
    sig_tau = p[_SIGMA_TAU]

    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = ci + co
    hxy2 = hx * hx + hy * hy
    hh = hxy2 + hz * hz

    ratio = effective_roughness_ratio(log_k(ci, si, tau_2s), log_k(co, so, tau_2s))
    kz = wave_k * sigma * ratio * hz
    g = kz * kz
    tau = p[_TAU]
    a = 0.25 * tau * tau * wave_k * wave_k * hxy2
    series = diffuse_series(g, a)
    if series == 0.0:
        return kd_r, kd_g, kd_b
    geom = hh / hz
    geom *= geom
    common = (
        INV_PI
        * geom
        * shadow_over_cos(ci, si, tau_2s, sig_tau)
        * shadow_over_cos(co, so, tau_2s, sig_tau)
        * p[_D_PREFACTOR]
        * series
    )
    cos_b = min(0.5 * math.sqrt(hh), 1.0)
    return (
        kd_r + common * _fresnel(cos_b, p[_N], p[_K]),
        kd_g + common * _fresnel(cos_b, p[_N + 1], p[_K + 1]),
        kd_b + common * _fresnel(cos_b, p[_N + 2], p[_K + 2]),
    )
