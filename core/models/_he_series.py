"""Numerical building blocks of the He-Torrance-Sillion-Greenberg model (see :mod:`core.models.he`).

Kept apart from the model module so the tests can reach each piece: the shadowing function, the effective
roughness from the Newton iteration, and the Poisson-weighted series of the directional-diffuse term.
The kernels are numba functions working on plain floats; the tables they read are computed once from them and
shipped as ``_he_series.npz`` (:data:`TABLES_FILE`, written by ``python -m core.models._he_tables``).
"""

from __future__ import annotations

import math
import os
import warnings
import zipfile
from pathlib import Path

import numpy as np
from numba import njit

from core.jit import kernel

INV_SQRT_PI = 0.5641895835477563
TWO_SQRT_TWO_PI = 5.0132565492620005  # 2 sqrt(2 pi)
LOG_TWO_SQRT_TWO_PI = math.log(TWO_SQRT_TWO_PI)
SERIES_TOL = 1e-14
"""Relative size of the last term kept on either side of the series' peak. Beyond it the terms fall faster than
geometrically (the sequence is log-concave), so what is left off is of the same order; 1e-17 would take 13 %
more terms for digits no use of the BRDF can see."""
MAX_TERMS = 200000
RATIO_STRIDE_MAX = 8
RATIO_A_MAX = 1e4
"""Strides up to ``RATIO_STRIDE_MAX`` with ``a`` up to ``RATIO_A_MAX`` (the seed's settings reach 550) add
the terms by their ratio (one exponential a term, no logarithm); beyond, each term's logarithm, as the ratio's
exponent ``a k / (m (m + k))`` then carries rounding of order 1e-12 over the sum (measured against the
logarithms' sum; within 1.2e-13 of it inside these limits, ``tests/core/models/test_he.py``)."""


@njit(inline="always", nogil=True, cache=True)
def _dot6(w, values, j):
    """``sum_k w[k] values[j + k]`` over six nodes, left to right."""
    return (
        w[0] * values[j]
        + w[1] * values[j + 1]
        + w[2] * values[j + 2]
        + w[3] * values[j + 3]
        + w[4] * values[j + 4]
        + w[5] * values[j + 5]
    )


@njit(inline="always", nogil=True, cache=True)
def _lagrange6(t):
    """Weights of the six-node Lagrange interpolant on the nodes ``0..5`` at ``t``."""
    d0 = t
    d1 = t - 1.0
    d2 = t - 2.0
    d3 = t - 3.0
    d4 = t - 4.0
    d5 = t - 5.0
    p01 = d0 * d1
    p23 = d2 * d3
    p45 = d4 * d5
    return (
        d1 * p23 * p45 * (-1.0 / 120.0),
        d0 * p23 * p45 * (1.0 / 24.0),
        p01 * d3 * p45 * (-1.0 / 12.0),
        p01 * d2 * p45 * (1.0 / 12.0),
        p01 * p23 * d5 * (-1.0 / 24.0),
        p01 * p23 * d4 * (1.0 / 120.0),
    )


@kernel
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


@kernel
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


@kernel
def direction_k(c, s, tau_over_2sigma, sigma_over_tau):
    """``(K, S / cos)`` of one direction (:func:`log_k`'s ``K`` itself and :func:`shadow_over_cos`): both read
    ``mu = tau cot(theta) / (2 sigma)`` and ``erfc(mu)``, computed once here; the kernel adds the two
    directions' ``K`` and takes one logarithm (:func:`log_roughness_ratio_of_k`). ``K = 0`` where ``mu >= 25``:
    there ``K < 1e-270`` and ``S / cos = 1 / cos`` to rounding (a ``K`` that small vanishes against the other
    direction's, and a sum ``C`` below ``e^-60`` gives ``sigma_0 = sigma`` to rounding)."""
    if s <= 0.0:
        return 0.0, 1.0 / c
    mu = tau_over_2sigma * c / s
    if mu >= 25.0:
        return 0.0, 1.0 / c
    ec = math.erfc(mu)
    e = math.exp(-mu * mu)
    n = 1.0 - 0.5 * ec
    return s * ec / c, n / (c * n + sigma_over_tau * s * e * INV_SQRT_PI)


@kernel
def _initial_log_u(log_c):
    """A start for :func:`_halley_u2`: ``ln C - C^2 / 2`` (the small-``C`` expansion ``u = C - C^3/2 + ...``)
    when ``ln C < -1``, ``ln C`` up to 0 and ``ln(2 ln C + 1) / 2`` beyond."""
    if log_c < -1.0:
        return log_c - 0.5 * math.exp(2.0 * log_c)
    if log_c < 0.0:
        return log_c
    return 0.5 * math.log(2.0 * log_c + 1.0)


@kernel
def _halley_u2(log_c, t):
    """``u^2`` with ``u exp(u^2/2) = C`` by Halley's method on ``t = ln u`` from ``t`` (see
    :func:`effective_roughness_ratio`)."""
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
    return u2


@kernel
def effective_roughness_ratio(log_ki, log_kr):
    """``sigma_0 / sigma = (1 + z0^2 / sigma^2)^(-1/2)`` from He et al.'s equation for ``z0``:

        sqrt(pi/2) z0 = (sigma/4) (K_i + K_r) exp(-z0^2 / (2 sigma^2)).

    With ``u = z0 / sigma`` this is ``u exp(u^2/2) = C = (K_i + K_r) / (2 sqrt(2 pi))``, solved on ``t = ln u``:
    ``psi(t) = t + exp(2t)/2 - ln C`` is increasing and convex. Halley's method (cubic convergence) from
    ``t = ln C - C^2 / 2`` (the small-``C`` expansion ``u = C - C^3/2 + ...``) when ``ln C < -1``, ``ln C`` up
    to 0 and ``ln(2 ln C + 1) / 2`` beyond: 1 to 3 exponentials, where Newton's method takes 1 to 6. It stops after a
    step below ``1e-6`` (the next error is of order ``step^3``), and ``u^2 = exp(2t)`` is updated from the
    last exponential by the Taylor series of ``exp(-2 step)`` to second order (error ``~step^3``)."""
    hi = max(log_ki, log_kr)
    if hi == -math.inf:
        return 1.0
    lo = min(log_ki, log_kr)
    log_c = hi + math.log1p(math.exp(lo - hi)) - LOG_TWO_SQRT_TWO_PI
    if log_c < -60.0:
        u = math.exp(log_c)  # u exp(u^2/2) = C with u ~ C < 1e-26: u = C to double precision
        return 1.0 / math.sqrt(1.0 + u * u)
    return 1.0 / math.sqrt(1.0 + _halley_u2(log_c, _initial_log_u(log_c)))


RATIO_X_MIN = -20.0
RATIO_X_MAX = 32.0
RATIO_STEP = 1.0 / 128.0
RATIO_NODES = int(round((RATIO_X_MAX - RATIO_X_MIN) / RATIO_STEP)) + 6
"""The table of :func:`log_roughness_ratio_of_k`: ``ln(sigma_0 / sigma)`` at ``ln C = RATIO_X_MIN + (i - 2) h``
(two nodes below ``RATIO_X_MIN``, three above ``RATIO_X_MAX``: every ``ln C`` between has its centred stencil)."""


@njit(nogil=True, cache=True)
def _ratio_table():
    out = np.empty(RATIO_NODES)
    for i in range(RATIO_NODES):
        x = RATIO_X_MIN + (i - 2) * RATIO_STEP
        out[i] = -0.5 * math.log1p(_halley_u2(x, _initial_log_u(x)))
    return out


# RATIO_TABLE (of _ratio_table) is read from the tables' file with the series' tables: see load_tables below


@kernel
def log_roughness_ratio_of_k(k_sum):
    """``ln(sigma_0 / sigma)`` (:func:`effective_roughness_ratio`'s logarithm) from ``K_i + K_r`` itself (of
    :func:`direction_k`): ``-ln(1 + u^2) / 2`` read from ``RATIO_TABLE`` by six-node Lagrange interpolation in
    ``ln C`` for ``ln C`` in ``[RATIO_X_MIN, RATIO_X_MAX]`` (within 4e-15 of the converged iteration),
    ``-C^2 / 2`` below (``u = C + O(C^3)``: error below ``C^4 < 1e-34``), the iteration above. One logarithm and
    six table values, where the iteration takes two to four exponentials in sequence."""
    if k_sum <= 0.0:
        return 0.0
    x = math.log(k_sum) - LOG_TWO_SQRT_TWO_PI
    if x < RATIO_X_MIN:
        c = math.exp(x)
        return -0.5 * c * c
    if x > RATIO_X_MAX:
        return -0.5 * math.log1p(_halley_u2(x, _initial_log_u(x)))
    u = (x - RATIO_X_MIN) * (1.0 / RATIO_STEP) + 2.0
    i = min(int(u) - 2, RATIO_NODES - 6)
    return _dot6(_lagrange6(u - i), RATIO_TABLE, i)


HALF_LOG_TWO_PI = 0.9189385332046728


@kernel
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


@kernel
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
    # 2-3 steps where g alone takes 4-7 at the seed's settings; any start near the peak gives the same sum
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


# ------------------------------------------------------------------------------------------ the series' tables
TABLE_A_MAX = 1024.0
TABLE_G_MAX = 128.0
TABLE_G_MID = 1.0
TABLE_G_MIN = 0.1
"""The tabulated domain: ``0.1 <= g <= 128`` and ``0 <= a <= 1024`` (the seed's settings reach ``g = 61.7`` and
``a = 555``), in two tables split at ``g = 1``; outside, :func:`tabulated_series_log` sums the series
(:func:`diffuse_series`)."""
TABLE_STEP = 1.0 / 32.0
"""Node spacing in ``x = ln g`` (both tables) and in ``y = ln(1 + a)`` (``g >= 1``; half of it below, where the
terms near ``m = 1`` make the sum turn faster with ``a``: at ``1/32`` the error there reached 1.8e-8)."""
TABLE_TOL = 2e-9
"""Bound of ``|tabulated_series_log / diffuse_series - 1|`` over the domain: the largest measured, on 16 points
of every cell of both tables and 10^6 random points, is 8.4e-10 (near ``g = 1``, ``a = 5``); a sample of them
is checked by ``tests/core/models/test_he.py``."""


def _grid(g_lo: float, g_hi: float, step_y: float) -> tuple[float, int, int]:
    """``(x of row 0, rows, columns)`` of a table over ``[g_lo, g_hi] x [0, TABLE_A_MAX]``: two rows below
    ``ln g_lo`` and three above ``ln g_hi``, so that every point has its centred six-node stencil in ``x``; in
    ``y`` the stencil is shifted near ``a = 0`` to stay in ``a >= 0``."""
    x0 = math.log(g_lo) - 2.0 * TABLE_STEP
    rows = int(math.ceil((math.log(g_hi) - math.log(g_lo)) / TABLE_STEP)) + 6
    cols = int(math.ceil(math.log1p(TABLE_A_MAX) / step_y)) + 4
    return x0, rows, cols


ROUGH_X0, ROUGH_ROWS, ROUGH_COLS = _grid(TABLE_G_MID, TABLE_G_MAX, TABLE_STEP)
SMOOTH_X0, SMOOTH_ROWS, SMOOTH_COLS = _grid(TABLE_G_MIN, TABLE_G_MID, TABLE_STEP / 2.0)
LOG_TABLE_G_MIN = math.log(TABLE_G_MIN)
LOG_TABLE_G_MAX = math.log(TABLE_G_MAX)


@njit(nogil=True, cache=True)
def _series_table(x0, rows, cols, step_y):
    """``ln diffuse_series(g, a)`` on the nodes ``x_i = x0 + i TABLE_STEP``, ``y_j = j step_y`` (``g = e^x``,
    ``a = e^y - 1``)."""
    out = np.empty((rows, cols))
    for i in range(rows):
        g = math.exp(x0 + i * TABLE_STEP)
        for j in range(cols):
            out[i, j] = math.log(diffuse_series(g, math.expm1(j * step_y)))
    return out


TABLES_FILE = Path(__file__).with_name("_he_series.npz")
"""The tables, computed once by :func:`build_tables` and shipped with the package (uncompressed ``.npz``,
634 kB; ~1 ms to read, where building them took numba's cached functions, 0.3-0.6 s at every import).
:mod:`core._numba_cache` stamps the compiled kernels of this module with this file too: the kernels freeze the
tables' values, so a regenerated file recompiles them."""
REGENERATE = "python -m core.models._he_tables"


def _grid_key() -> np.ndarray:
    """The constants the tables are built on, stored with them: a file built on another grid is not used."""
    constants = (RATIO_X_MIN, RATIO_X_MAX, RATIO_STEP, RATIO_NODES, TABLE_A_MAX, TABLE_G_MIN, TABLE_G_MID)
    constants += (TABLE_G_MAX, TABLE_STEP, ROUGH_X0, ROUGH_ROWS, ROUGH_COLS, SMOOTH_X0, SMOOTH_ROWS)
    constants += (SMOOTH_COLS,)
    return np.array(constants, dtype=np.float64)


TABLE_SHAPES = {
    "ratio": (RATIO_NODES,),
    "rough": (ROUGH_ROWS, ROUGH_COLS),
    "smooth": (SMOOTH_ROWS, SMOOTH_COLS),
}


def build_tables() -> dict[str, np.ndarray]:
    """The three tables computed from the code: ``ratio`` (:func:`log_roughness_ratio_of_k`'s, of
    :func:`_ratio_table`), ``rough`` and ``smooth`` (``ln`` of :func:`diffuse_series` for ``g >= 1`` and below)."""
    return {
        "ratio": _ratio_table(),
        "rough": _series_table(ROUGH_X0, ROUGH_ROWS, ROUGH_COLS, TABLE_STEP),
        "smooth": _series_table(SMOOTH_X0, SMOOTH_ROWS, SMOOTH_COLS, TABLE_STEP / 2.0),
    }


class TablesFileError(ValueError):
    """What makes the tables' file unusable (missing, damaged, of another grid)."""


def _read_tables(path: Path) -> dict[str, np.ndarray]:
    """The tables stored at ``path``; :class:`TablesFileError` naming what is wrong with the file."""
    names = ("grid", *TABLE_SHAPES)
    if not path.is_file():
        raise TablesFileError("the file is missing")
    if not zipfile.is_zipfile(path):  # np.load would try it as a pickle
        raise TablesFileError("the file is not an .npz (zip) archive")
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [name for name in names if name not in data.files]
            stored = {} if missing else {name: data[name] for name in names}
    except (OSError, EOFError, ValueError, zipfile.BadZipFile) as exc:
        raise TablesFileError(f"the file cannot be read ({type(exc).__name__}: {exc})") from None
    if missing:
        raise TablesFileError(f"the file has no {', '.join(missing)} table")
    if not all(isinstance(table, np.ndarray) for table in stored.values()):  # a member that is not .npy
        raise TablesFileError("the file holds a table that is not an .npy array")
    grid = stored.pop("grid")
    if grid.shape != _grid_key().shape or not np.array_equal(grid, _grid_key()):
        raise TablesFileError("the file was built on other grid constants than the code's")
    for name, table in stored.items():
        if table.dtype != np.float64 or table.shape != TABLE_SHAPES[name]:
            raise TablesFileError(
                f"its table {name!r} is {table.dtype} {table.shape}, not float64 {TABLE_SHAPES[name]}"
            )
        if not np.isfinite(table).all():
            raise TablesFileError(f"its table {name!r} holds non-finite values")
    return stored


def load_tables(path: Path = TABLES_FILE) -> dict[str, np.ndarray]:
    """The tables of the file ``path``; when it is missing or unusable, a ``RuntimeWarning`` naming it and the
    command that writes it again, and the tables built in memory (the same values, 0.3-0.6 s)."""
    try:
        return _read_tables(Path(path))
    except TablesFileError as exc:
        warnings.warn(
            f"He's series tables {path}: {exc}. Building them in memory instead; "
            f"regenerate the file with `{REGENERATE}`.",
            RuntimeWarning,
            stacklevel=2,
        )
    return build_tables()


def write_tables(path: Path = TABLES_FILE) -> Path:
    """Compute the tables (:func:`build_tables`) and write them to ``path`` atomically (a temporary file in the
    same folder, then renamed over it)."""
    path = Path(path)
    tables = build_tables()
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        # np.savez's layout (one .npy a table, uncompressed) with a fixed date in the zip entries: the same tables
        # make the same bytes, so writing them again changes neither git nor the kernels' cache stamps
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED) as z:
            for name, table in (("grid", _grid_key()), *tables.items()):
                info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                with z.open(info, "w", force_zip64=True) as out:
                    np.lib.format.write_array(out, np.ascontiguousarray(table), allow_pickle=False)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


_TABLES = load_tables()
RATIO_TABLE = _TABLES["ratio"]
ROUGH_TABLE = _TABLES["rough"]
SMOOTH_TABLE = _TABLES["smooth"]
"""``ln`` of the series for ``g >= 1`` (162 x 226 values) and below (80 x 448), read from ``TABLES_FILE``
(built by :func:`_series_table`) and frozen into the compiled kernels (580 kB together)."""


@njit(inline="always", nogil=True, cache=True)
def _row_at(table, i, j, w):
    """Row ``i`` of ``table`` interpolated in ``y`` from columns ``j..j+5`` with the weights ``w``."""
    return _dot6(w, table[i], j)


@njit(inline="always", nogil=True, cache=True)
def _interpolate(table, x0, step_y, log_g, a):
    """``exp`` of the six-by-six-node Lagrange interpolant of ``table`` at ``(ln g, ln(1 + a))``."""
    u = (log_g - x0) * (1.0 / TABLE_STEP)
    v = math.log1p(a) * (1.0 / step_y)
    i = min(int(u) - 2, table.shape[0] - 6)
    j = min(max(int(v) - 2, 0), table.shape[1] - 6)
    w0, w1, w2, w3, w4, w5 = _lagrange6(u - i)
    wy = _lagrange6(v - j)
    s = w0 * _row_at(table, i, j, wy) + w1 * _row_at(table, i + 1, j, wy) + w2 * _row_at(table, i + 2, j, wy)
    s += (
        w3 * _row_at(table, i + 3, j, wy)
        + w4 * _row_at(table, i + 4, j, wy)
        + w5 * _row_at(table, i + 5, j, wy)
    )
    return math.exp(s)


@kernel
def tabulated_series(g, a):
    """:func:`tabulated_series_log` of ``ln g`` (0 for ``g <= 0``)."""
    if g <= 0.0:
        return 0.0
    return tabulated_series_log(math.log(g), a)


@kernel
def tabulated_series_log(log_g, a):
    """:func:`diffuse_series` of ``g = exp(log_g)`` within ``TABLE_TOL`` (relative): interpolated in
    ``ROUGH_TABLE`` or ``SMOOTH_TABLE`` where ``(g, a)`` is in their domain, else the sum itself.

    ``ln`` of the series is a smooth function of ``x = ln g`` and ``y = ln(1 + a)``: the logarithm of a sum of
    positive terms each ``exp`` of a function linear in ``x`` and in ``a``, whose derivatives are cumulants
    of ``m`` and ``1/m`` under the terms' weights; ``y`` spaces the nodes as those of ``1/m`` shrink with
    ``a``. It is interpolated by the tensor product of six-node Lagrange polynomials (error of order
    ``h^6``): 36 table values, one logarithm and one exponential, where the sum takes 30 to 60 exponentials
    at the seed's settings."""
    if 0.0 <= a <= TABLE_A_MAX:
        if 0.0 <= log_g <= LOG_TABLE_G_MAX:
            return _interpolate(ROUGH_TABLE, ROUGH_X0, TABLE_STEP, log_g, a)
        if LOG_TABLE_G_MIN <= log_g < 0.0:
            return _interpolate(SMOOTH_TABLE, SMOOTH_X0, TABLE_STEP / 2.0, log_g, a)
    return diffuse_series(math.exp(log_g), a)
