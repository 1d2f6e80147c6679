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


@njit(inline="always", nogil=True, cache=True)
def half_vector_lobe(wo, n, u1, u2):
    """Reflect ``wo`` about a half vector drawn from ``(n+1)/(2 pi) cos^n(theta_h)`` about the normal.

    The direction may fall below the horizon (when the half vector leans away from ``wo``); see
    :func:`half_vector_lobe_pdf` for its density.
    """
    h = cosine_power_lobe((0.0, 0.0, 1.0), n, u1, u2)
    d2 = 2.0 * dot(wo, h)
    return d2 * h[0] - wo[0], d2 * h[1] - wo[1], d2 * h[2] - wo[2]


@njit(inline="always", nogil=True, cache=True)
def half_vector_lobe_pdf(wo, wi, n):
    """Density per unit solid angle of :func:`half_vector_lobe` at ``wi``.

    The half vector of ``wi`` is ``+-(wi + wo)/|wi + wo|``, taking the sign with ``h.z >= 0`` (the sampled
    hemisphere); the reflection's Jacobian is ``d(omega_h)/d(omega_i) = 1 / (4 |wo.h|)``. Since
    ``|wo.h| = |wi + wo| / 2``, the density is finite for every ``wi`` except ``wi = -wo`` (measure zero),
    where 0 is returned.
    """
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    norm = math.sqrt(hx * hx + hy * hy + hz * hz)
    if norm == 0.0:
        return 0.0
    cos_h = abs(hz) / norm
    if cos_h <= 0.0:
        return 0.0
    return (n + 1.0) / TWO_PI * cos_h**n / (2.0 * norm)


@njit(inline="always", nogil=True, cache=True)
def mixture_probability(w_lobe, w_diffuse):
    """Probability of picking the lobe in a lobe + cosine-hemisphere mixture, from the two (estimated)
    albedos. Clamped to [0.1, 0.9] when both components carry energy, so neither is ever starved (the
    variance of ``f cos / pdf`` stays within 10x of either component's own); 1 or 0 when only one does."""
    if w_diffuse <= 0.0:
        return 1.0
    if w_lobe <= 0.0:
        return 0.0
    q = w_lobe / (w_lobe + w_diffuse)
    return min(0.9, max(0.1, q))


@njit(inline="always", nogil=True, cache=True)
def luminance_at(p, i):
    """Rec. 709 luminance of the RGB colour stored at ``p[i:i+3]`` (mixture weights of colour lobes)."""
    return 0.2126 * p[i] + 0.7152 * p[i + 1] + 0.0722 * p[i + 2]
