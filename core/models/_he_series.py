"""Numerical building blocks of the He-Torrance-Sillion-Greenberg model (see :mod:`core.models.he`).

Kept apart from the model module so the tests can reach each piece: the shadowing function, the effective
roughness from the Newton iteration, and the Poisson-weighted series of the directional-diffuse term.
All functions are numba kernels working on plain floats.
"""

from __future__ import annotations

import math

from numba import njit

INV_SQRT_PI = 0.5641895835477563
TWO_SQRT_TWO_PI = 5.0132565492620005  # 2 sqrt(2 pi)
SERIES_TOL = 1e-14
"""Relative size of the last term kept on either side of the series' peak. Beyond it the terms fall faster than
geometrically (the sequence is log-concave), so what is left off is of the same order; 1e-17 before took 13 %
more terms for digits no use of the BRDF can see."""
MAX_TERMS = 200000
RATIO_STRIDE_MAX = 8
RATIO_A_MAX = 1e4
"""Strides up to ``RATIO_STRIDE_MAX`` with ``a`` up to ``RATIO_A_MAX`` (the seed's settings reach 550) add
the terms by their ratio (one exponential a term, no logarithm); beyond, each term's logarithm, as the ratio's
exponent ``a k / (m (m + k))`` then carries rounding of order 1e-12 over the sum (measured against the
logarithms' sum; within 1.2e-13 of it inside these limits, ``tests/core/models/test_he.py``)."""


@njit(nogil=True, cache=True)
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


@njit(nogil=True, cache=True)
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


@njit(nogil=True, cache=True)
def direction_terms(c, s, tau_over_2sigma, sigma_over_tau):
    """``(ln K, S / cos)`` of one direction (:func:`log_k` and :func:`shadow_over_cos`): both read
    ``mu = tau cot(theta) / (2 sigma)`` and ``erfc(mu)``, computed once here, and ``ln K = ln(s erfc(mu) / c)``
    takes one logarithm (the same values to rounding, ~1e-16; no underflow: ``erfc(mu) > 1e-274`` below
    ``mu = 25``, beyond which the asymptotic ``ln erfc`` is used as in :func:`log_k`)."""
    if s <= 0.0:
        return -math.inf, 1.0 / c
    mu = tau_over_2sigma * c / s
    ec = math.erfc(mu)
    if mu < 25.0:
        lk = math.log(s * ec / c)
    else:
        x = 1.0 / (mu * mu)
        lk = (
            math.log(s / c)
            - mu * mu
            - math.log(mu)
            - 0.5723649429247001
            + math.log1p(-0.5 * x + 0.75 * x * x)
        )
    e = math.exp(-mu * mu) if mu < 40.0 else 0.0
    n = 1.0 - 0.5 * ec
    return lk, n / (c * n + sigma_over_tau * s * e * INV_SQRT_PI)


@njit(nogil=True, cache=True)
def effective_roughness_ratio(log_ki, log_kr):
    """``sigma_0 / sigma = (1 + z0^2 / sigma^2)^(-1/2)`` from He et al.'s equation for ``z0``:

        sqrt(pi/2) z0 = (sigma/4) (K_i + K_r) exp(-z0^2 / (2 sigma^2)).

    With ``u = z0 / sigma`` this is ``u exp(u^2/2) = C = (K_i + K_r) / (2 sqrt(2 pi))``, solved on ``t = ln u``:
    ``psi(t) = t + exp(2t)/2 - ln C`` is increasing and convex. Halley's method (cubic convergence) from
    ``t = ln C - C^2 / 2`` (the small-``C`` expansion ``u = C - C^3/2 + ...``) when ``ln C < -1``, ``ln C`` up
    to 0 and ``ln(2 ln C + 1) / 2`` beyond: 1 to 3 exponentials, where Newton's method took 1 to 6. It stops after a
    step below ``1e-6`` (the next error is of order ``step^3``), and ``u^2 = exp(2t)`` is updated from the
    last exponential by the Taylor series of ``exp(-2 step)`` to second order (error ``~step^3``)."""
    hi = max(log_ki, log_kr)
    if hi == -math.inf:
        return 1.0
    lo = min(log_ki, log_kr)
    log_c = hi + math.log1p(math.exp(lo - hi)) - math.log(TWO_SQRT_TWO_PI)
    if log_c < -60.0:
        u = math.exp(log_c)  # u exp(u^2/2) = C with u ~ C < 1e-26: u = C to double precision
        return 1.0 / math.sqrt(1.0 + u * u)
    if log_c < -1.0:
        t = log_c - 0.5 * math.exp(2.0 * log_c)
    elif log_c < 0.0:
        t = log_c
    else:
        t = 0.5 * math.log(2.0 * log_c + 1.0)
    u2 = math.exp(2.0 * t)
    for _ in range(100):
        e2 = u2
        f = t + 0.5 * e2 - log_c
        d1 = 1.0 + e2
        step = f / d1 / (1.0 - f * e2 / (d1 * d1))
        t -= step
        if abs(step) < 1e-6:
            u2 = e2 * (1.0 - 2.0 * step + 2.0 * step * step)
            break
        u2 = math.exp(2.0 * t)
    return 1.0 / math.sqrt(1.0 + u2)


HALF_LOG_TWO_PI = 0.9189385332046728


@njit(nogil=True, cache=True)
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


@njit(nogil=True, cache=True)
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
    # from the larger of g (the Poisson peak, a = 0) and 0.7 sqrt(a) (where exp(-a/m) lets the terms rise):
    # 2-3 steps where g alone took 4-7 at the seed's settings; any start near the peak gives the same sum
    m = max(1.0, g, 0.7 * math.sqrt(a))
    for _ in range(60):
        f = log_g + math.log(m / ((m + 1.0) * (m + 1.0))) + a / (m * (m + 1.0))
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
        # exact sum by the term ratio: T(m+1) = T(m) g m exp(a/(m(m+1))) / (m+1)^2, with one division:
        # q = 1/(m(m+1)) and 1/(m+1) = q m (the same terms to rounding, ~1e-16 each)
        t = 1.0
        mm = m0
        for _ in range(MAX_TERMS):
            q = 1.0 / (mm * (mm + 1.0))
            qm = q * mm
            t *= g * mm * math.exp(a * q) * (qm * qm)
            mm += 1.0
            total += t
            if t < SERIES_TOL * total:
                break
        t = 1.0
        mm = m0
        inv_g = 1.0 / g
        while mm > 1.0:
            # T(m-1) = T(m) m^2 / (g (m-1) exp(a/((m-1) m))), 1/(m-1) = q m with q = 1/((m-1) m)
            q = 1.0 / ((mm - 1.0) * mm)
            t *= mm * mm * (q * mm) * math.exp(-a * q) * inv_g
            mm -= 1.0
            total += t
            if t < SERIES_TOL * total:
                break
        return math.exp(lt0) * total
    k = int(step)
    if k <= RATIO_STRIDE_MAX and a <= RATIO_A_MAX:
        # every k-th term by the ratio T(m+k) / T(m) = g^k m exp(a k / (m (m+k))) / ((m+k) (m+1)...(m+k)):
        # one exponential and no logarithm a term (the same terms to rounding, ~k+5 ulp a step)
        gk = g**k
        t = 1.0
        mm = m0
        for _ in range(MAX_TERMS):
            hi = mm + step
            prod = hi
            for j in range(1, k + 1):
                prod *= mm + j
            t *= gk * mm * math.exp(a * step / (mm * hi)) / prod
            mm = hi
            total += t
            if t < SERIES_TOL * total:
                break
        t = 1.0
        mm = m0
        for _ in range(MAX_TERMS):
            lo = mm - step
            if lo < 1.0:
                break
            prod = lo
            for j in range(1, k + 1):
                prod *= lo + j
            t *= mm * prod * math.exp(-a * step / (lo * mm)) / (gk * lo * lo)
            mm = lo
            total += t
            if t < SERIES_TOL * total:
                break
        return math.exp(lt0) * total * step
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
