"""Poulin-Fournier anisotropic reflection from parallel cylinders (P. Poulin and A. Fournier, "A model for
anisotropic reflection", SIGGRAPH 1990, 273-282).

Microgeometry. The surface is a plane covered with identical parallel cylinders of unit radius whose axes run
along the tangent ``x`` (the brushing direction). In the cross-section (the ``yz``-plane) each cylinder shows a
circular cap that rises ``h`` radii above the base plane (``0 < h <= 1``; ``h = 1`` is a half cylinder), so a
cap spans the normal angles ``|beta| <= beta_m = acos(1 - h)`` and the half-width ``w = sqrt(h (2 - h))``; the
axes of neighbouring cylinders are ``d`` radii apart (``d >= 2``: they may touch), with flat base plane between
the caps. Every surface element reflects with the same local BRDF, Phong's model made a reciprocal BRDF by
Lewis' normalization:

    f_loc = kd / pi + ks (n + 2) / (2 pi) max(0, cos alpha)^n,   cos alpha = 2 (N.wi)(N.wo) - wi.wo,

``N`` the local normal (``(0, sin beta, cos beta)`` on a cap, ``z`` on the flat part); with ``kd + ks <= 1``
each element conserves energy.

Self-shadowing and masking, as in the paper: light reaching a cap or the flat part may be blocked by the
neighbouring cylinder, and so may the reflected light on its way to the viewer. Everything is x-invariant, so
visibility depends only on the direction projected onto the cross-section, ``A (sin gamma, cos gamma)`` with
``A = |(w_y, w_z)|``. For ``gamma > 0`` the blocker is the next cylinder: its silhouette is its tangent point
(normal angle ``gamma - pi/2``) when that lies on the cap (``gamma >= pi/2 - beta_m``) and otherwise the edge
of the cap on the base plane. A point of a cap at normal angle ``beta`` is lit (seen) when it faces the
direction, ``|beta - gamma| < pi/2``, and lies above the silhouette line:
``sin(beta - gamma) <= delta(gamma)`` with the signed distance of the cap's centre from that line

    delta = d cos(gamma) - 1                              (tangent-point silhouette),
    delta = (d - w) cos(gamma) - (1 - h) sin(gamma)        (edge silhouette),

and a point of the flat part at ``y`` (from the axis of the cylinder on its left) when
``y <= y* = d - 1/cos(gamma) + (1 - h) tan(gamma)`` (tangent case; no shadow in the edge case). ``gamma < 0``
mirrors this. Each direction so gives one interval of the cap and one of the flat part; the element is lit
and seen on the intersection of the two directions' intervals.

The BRDF is the radiance of one period of width ``d`` divided by the irradiance on it (single scattering;
interreflections between cylinders are ignored, as in the paper):

    f(wi, wo) = 1 / (d cos_i cos_o) [ int_cap f_loc (N.wi)(N.wo) d beta + L_flat f_loc(z) cos_i cos_o ].

The diffuse part of the cap integral is in closed form (a product of two cosines). The paper approximates the
specular integrand by a Chebyshev polynomial; we integrate it with 24-point Gauss-Legendre over the part of
the visible interval where ``cos alpha > 0`` and within 7 widths of the lobe's peak at
``beta = (gamma_i + gamma_o)/2`` (``cos alpha = A_i A_o cos(2 (beta - beta*)) - w_ix w_ox`` there, a Gaussian of
width ``sqrt(cos alpha_max / (4 n A_i A_o))`` for large ``n``; the neglected tails are below ``e^-24``, the
quadrature error of a Gaussian on that window is 3e-9).

Grooves ("subtracted" cylinders, ``grooves = true``): the same circles cut ``h`` deep into the plane. The
plane is then never shadowed; a groove point at normal angle ``beta`` is seen from ``gamma`` when it faces it
and the ray leaves the groove before meeting its far wall, which reduces to
``|beta - 2 gamma| <= pi - beta_m``. The integrals are the same.

Traits: reciprocal (the expression is symmetric in ``wi`` and ``wo``), not isotropic (the cylinders have a
direction). Energy is conserved when ``kd + ks <= 1`` (the seed's 0.2 + 0.8), but the bounds allow more, so
the trait is not claimed. Limits: ``h -> 0`` or ``d -> infinity`` give the flat surface's Phong + Lambert.

Seed parameters: ``POULIN d = 2, h = 0.01, n = 100, ks = 0.8, kd = 0.2``.
"""

from __future__ import annotations

import math

import numpy as np

from core.brdf import Param, Traits, declare, param_offsets, param_row_size
from core.jit import kernel

CITATION = (
    "P. Poulin and A. Fournier, A model for anisotropic reflection, Proc. SIGGRAPH 1990, "
    "Computer Graphics 24(4), 273-282."
)

INV_PI = 0.3183098861837907
INV_TWO_PI = 0.15915494309189535
HALF_PI = 1.5707963267948966
PEAK_WIDTHS = 7.0
_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)
GL_X = np.ascontiguousarray(_GL_X)
GL_W = np.ascontiguousarray(_GL_W)


PARAMS = (
    Param(
        "d",
        2.0,
        2.0,
        100.0,
        unit="radii",
        label="Cylinder spacing",
        log=True,
        doc="Distance between the axes of neighbouring cylinders, in cylinder radii (2: touching).",
    ),
    Param(
        "h",
        0.01,
        1e-4,
        1.0,
        unit="radii",
        label="Cylinder height",
        log=True,
        doc="Height the cylinders rise above the base plane, in radii (1: half cylinders).",
    ),
    Param(
        "n",
        100.0,
        1.0,
        1e4,
        label="Phong exponent",
        log=True,
        doc="Phong exponent of the local reflection on the cylinders and the base plane.",
    ),
    Param(
        "ks",
        (0.8, 0.8, 0.8),
        0.0,
        1.0,
        label="Specular reflectance",
        kind="color",
        doc="Specular (normalized Phong) reflectance of the surface elements.",
    ),
    Param(
        "kd",
        (0.2, 0.2, 0.2),
        0.0,
        1.0,
        label="Diffuse reflectance",
        kind="color",
        doc="Lambertian reflectance of the surface elements.",
    ),
    Param(
        "grooves",
        0.0,
        label="Grooves (subtracted cylinders)",
        kind="bool",
        doc="Cut the cylinders into the plane (grooves of depth h) instead of raising them.",
    ),
)
_D, _H, _N, _KS, _KD, _GROOVES = param_offsets(PARAMS, "d", "h", "n", "ks", "kd", "grooves")
# derive_poulin_fournier appends the cap half-width w and half-angle beta_m to the parameters
_W = param_row_size(PARAMS)
_BETA_M = _W + 1


def derive_poulin_fournier(p: np.ndarray) -> np.ndarray:
    """Append the cap half-width ``w = sqrt(h (2 - h))`` and half-angle ``beta_m = acos(1 - h)``."""
    h = p[_H]
    return np.concatenate([p, [math.sqrt(h * (2.0 - h)), math.acos(1.0 - h)]])


@kernel
def _visible_cap(gamma, d, h, w, beta_m):
    """Interval ``[lo, hi]`` of cap normal angles facing the direction and not blocked by the neighbour."""
    g = abs(gamma)
    if g >= HALF_PI - beta_m:
        delta = d * math.cos(g) - 1.0
    else:
        delta = (d - w) * math.cos(g) - (1.0 - h) * math.sin(g)
    reach = HALF_PI if delta >= 1.0 else math.asin(max(delta, -1.0))
    if gamma >= 0.0:
        return max(-beta_m, gamma - HALF_PI), min(beta_m, gamma + reach)
    return max(-beta_m, gamma - reach), min(beta_m, gamma + HALF_PI)


@kernel
def _visible_groove(gamma, beta_m):
    """Interval of groove normal angles facing the direction and not blocked by the groove's own wall.

    A groove point at normal angle ``beta`` sits at ``C - N`` on the circle of centre ``C = (0, 1 - h)``; a ray
    leaving it along ``p`` meets the circle again after ``t = 2 N.p`` and escapes when that point is above the
    base plane: ``(1 - h) - cos(beta) + 2 cos(beta - gamma) cos(gamma) >= 0``, i.e.
    ``cos(beta - 2 gamma) >= -(1 - h) = cos(pi - beta_m)``.
    """
    reach = math.pi - beta_m
    lo = max(-beta_m, max(gamma - HALF_PI, 2.0 * gamma - reach))
    hi = min(beta_m, min(gamma + HALF_PI, 2.0 * gamma + reach))
    return lo, hi


@kernel
def _visible_flat(gamma, d, h, w, beta_m):
    """Interval ``[lo, hi]`` of the flat part (``y`` from the left cylinder's axis) seen from the direction."""
    g = abs(gamma)
    y_star = d - w
    if g >= HALF_PI - beta_m:
        c = math.cos(g)
        y_star = d - 1.0 / c + (1.0 - h) * math.sin(g) / c if c > 0.0 else -math.inf
    if gamma >= 0.0:
        return w, min(d - w, y_star)
    return max(w, d - y_star), d - w


@kernel
def _phong(cos_alpha, n):
    if cos_alpha <= 0.0:
        return 0.0
    return cos_alpha**n


@kernel
def eval_poulin_fournier(wi, wo, p):
    ci = wi[2]
    co = wo[2]
    if ci <= 0.0 or co <= 0.0:
        return 0.0, 0.0, 0.0
    d = p[_D]
    h = p[_H]
    n = p[_N]
    w = p[_W]
    beta_m = p[_BETA_M]
    a_i = math.sqrt(wi[1] * wi[1] + ci * ci)
    a_o = math.sqrt(wo[1] * wo[1] + co * co)
    g_i = math.atan2(wi[1], ci)
    g_o = math.atan2(wo[1], co)
    dot_io = wi[0] * wo[0] + wi[1] * wo[1] + ci * co
    spec_norm = (n + 2.0) * INV_TWO_PI

    grooves = p[_GROOVES] != 0.0
    # Flat part: the intersection of the two visible intervals (grooves never shadow the plane).
    if grooves:
        flat_len = d - 2.0 * w
    else:
        lo_i, hi_i = _visible_flat(g_i, d, h, w, beta_m)
        lo_o, hi_o = _visible_flat(g_o, d, h, w, beta_m)
        flat_len = max(0.0, min(hi_i, hi_o) - max(lo_i, lo_o))
    flat_diffuse = flat_len
    flat_spec = flat_len * _phong(2.0 * ci * co - dot_io, n) if flat_len > 0.0 else 0.0

    # Caps (or grooves): lit and seen normal angles.
    if grooves:
        lo_i, hi_i = _visible_groove(g_i, beta_m)
        lo_o, hi_o = _visible_groove(g_o, beta_m)
    else:
        lo_i, hi_i = _visible_cap(g_i, d, h, w, beta_m)
        lo_o, hi_o = _visible_cap(g_o, d, h, w, beta_m)
    b1 = max(lo_i, lo_o)
    b2 = min(hi_i, hi_o)
    cap_diffuse = 0.0
    cap_spec = 0.0
    if b2 > b1:
        ab = a_i * a_o
        gsum = g_i + g_o
        gdiff = g_i - g_o
        # int cos(b - g_i) cos(b - g_o) db = [(b2 - b1) cos(g_i - g_o) + (sin(2 b2 - gsum) - sin(2 b1 - gsum))/2]/2
        cap_diffuse = (
            0.5
            * ab
            * ((b2 - b1) * math.cos(gdiff) + 0.5 * (math.sin(2.0 * b2 - gsum) - math.sin(2.0 * b1 - gsum)))
        )
        # Phong lobe on the cap: cos(alpha) = ab cos(2 (b - b*)) - e, b* = gsum / 2
        e = wi[0] * wo[0]
        c_max = ab - e
        if c_max > 0.0 and ab > 0.0:
            ratio = e / ab
            half = HALF_PI if ratio <= -1.0 else 0.5 * math.acos(min(ratio, 1.0))
            width = PEAK_WIDTHS * math.sqrt(c_max / (4.0 * n * ab))
            half = min(half, width)
            centre = 0.5 * gsum
            s1 = max(b1, centre - half)
            s2 = min(b2, centre + half)
            if s2 > s1:
                mid = 0.5 * (s1 + s2)
                rad = 0.5 * (s2 - s1)
                half_ab = 0.5 * ab
                base = half_ab * math.cos(gdiff)
                acc = 0.0
                for k in range(GL_X.shape[0]):
                    b = mid + rad * GL_X[k]
                    proj = base + half_ab * math.cos(2.0 * b - gsum)  # (N.wi)(N.wo)
                    acc += GL_W[k] * proj * _phong(2.0 * proj - dot_io, n)
                cap_spec = rad * acc

    inv = 1.0 / (d * ci * co)
    diffuse = (cap_diffuse + flat_diffuse * ci * co) * inv * INV_PI
    spec = (cap_spec + flat_spec * ci * co) * inv * spec_norm
    return (
        p[_KD] * diffuse + p[_KS] * spec,
        p[_KD + 1] * diffuse + p[_KS + 1] * spec,
        p[_KD + 2] * diffuse + p[_KS + 2] * spec,
    )


NOTES = (
    "Cylinders along the tangent x; cap self-shadowing and masking by the neighbouring cylinder; "
    "diffuse part in closed form, Phong part by 24-point Gauss-Legendre over the lit-and-seen interval. "
    "Local BRDF: Lambert + Lewis-normalized Phong. Raised cylinders or grooves. Energy is "
    "conserved for kd + ks <= 1 (not guaranteed by the bounds)."
)


POULIN_FOURNIER = declare(globals(), "Poulin-Fournier (1990)", Traits.RECIPROCAL | Traits.MIRROR_SYMMETRIC)
