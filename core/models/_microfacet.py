"""Microfacet building blocks shared by the models: reflection about a half vector, the half vector of a
reflection pair, Beckmann's distribution (its density, an exact sampler and the density of the reflected
direction), and the anisotropic GGX distribution (its density, Smith's masking and the sampler of visible
normals).

Beckmann (P. Beckmann and A. Spizzichino, *The Scattering of Electromagnetic Waves from Rough Surfaces*, 1963):
facet slopes are Gaussian. With RMS slopes ``ax``, ``ay`` along x and y the density of facet normals per unit
projected area, for a unit ``h``, is ``D(h) = exp(-(h.x^2/ax^2 + h.y^2/ay^2) / h.z^2) / (pi ax ay h.z^4)``
(isotropic: ``exp(-tan^2(theta_h) / m^2) / (pi m^2 cos^4(theta_h))``); ``D(h) cos(theta_h)`` integrates to 1
over the hemisphere. Used by Cook-Torrance, Ward (whose lobe is the anisotropic Beckmann one, Walter 2005) and
the coupled model.

Anisotropic GGX (Trowbridge-Reitz; Walter et al. 2007, Heitz 2014): with roughnesses ``ax``, ``ay`` along x
and y, ``D(h) = 1 / (pi ax ay (h.x^2/ax^2 + h.y^2/ay^2 + h.z^2)^2)`` for unit ``h`` (no tangent, finite at
``h.z = 0``), and Smith's masking ``G1(v) = 2 v.z / (v.z + sqrt(v.z^2 + ax^2 v.x^2 + ay^2 v.y^2))``. Used by
GGX (``ax = ay``) and the Disney principled model.

All densities are per unit solid angle.
"""

from __future__ import annotations

import math

from numba import njit

from core.jit import kernel

PI = math.pi
TWO_PI = 2.0 * math.pi


@kernel
def reflect_about(wo, hx, hy, hz):
    """``wo`` reflected about the unit vector ``h``: ``2 (wo.h) h - wo``."""
    d2 = 2.0 * (wo[0] * hx + wo[1] * hy + wo[2] * hz)
    return d2 * hx - wo[0], d2 * hy - wo[1], d2 * hz - wo[2]


@njit(inline="always", nogil=True, cache=True)
def upper_half_vector(wo, wi):
    """The unit half vector ``h = +-(wi + wo) / |wi + wo|`` of a reflection pair, with the sign that gives
    ``h.z >= 0`` (the hemisphere the half-vector samplers draw from), and ``|wi + wo|``.

    For unit ``wi``, ``wo``: ``|wo.h| = |wi + wo| / 2``, so the reflection Jacobian
    ``d(omega_h) / d(omega_i) = 1 / (4 |wo.h|)`` is ``1 / (2 |wi + wo|)``. At ``wi = -wo`` the length is 0
    and ``h`` is undefined: ``(0, 0, 0, 0)`` is returned (callers give density 0 there, a set of measure zero).
    """
    sx = wi[0] + wo[0]
    sy = wi[1] + wo[1]
    sz = wi[2] + wo[2]
    norm = math.sqrt(sx * sx + sy * sy + sz * sz)
    if norm == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if sz < 0.0:
        sx, sy, sz = -sx, -sy, -sz
    return sx / norm, sy / norm, sz / norm, norm


@kernel
def beckmann_d(m, hx, hy, hz):
    """Isotropic Beckmann ``D`` at the half vector ``h``, given unnormalized (only its direction enters):
    ``exp(-tan^2(theta_h) / m^2) / (pi m^2 cos^4(theta_h))``; 0 for ``h.z <= 0`` or where it underflows."""
    if hz <= 0.0:
        return 0.0
    hz2 = hz * hz
    tan2 = (hx * hx + hy * hy) / hz2
    e = tan2 / (m * m)
    if e > 700.0:
        return 0.0
    cos2 = hz2 / (hx * hx + hy * hy + hz2)
    return math.exp(-e) / (math.pi * m * m * cos2 * cos2)


@kernel
def beckmann_sample_h(ax, ay, u1, u2):
    """A half vector (upper hemisphere) whose slopes ``(-h.x/h.z, -h.y/h.z)`` are Gaussian with variances
    ``ax^2 / 2``, ``ay^2 / 2``: density ``D(h) cos(theta_h)`` per unit solid angle of ``h`` (anisotropic
    Beckmann; also Ward's lobe, Walter 2005)."""
    r = math.sqrt(-math.log(1.0 - u1))  # 1 - u1 in (0, 1]
    phi = TWO_PI * u2
    sx = ax * r * math.cos(phi)
    sy = ay * r * math.sin(phi)
    inv = 1.0 / math.sqrt(sx * sx + sy * sy + 1.0)
    return -sx * inv, -sy * inv, inv


@kernel
def beckmann_pdf_h(hx, hy, hz, ax, ay):
    """Density of :func:`beckmann_sample_h` per unit solid angle at unit ``h`` with ``hz > 0``:
    the slope density ``exp(-(x^2/ax^2 + y^2/ay^2)) / (pi ax ay)`` times ``d(slope) / d(omega_h) =
    1 / cos^3(theta_h)``."""
    if hz <= 0.0:
        return 0.0
    e = ((hx / ax) ** 2 + (hy / ay) ** 2) / (hz * hz)
    if e > 700.0:
        return 0.0
    return math.exp(-e) / (PI * ax * ay * hz * hz * hz)


@kernel
def beckmann_reflection_pdf(wo, wi, ax, ay):
    """Density per unit solid angle of ``wi`` = ``wo`` reflected about a :func:`beckmann_sample_h` half
    vector (see :func:`upper_half_vector` for the Jacobian); 0 at ``wi = -wo`` (measure zero)."""
    hx, hy, hz, norm = upper_half_vector(wo, wi)
    if norm == 0.0:
        return 0.0
    return beckmann_pdf_h(hx, hy, hz, ax, ay) / (2.0 * norm)  # 4 |wo.h| = 2 |wi + wo|


@njit(inline="always", nogil=True, cache=True)
def ggx_anisotropic_d(hx, hy, hz, ax, ay):
    """Anisotropic GGX ``D`` at unit ``h`` (0 below the horizon)."""
    if hz <= 0.0:
        return 0.0
    t = (hx / ax) ** 2 + (hy / ay) ** 2 + hz * hz
    return 1.0 / (PI * ax * ay * t * t)


@njit(inline="always", nogil=True, cache=True)
def ggx_anisotropic_g1_over_cos(v, ax, ay):
    """``G1(v) / v.z`` for ``v.z >= 0`` in the form ``2 / (v.z + sqrt(v.z^2 + ax^2 v.x^2 + ay^2 v.y^2))``,
    finite at grazing ``v`` (``ax``, ``ay`` > 0)."""
    z = v[2]
    return 2.0 / (z + math.sqrt(z * z + (ax * v[0]) ** 2 + (ay * v[1]) ** 2))


@kernel
def ggx_visible_normal(wo, ax, ay, u1, u2):
    """E. Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018: a microfacet normal
    ``h`` with density ``D_v(h) = G1(wo) max(0, wo.h) D(h) / wo.z`` for ``wo.z >= 0``, by stretching ``wo``
    to the unit-roughness configuration, sampling the projected hemisphere there, and unstretching."""
    vx = ax * wo[0]
    vy = ay * wo[1]
    vz = wo[2]
    inv = 1.0 / math.sqrt(vx * vx + vy * vy + vz * vz)
    vx *= inv
    vy *= inv
    vz *= inv
    lensq = vx * vx + vy * vy
    if lensq > 0.0:
        il = 1.0 / math.sqrt(lensq)
        t1x, t1y, t1z = -vy * il, vx * il, 0.0
    else:
        t1x, t1y, t1z = 1.0, 0.0, 0.0
    # t2 = v x t1
    t2x = vy * t1z - vz * t1y
    t2y = vz * t1x - vx * t1z
    t2z = vx * t1y - vy * t1x
    r = math.sqrt(u1)
    phi = TWO_PI * u2
    a = r * math.cos(phi)
    b = r * math.sin(phi)
    s = 0.5 * (1.0 + vz)
    b = (1.0 - s) * math.sqrt(max(0.0, 1.0 - a * a)) + s * b
    w = math.sqrt(max(0.0, 1.0 - a * a - b * b))
    nx = a * t1x + b * t2x + w * vx
    ny = a * t1y + b * t2y + w * vy
    nz = a * t1z + b * t2z + w * vz
    hx = ax * nx
    hy = ay * ny
    hz = max(0.0, nz)
    inv = 1.0 / math.sqrt(hx * hx + hy * hy + hz * hz)
    return hx * inv, hy * inv, hz * inv


@njit(inline="always", nogil=True, cache=True)
def ggx_visible_normal_reflection_pdf(wo, wi, ax, ay):
    """Density per unit solid angle of ``wi`` = ``wo`` (``wo.z >= 0``) reflected about a
    :func:`ggx_visible_normal`: ``D_v(h) / (4 wo.h) = G1(wo) D(h) / (4 wo.z)``.

    Visible normals face ``wo``, so ``wo.h = |wi + wo| / 2 > 0`` holds for ``h = (wi + wo) / |wi + wo|``; ``D``
    is 0 below the horizon, so pairs with ``(wi + wo).z <= 0`` have density 0 (no flip to the upper side).
    """
    if wi[2] + wo[2] <= 0.0:
        return 0.0
    hx, hy, hz, _ = upper_half_vector(wo, wi)
    return 0.25 * ggx_anisotropic_g1_over_cos(wo, ax, ay) * ggx_anisotropic_d(hx, hy, hz, ax, ay)
