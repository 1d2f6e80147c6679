"""Specular albedo tables of the Kelemen & Szirmay-Kalos coupled model (see :mod:`core.models.coupled`).

The specular term is ``f_s(L, V) = P(H) F(V.H) / |L + V|^2`` with the Beckmann density ``P`` (normalized so
that ``int P(H) (N.H) d omega_H = 1``) and Schlick's Fresnel ``F = R0 + (1 - R0) (1 - V.H)^5``. Its albedo is
linear in ``R0``: ``a(theta) = R0 A(theta) + B(theta)`` with

    A = int f_s[F = 1 - (1 - V.H)^5] cos(theta_L) d omega_L,   B = int f_s[F = (1 - V.H)^5] cos(theta_L) d omega_L,

so one pair of tables per roughness ``m`` serves every colour.

Quadrature. Changing variables to the halfway vector (``d omega_L = 4 (V.H) d omega_H``, ``|L + V| = 2 V.H``)
and then to ``u = exp(-tan^2(theta_H) / m^2)`` (so that ``P(H) (N.H) d omega_H = du dphi / (2 pi)``):

    a(V) = 1/(2 pi) int_0^1 du int dphi  F(V.H) (N.L) / ((V.H) (N.H)),   over the H with N.L > 0,

and we integrate over ``x = -ln u = tan^2(theta_H) / m^2`` (density ``exp(-x)``, smooth at both ends).

With ``V`` in the xz-plane at polar angle ``theta_v``, ``N.L > 0`` holds for every azimuth when
``theta_H < (pi/2 - theta_v)/2``, for ``|phi| < phi_max(theta_H)`` up to ``theta_H = (pi/2 + theta_v)/2`` and
never beyond. On the first part the azimuth integral runs over the whole circle (midpoint rule, spectrally
accurate for a periodic integrand; it also makes the result a smooth function of ``x``), with Gauss-Legendre
in ``x``. On the second part tanh-sinh quadrature runs over ``[0, phi_max]`` (it resolves the thin layer near
``phi_max`` that appears for grazing ``V``) and Gauss-Legendre over ``x`` after a cosine map that absorbs the
square-root behaviour of ``phi_max`` at both ends. Measured against scipy's adaptive quadrature: below 1e-6
everywhere, below 1e-9 away from the last degree before grazing; the Catmull-Rom interpolation of the
``N_TABLE`` graded nodes adds about 1e-7. The tests repeat the comparison.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

N_TABLE = 256
"""Table nodes (without the two ghosts), graded towards grazing (see :func:`table_map`)."""
MU0 = 1e-4
_N_U, _N_PHI, _N_U2 = 64, 48, 64
_X_CUT = 42.0
_GL_U = np.polynomial.legendre.leggauss(_N_U)
_GL_U2 = np.polynomial.legendre.leggauss(_N_U2)


def _tanh_sinh(step: float = 1.0 / 12.0, reach: float = 3.2) -> tuple[np.ndarray, np.ndarray]:
    """Tanh-sinh nodes and weights on [-1, 1]: they crowd doubly-exponentially at both ends, which resolves
    the thin layer (width ~ cos(theta_v)) near ``phi_max`` where ``N.L / (V.H)`` varies fast."""
    t = np.arange(-reach, reach + 0.5 * step, step)
    u = 0.5 * np.pi * np.sinh(t)
    x = np.tanh(u)
    w = step * 0.5 * np.pi * np.cosh(t) / np.cosh(u) ** 2
    return x, w


_GL_PHI2 = _tanh_sinh()


def _weights(cos_vh, cos_l, cos_h):
    """Return ``(A, B)`` integrand values: ``F (N.L) / ((V.H)(N.H))`` for the two Fresnel parts."""
    s5 = (1.0 - cos_vh) ** 5
    base = np.where(cos_l > 0.0, cos_l / (cos_vh * cos_h), 0.0)
    return base * (1.0 - s5), base * s5


def _integrand_sums(theta_v, m, x, wx, phi, wphi):
    """Sum of weights over the tensor grid ``x x phi`` (broadcast shapes ``(nx, 1)`` and ``(nx, nphi)``)."""
    sv, cv = np.sin(theta_v), np.cos(theta_v)
    tan2 = (m * m) * x
    cos_h = 1.0 / np.sqrt(1.0 + tan2)
    sin_h = np.sqrt(np.maximum(0.0, 1.0 - cos_h * cos_h))
    cos_vh = sv * sin_h * np.cos(phi) + cv * cos_h
    cos_l = 2.0 * cos_vh * cos_h - cv
    cos_vh = np.maximum(cos_vh, 1e-300)
    a, b = _weights(cos_vh, cos_l, cos_h)
    w = wx * wphi
    return float(np.sum(a * w)), float(np.sum(b * w))


def _albedo_at(theta_v: float, m: float) -> tuple[float, float]:
    """``(A, B)`` at one viewing angle (see the module docstring for the two parts)."""
    xg, wg = _GL_U
    xg2, wg2 = _GL_U2
    xp2, wp2 = _GL_PHI2  # tanh-sinh
    th1 = 0.5 * (np.pi / 2 - theta_v)
    th2 = 0.5 * (np.pi / 2 + theta_v)
    # x = tan^2(theta_H) / m^2 = -ln u; the density of x is exp(-x), negligible beyond X_CUT.
    x1 = min(np.tan(th1) ** 2 / (m * m), _X_CUT)
    x2 = _X_CUT if th2 >= np.pi / 2 - 1e-12 else min(np.tan(th2) ** 2 / (m * m), x1 + _X_CUT)
    total_a = total_b = 0.0
    # Part 1: x in [0, x1], whole circle of azimuths (midpoint rule on [0, pi] by symmetry).
    if x1 > 0.0:
        x = (0.5 * x1 * (xg + 1.0))[:, None]
        wx = (0.5 * x1 * wg * np.exp(-x[:, 0]))[:, None]
        phi = (np.arange(_N_PHI) + 0.5) * (np.pi / _N_PHI)
        wphi = np.full(_N_PHI, 2.0 * np.pi / _N_PHI)
        a, b = _integrand_sums(theta_v, m, x, wx, phi[None, :], wphi[None, :])
        total_a += a
        total_b += b
    # Part 2: x in [x1, x2], azimuths |phi| < phi_max(x); cosine map in x for the end behaviour.
    if x2 > x1 and theta_v > 0.0:
        t = 0.5 * (xg2 + 1.0)
        x = x1 + (x2 - x1) * 0.5 * (1.0 - np.cos(np.pi * t))
        dx = (x2 - x1) * 0.5 * np.pi * np.sin(np.pi * t) * 0.5 * wg2 * np.exp(-x)
        th = np.arctan(m * np.sqrt(x))
        c_star = -np.cos(theta_v) * np.cos(2 * th) / (np.sin(theta_v) * np.sin(2 * th))
        phi_max = np.arccos(np.clip(c_star, -1.0, 1.0))
        phi = (0.5 * (xp2 + 1.0))[None, :] * phi_max[:, None]
        wphi = 2.0 * (0.5 * wp2)[None, :] * phi_max[:, None]  # x2: both signs of phi
        a, b = _integrand_sums(theta_v, m, x[:, None], dx[:, None], phi, wphi)
        total_a += a
        total_b += b
    return total_a / (2.0 * np.pi), total_b / (2.0 * np.pi)


def table_map() -> tuple[float, float]:
    """``(mu0, K)`` of the node map ``cos(theta(s)) = mu0 (exp(K s) - 1)``, ``s`` in ``[0, 1]``, ``mu(1) = 1``.

    Near grazing (``mu = cos(theta) -> 0``) the albedo behaves like ``1 - C mu ln(1/mu)`` and, for smooth
    surfaces, changes over ``mu ~ m``; nodes graded geometrically in ``mu`` (3.6 % apart) down to
    ``mu0 = 1e-4`` resolve both. Near normal incidence ``a`` is a smooth function of ``mu``.
    """
    return MU0, float(np.log1p(1.0 / MU0))


def table_thetas() -> np.ndarray:
    """Node angles at ``s = j / (N_TABLE - 1)`` for ``j = -1 .. N_TABLE`` (one ghost node at each end).

    The ghost below ``mu = 0`` mirrors ``mu`` (it is only a Catmull-Rom end condition); the ghost beyond
    ``mu = 1`` is not evaluated (the table stores a linear extrapolation there).
    """
    mu0, k = table_map()
    s = np.arange(-1, N_TABLE + 1) / (N_TABLE - 1)
    mu = np.abs(mu0 * np.expm1(k * s))
    return np.arccos(np.minimum(mu, 1.0))


@lru_cache(maxsize=64)
def albedo_tables(m: float) -> tuple[np.ndarray, np.ndarray]:
    """Tables ``A, B`` of shape ``(N_TABLE + 2,)`` at :func:`table_thetas` (ghost nodes included)."""
    thetas = table_thetas()
    table_a = np.empty(len(thetas))
    table_b = np.empty(len(thetas))
    for j, theta_v in enumerate(thetas[:-1]):
        table_a[j], table_b[j] = _albedo_at(float(theta_v), m)
    table_a[-1] = 2.0 * table_a[-2] - table_a[-3]
    table_b[-1] = 2.0 * table_b[-2] - table_b[-3]
    table_a.setflags(write=False)
    table_b.setflags(write=False)
    return table_a, table_b


def catmull_rom(table: np.ndarray, j: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Catmull-Rom interpolation on interval ``j`` (nodes ``j, j+1`` of the un-ghosted table) at fraction
    ``t``: the same rule as the kernel's. ``table`` includes the ghost nodes (offset 1)."""
    p0, p1, p2, p3 = table[j], table[j + 1], table[j + 2], table[j + 3]
    t2 = t * t
    t3 = t2 * t
    return 0.5 * (
        2.0 * p1
        + (p2 - p0) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t3
    )


def interpolate(table: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """The kernel's interpolation of ``table`` at ``mu = cos(theta)`` (numpy version, for tests)."""
    mu0, k = table_map()
    s = np.log1p(np.asarray(mu) / mu0) / k
    x = np.clip(s, 0.0, 1.0) * (N_TABLE - 1)
    j = np.minimum(np.floor(x).astype(int), N_TABLE - 2)
    return catmull_rom(table, j, x - j)


def hemispherical_average(table: np.ndarray) -> float:
    """``2 int_0^1 a(mu) mu dmu`` of the interpolant (Gauss-Legendre per node interval in ``s``, where the
    interpolant is a cubic and the map is smooth: exact to rounding)."""
    mu0, k = table_map()
    x, w = np.polynomial.legendre.leggauss(12)
    t = 0.5 * (x + 1.0)
    j = np.arange(N_TABLE - 1)[:, None]
    s = (j + t[None, :]) / (N_TABLE - 1)
    mu = mu0 * np.expm1(k * s)
    dmu_ds = mu0 * k * np.exp(k * s)
    vals = catmull_rom(table, np.broadcast_to(j, s.shape), np.broadcast_to(t[None, :], s.shape))
    return float(np.sum(2.0 * vals * mu * dmu_ds * (0.5 * w)[None, :]) / (N_TABLE - 1))
