"""Sampling building blocks shared by the analytic samplers: cosine hemisphere, cosine-power lobes.

All densities are per unit solid angle. Lobes about an arbitrary axis may put mass below the horizon;
the density returned is the lobe's own, so ``sample`` and ``pdf`` always agree.
"""

from __future__ import annotations

import math

from numba import njit

from core.geometry import basis, dot, from_frame

TWO_PI = 6.283185307179586
INV_PI = 0.3183098861837907


@njit(inline="always", nogil=True, cache=True)
def cosine_hemisphere(u1, u2):
    """Cosine-weighted direction on the upper hemisphere (Malley: uniform disk point, lifted)."""
    r = math.sqrt(u1)
    phi = TWO_PI * u2
    x = r * math.cos(phi)
    y = r * math.sin(phi)
    return x, y, math.sqrt(max(0.0, 1.0 - u1))


@njit(inline="always", nogil=True, cache=True)
def cosine_hemisphere_pdf(cos_theta):
    return cos_theta * INV_PI if cos_theta > 0.0 else 0.0


@njit(inline="always", nogil=True, cache=True)
def uniform_hemisphere(u1, u2):
    z = u1
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = TWO_PI * u2
    return r * math.cos(phi), r * math.sin(phi), z


@njit(inline="always", nogil=True, cache=True)
def cosine_power_lobe(axis, n, u1, u2):
    """Direction about unit ``axis`` with density ``(n+1)/(2 pi) cos^n(alpha)`` over the sphere's cap
    ``alpha < pi/2`` around the axis."""
    cos_a = u1 ** (1.0 / (n + 1.0))
    sin_a = math.sqrt(max(0.0, 1.0 - cos_a * cos_a))
    phi = TWO_PI * u2
    t, b = basis(axis)
    return from_frame((sin_a * math.cos(phi), sin_a * math.sin(phi), cos_a), t, b, axis)


@njit(inline="always", nogil=True, cache=True)
def cosine_power_lobe_pdf(axis, n, w):
    c = dot(axis, w)
    if c <= 0.0:
        return 0.0
    return (n + 1.0) / TWO_PI * c**n
