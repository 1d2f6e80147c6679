"""Sampling building blocks shared by the analytic samplers: cosine hemisphere, cosine-power lobes, and the
mixture of a lobe (cosine-power, half-vector cosine-power or Beckmann) with the cosine hemisphere, and the
lobe's probability in it from luminance-weighted albedos.

All densities are per unit solid angle. Lobes about an arbitrary axis may put mass below the horizon;
the density returned is the lobe's own, so ``sample`` and ``pdf`` always agree. Microfacet (half-vector
and Beckmann) helpers are in ``core.models._microfacet``.
"""

from __future__ import annotations

import math

from numba import njit

from core.geometry import basis, dot, from_frame
from core.models._microfacet import (
    beckmann_reflection_pdf,
    beckmann_sample_h,
    reflect_about,
    upper_half_vector,
)

TWO_PI = 6.283185307179586
INV_PI = 0.3183098861837907
LUMA = (0.2126, 0.7152, 0.0722)
"""Rec. 709 luminance weights of linear RGB."""


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
def cosine_power(axis, w, n):
    """``cos^n`` of the angle between unit ``axis`` and ``w``, 0 beyond a right angle (the cosine clamped at 1
    against rounding): the value of a Phong-type lobe."""
    c = dot(axis, w)
    return min(c, 1.0) ** n if c > 0.0 else 0.0


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
    return reflect_about(wo, h[0], h[1], h[2])


@njit(inline="always", nogil=True, cache=True)
def half_vector_lobe_pdf(wo, wi, n):
    """Density per unit solid angle of :func:`half_vector_lobe` at ``wi``: the half-vector density at the
    upper half vector of ``(wo, wi)`` times the reflection Jacobian ``1 / (2 |wi + wo|)``
    (:func:`core.models._microfacet.upper_half_vector`); finite for every ``wi`` except ``wi = -wo``
    (measure zero), where 0 is returned.
    """
    _, _, cos_h, norm = upper_half_vector(wo, wi)
    if cos_h <= 0.0:  # also at wi = -wo, where norm = 0
        return 0.0
    return (n + 1.0) / TWO_PI * cos_h**n / (2.0 * norm)


@njit(inline="always", nogil=True, cache=True)
def luminance3(r, g, b):
    """Rec. 709 luminance of a linear RGB colour."""
    return LUMA[0] * r + LUMA[1] * g + LUMA[2] * b


@njit(inline="always", nogil=True, cache=True)
def luminance_at(p, i):
    """Luminance of the RGB colour stored at ``p[i:i+3]`` (mixture weights of colour lobes)."""
    return luminance3(p[i], p[i + 1], p[i + 2])


@njit(inline="always", nogil=True, cache=True)
def lobe_probability(w_lobe, w_diffuse):
    """Probability of the lobe in a lobe + cosine-hemisphere mixture: its share ``w_lobe / (w_lobe +
    w_diffuse)`` of two non-negative (estimated) albedos, unclamped; 0.5 when both are 0."""
    total = w_lobe + w_diffuse
    if total <= 0.0:
        return 0.5
    return w_lobe / total


@njit(inline="always", nogil=True, cache=True)
def luminance_lobe_probability(p, ks, kd):
    """:func:`lobe_probability` of the luminances of the colours at ``p[ks:ks+3]`` (the lobe's) and
    ``p[kd:kd+3]`` (the diffuse albedo)."""
    return lobe_probability(luminance_at(p, ks), luminance_at(p, kd))


@njit(inline="always", nogil=True, cache=True)
def lobe_probability_clamped(w_lobe, w_diffuse):
    """:func:`lobe_probability` clamped to [0.1, 0.9] when both components carry energy, so neither is ever
    starved when the albedos are rough estimates (the variance of ``f cos / pdf`` stays within 10x of either
    component's own); 1 or 0 when only one does (1 when neither does)."""
    if w_diffuse <= 0.0:
        return 1.0
    if w_lobe <= 0.0:
        return 0.0
    return min(0.9, max(0.1, lobe_probability(w_lobe, w_diffuse)))


@njit(inline="always", nogil=True, cache=True)
def diffuse_plus_lobe(p, kd, ks, lobe):
    """The RGB value ``kd / pi + ks * lobe`` of a Lambertian term plus a scalar lobe ``lobe`` weighted by a
    colour: ``kd`` and ``ks`` are the offsets of the two colours in the kernel row ``p``."""
    return (
        p[kd] * INV_PI + p[ks] * lobe,
        p[kd + 1] * INV_PI + p[ks + 1] * lobe,
        p[kd + 2] * INV_PI + p[ks + 2] * lobe,
    )


@njit(inline="always", nogil=True, cache=True)
def mixture_pdf(q, lobe_pdf, cos_theta_i):
    """Density of the mixture: the lobe (density ``lobe_pdf`` at ``wi``) with probability ``q``, the cosine
    hemisphere otherwise."""
    return q * lobe_pdf + (1.0 - q) * cosine_hemisphere_pdf(cos_theta_i)


# The three mixtures below share their shape but not their lobe: numba inlines each with its own lobe, where a
# lobe passed as an argument would be a call through a function pointer in every sample.
@njit(inline="always", nogil=True, cache=True)
def cosine_lobe_mixture_sample(axis, n, q, u1, u2, u3):
    """With probability ``q`` (``u3 < q``) a direction of :func:`cosine_power_lobe` about ``axis``, otherwise
    of the cosine hemisphere, and the mixture's density there (see :func:`cosine_lobe_mixture_pdf`)."""
    if u3 < q:
        w = cosine_power_lobe(axis, n, u1, u2)
    else:
        w = cosine_hemisphere(u1, u2)
    return w[0], w[1], w[2], cosine_lobe_mixture_pdf(axis, n, q, w)


@njit(inline="always", nogil=True, cache=True)
def cosine_lobe_mixture_pdf(axis, n, q, wi):
    return mixture_pdf(q, cosine_power_lobe_pdf(axis, n, wi), wi[2])


@njit(inline="always", nogil=True, cache=True)
def half_vector_mixture_sample(wo, n, q, u1, u2, u3):
    """With probability ``q`` a direction of :func:`half_vector_lobe`, otherwise of the cosine hemisphere, and
    the mixture's density there (see :func:`half_vector_mixture_pdf`)."""
    if u3 < q:
        w = half_vector_lobe(wo, n, u1, u2)
    else:
        w = cosine_hemisphere(u1, u2)
    return w[0], w[1], w[2], half_vector_mixture_pdf(wo, n, q, w)


@njit(inline="always", nogil=True, cache=True)
def half_vector_mixture_pdf(wo, n, q, wi):
    return mixture_pdf(q, half_vector_lobe_pdf(wo, wi, n), wi[2])


@njit(inline="always", nogil=True, cache=True)
def beckmann_mixture_sample(wo, ax, ay, q, u1, u2, u3):
    """With probability ``q`` ``wo`` reflected about a Beckmann half vector
    (:func:`core.models._microfacet.beckmann_sample_h`), otherwise a direction of the cosine hemisphere, and
    the mixture's density there (see :func:`beckmann_mixture_pdf`)."""
    if u3 < q:
        hx, hy, hz = beckmann_sample_h(ax, ay, u1, u2)
        wi = reflect_about(wo, hx, hy, hz)
    else:
        wi = cosine_hemisphere(u1, u2)
    return wi[0], wi[1], wi[2], beckmann_mixture_pdf(wo, wi, ax, ay, q)


@njit(inline="always", nogil=True, cache=True)
def beckmann_mixture_pdf(wo, wi, ax, ay, q):
    lobe = beckmann_reflection_pdf(wo, wi, ax, ay) if q > 0.0 else 0.0
    return mixture_pdf(q, lobe, wi[2])
