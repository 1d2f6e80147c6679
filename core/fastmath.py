"""Arc tangent, arc cosine, sine and cosine for compiled loops, within a few units in the last place of the
library's, without its calls.

The library's ``atan2``, ``acos`` and ``sin``/``cos`` cost 15-25 ns each in a loop (a call that LLVM cannot
inline or overlap with its neighbours); a draw of a tabulated sampler made three or four of them (8-9 % of a
demo pass of ``uniform_cdf`` or ``factored`` by ``perf``). These are a few multiply-adds each, by
Estrin's scheme (short chains of dependent operations), inlined where they are called, and their octants,
quadrants and signs are selects rather than branches: a batch of draws or a sweep of a disk falls in every
octant, and a mispredicted branch costs more than the work it skips (in isolation, a ``uniform_cdf`` draw
takes 113 ns instead of 137 with the library's calls, a ``compress_cdf`` draw 80 instead of 106, a ``factored``
density 43 instead of 61; the same values to the bit).

- :func:`atan2`: reduction to ``[0, 1]`` by the octant, above ``tan(pi/8)`` by ``pi/4 + atan((t-1)/(t+1))``,
  then a degree-10 polynomial in ``t^2`` (a Chebyshev fit; within 5e-16 of the library's).
- :func:`acos`: ``atan2(sqrt((1 - x)(1 + x)), x)`` (the product keeps the root accurate near ``|x| = 1``).
- :func:`sin_cos`: reduction to ``|t| <= pi/4`` by the nearest multiple of ``pi/2`` (one multiply-subtract:
  exact enough for the angles of a sphere's parameterization, ``|phi| <= 4 pi``), then the Taylor
  polynomials of ``sin`` and ``cos`` to degree 17 and 16 (truncation below 2e-17) and the quarter turns.
"""

from __future__ import annotations

import math

from numba import njit

HALF_PI = 0.5 * math.pi
QUARTER_PI = 0.25 * math.pi
_TAN_PI_8 = 0.41421356237309503

# Coefficients of (atan(t) / t - 1) / t^2 as a polynomial in u = t^2 on [0, tan(pi/8)^2]: a Chebyshev fit of
# degree 10 to the series (error below 4e-16 there; atan's own below 1e-17 absolute).
_ATAN = (
    -0.3333333333333335, 0.19999999999996815, -0.14285714284955728, 0.11111111039382242, -0.09090905577789848,
    0.07692206606588207, -0.06664841459947057, 0.058610027663728734, -0.05100269245681807, 0.03965572205667133,
    -0.019690822004180538,
)  # fmt: skip
_A0, _A1, _A2, _A3, _A4, _A5, _A6, _A7, _A8, _A9, _A10 = _ATAN

# Taylor coefficients of sin(t) / t and cos(t) in t^2, to degree 16-17 in t
_S1, _S2, _S3, _S4 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0
_S5, _S6, _S7, _S8 = -1.0 / 39916800.0, 1.0 / 6227020800.0, -1.0 / 1307674368000.0, 1.0 / 355687428096000.0
_C1, _C2, _C3, _C4 = -0.5, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0
_C5, _C6, _C7, _C8 = -1.0 / 3628800.0, 1.0 / 479001600.0, -1.0 / 87178291200.0, 1.0 / 20922789888000.0
_INV_HALF_PI = 2.0 / math.pi


@njit(inline="always", nogil=True, cache=True)
def atan_unit(t):
    """``atan(t)`` for ``t`` in ``[0, 1]`` (within 5e-16). Selects, not branches (see :func:`atan2`)."""
    big = t > _TAN_PI_8
    r = (t - 1.0) / (t + 1.0)
    t = r if big else t
    off = QUARTER_PI if big else 0.0
    u = t * t
    u2 = u * u
    u4 = u2 * u2
    u8 = u4 * u4
    f = (
        ((_A0 + _A1 * u) + u2 * (_A2 + _A3 * u))
        + u4 * ((_A4 + _A5 * u) + u2 * (_A6 + _A7 * u))
        + u8 * ((_A8 + _A9 * u) + u2 * _A10)
    )
    return off + (t + t * u * f)


@njit(inline="always", nogil=True, cache=True)
def atan2(y, x):
    """``atan2(y, x)`` in ``[-pi, pi]`` (within 5e-16 of the library's; 0 at the origin, and for ``x = -0.0``,
    where the library gives pi: signed zeros are not told apart).

    Every octant and sign is a select, not a branch: the directions of a sweep or of a batch of draws fall in
    any octant, and each mispredicted branch cost more than the division and polynomial it skipped."""
    ay = abs(y)
    ax = abs(x)
    swap = ay > ax
    num = ax if swap else ay
    den = ay if swap else ax
    a = atan_unit(num / (den if den != 0.0 else 1.0))  # den = 0: both are, and t = 0 (NaN stays NaN)
    a = HALF_PI - a if swap else a
    a = math.pi - a if x < 0.0 else a
    return -a if y < 0.0 else a


@njit(inline="always", nogil=True, cache=True)
def acos(x):
    """``acos(x)`` for ``x`` in ``[-1, 1]`` (clamped), in ``[0, pi]``."""
    x = min(1.0, max(-1.0, x))
    return atan2(math.sqrt((1.0 - x) * (1.0 + x)), x)


@njit(inline="always", nogil=True, cache=True)
def sincos_small(t):
    """``(sin t, cos t)`` for ``|t| <= pi/4`` by their Taylor polynomials (error below 2e-17)."""
    t2 = t * t
    t4 = t2 * t2
    t8 = t4 * t4
    t16 = t8 * t8
    s = (
        ((1.0 + _S1 * t2) + t4 * (_S2 + _S3 * t2))
        + t8 * ((_S4 + _S5 * t2) + t4 * (_S6 + _S7 * t2))
        + t16 * _S8
    )
    c = (
        ((1.0 + _C1 * t2) + t4 * (_C2 + _C3 * t2))
        + t8 * ((_C4 + _C5 * t2) + t4 * (_C6 + _C7 * t2))
        + t16 * _C8
    )
    return t * s, c


@njit(inline="always", nogil=True, cache=True)
def sin_cos(phi):
    """``(sin phi, cos phi)`` for ``|phi| <= 4 pi`` (within ~4e-16 absolute of the library's): the nearest
    multiple ``k pi/2`` taken off, then a quarter turn per unit of ``k``."""
    k = int(math.floor(phi * _INV_HALF_PI + 0.5))
    s, c = sincos_small(phi - k * HALF_PI)
    # quarter turns k & 3 = 0, 1, 2, 3: (s, c), (c, -s), (-s, -c), (-c, s), by selects (no jump table)
    odd = (k & 1) == 1
    s1 = c if odd else s
    c1 = s if odd else c
    s1 = -s1 if (k & 2) != 0 else s1
    c1 = -c1 if ((k + 1) & 2) != 0 else c1
    return s1, c1


# Abramowitz & Stegun 4.4.46: acos(x) = sqrt(1 - x) (a0 + a1 x + ... + a7 x^7) on [0, 1], within 2.2e-8
_AC0, _AC1, _AC2, _AC3 = 1.5707963050, -0.2145988016, 0.0889789874, -0.0501743046
_AC4, _AC5, _AC6, _AC7 = 0.0308918810, -0.0170881256, 0.0066700901, -0.0012624911
_CELL_MARGIN = 1e-5
"""How far inside a cell (in cells) :func:`polar_cell`'s estimate must fall to be taken: its arc cosine errs
by < 2.2e-8 rad, under 1e-6 of a cell of up to ~100 cells to the quarter turn."""


@njit(inline="always", nogil=True, cache=True)
def acos_estimate(x):
    """``acos(x)`` for ``x`` in ``[-1, 1]`` within 2.2e-8 (Abramowitz & Stegun 4.4.46: a square root and a
    degree-7 polynomial, no division): a starting point or a cell's estimate, never an angle to keep."""
    ax = min(1.0, abs(x))
    x2 = ax * ax
    x4 = x2 * x2
    lo = (_AC0 + _AC1 * ax) + x2 * (_AC2 + _AC3 * ax)
    hi = (_AC4 + _AC5 * ax) + x2 * (_AC6 + _AC7 * ax)
    r = math.sqrt(1.0 - ax) * (lo + x4 * hi)
    return r if x >= 0.0 else math.pi - r


@njit(inline="always", nogil=True, cache=True)
def polar_cell(c, n):
    """``min(int(acos(c) / (pi/2) * n), n - 1)`` for ``c`` in ``[0, 1]`` (:func:`acos`'s, the same integer): the
    polar cell of ``n`` equal cells over the quarter turn holding the direction whose cosine is ``c``.

    Estimated with :func:`acos_estimate`; taken when that falls at least ``_CELL_MARGIN`` of a cell inside
    one, which the estimate's error cannot cross, and found with :func:`acos` otherwise (about one time in
    10^5). The tabulated and factored samplers find two or three such cells a draw or a density: a Lambertian
    draw of ``uniform_cdf``, ``compress_cdf``, ``factored`` takes 84, 50, 55 ns with it (113, 80, 74 with
    :func:`acos`), a density 41, 47, 27 ns (60, 72, 43), in isolation (the same cells, the same draws)."""
    t = acos_estimate(min(1.0, max(0.0, c))) * (n / HALF_PI)
    k = int(t)
    f = t - k
    if _CELL_MARGIN < f < 1.0 - _CELL_MARGIN and k < n:
        return k
    return min(int(acos(c) / HALF_PI * n), n - 1)


@njit(inline="always", nogil=True, cache=True)
def atan2_estimate(y, x):
    """``atan2(y, x)`` within 1.7e-6 (a degree-11 polynomial in the octant's ratio, one division): a starting
    point or a cell's estimate (:data:`AZIMUTH_MARGIN`), never an angle to keep. 0 at the origin."""
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    a = min(ax, ay) / (mx if mx > 0.0 else 1.0)
    s = a * a
    r = (
        (((-0.0117212 * s + 0.05265332) * s - 0.11643287) * s + 0.19354346) * s - 0.33262347
    ) * s + 0.99997726
    r *= a
    r = HALF_PI - r if ay > ax else r
    r = math.pi - r if x < 0.0 else r
    return -r if y < 0.0 else r


AZIMUTH_MARGIN = 1e-5
"""Radians by which :func:`atan2_estimate` must clear a cell's edges for its cell to be the exact angle's."""
