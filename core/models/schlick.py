"""Schlick's inexpensive BRDF model (C. Schlick, "An inexpensive BRDF model for physically-based rendering",
Computer Graphics Forum 13(3):233-246, Eurographics 1994), single and double layer.

A layer is described by three numbers: its reflection factor at normal incidence ``C`` (RGB), its roughness
``r`` (0 = perfect mirror, 1 = perfect Lambertian) and its isotropy ``p`` (1 = isotropic, toward 0 = strongly
anisotropic). Schlick separates the spectral factor from the directional one, ``R = S(u) D(t, v, v', w)``:

    S(u) = C + (1 - C)(1 - u)^5                                  (his Fresnel approximation)
    D    = a / pi + b / (4 pi v v') B(t, v, v', w) + c * (mirror impulse)
    b = 4 r (1 - r),   a = 0 and c = 1 - b if r < 1/2,   a = 1 - b and c = 0 otherwise
    B    = G(v) G(v') Z(t) A(w) + 1 - G(v) G(v')
    Z(t) = r / (1 + r t^2 - t^2)^2,   A(w) = sqrt(p / (p^2 - p^2 w^2 + w^2)),   G(v) = v / (r - r v + v)

with ``h`` the half vector, ``t = h.n``, ``u = h.wi = h.wo``, ``v = wo.n``, ``v' = wi.n`` and ``w`` the cosine of
the azimuth of ``h`` measured from the tangent ``x`` (the scratch direction). ``Z / pi`` is a normalized
facet density (``int Z t dw = pi``), ``G`` Schlick's Smith-like self-shadowing, and ``1 - G G'`` the light
that the facets obstruct and re-emit after several bounces (we read it inside the ``b / (4 pi v v')``
factor, as written above). A *double* material (the seed's ``ly = true``) puts a second layer
``(C', r', p')`` under the first: ``R = S(u) D + (1 - S(u)) S'(u) D'``.

Parameters: the top ("specular") layer is ``sc, sr, sp``, the base ("diffuse") layer ``dc, dr, dp``, and
``ly`` selects the double material. Two entries are registered from the same kernels, the seed's settings:
``schlick_d`` ("Schlick (D)": ``sc = 0.7, sr = 0.31, sp = 1, ly = true, dc = 1, dr = 0, dp = 1``) and
``schlick_s`` ("Schlick (S)": the same top layer, ``ly = false``).

What ``eval`` contains
    The impulse ``c`` (the perfectly specular share of a layer with ``r < 1/2``) is a Dirac delta in the
    mirror direction: a BRDF evaluation cannot represent it, so ``eval`` returns the non-impulsive part
    (``a`` and ``b`` terms) only. Note the consequence for the seed's ``schlick_d``: its base layer has
    ``dr = 0``, a perfect mirror (``b' = a' = 0``, ``c' = 1``), so at its defaults ``schlick_d`` evaluates
    exactly like ``schlick_s``; the base layer shows as soon as ``dr > 0``.

Numerical care
    ``A`` is undefined for ``h = n`` (no azimuth); there every facet orientation is the normal, and we take
    ``A = 1``, its azimuthal mean for ``p = 1``. The ``1 / (v v')`` factor grows without bound toward the
    horizon (so does the re-emission term, which does not vanish there): ``v`` and ``v'`` in that denominator
    are floored at ``COS_FLOOR = 1e-6``; values are exact for angles below 89.99994 degrees and finite above.

Traits: reciprocal (every factor is symmetric in the two directions). Not isotropic for ``p < 1`` and not
energy-conserving (the re-emission term's albedo diverges at grazing), so neither is claimed.

Sampling (after Schlick's inversion formulas): a mixture of three strategies with fixed weights derived from the parameters:
cosine-weighted directions (for the Lambertian parts and the broad re-emission), and, per layer with
``b > 0``, half vectors drawn by Schlick's inversions, ``t^2 = x / (r - r x + x)`` (exact for the density
``Z``) and the azimuth ``psi = (pi/2) sqrt(p^2 y^2 / (1 - y^2 + p^2 y^2))`` from the direction where ``A``
peaks, in a quadrant picked at random, then reflected: ``wi = 2 (wo.h) h - wo``. The azimuth mapping only
approximates ``A``, so its density is computed exactly from the mapping's Jacobian,
``p(psi) = (2/pi) p^2 / (p^2 + g^2 (1 - p^2))^(3/2)`` with ``g = 2 psi / pi``; the half-vector density is
``2 t Z(t) p(phi)`` per unit solid angle and ``pdf(wi) = that / (4 |wo.h|)``. Half vectors with
``wo.h < 0`` give directions below the horizon, which ``pdf`` accounts for (the density covers the sphere).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.brdf import Param, Traits, declare, param_offsets, param_row_size
from core.jit import kernel
from core.models._fresnel import fresnel_schlick
from core.models.lobes import cosine_hemisphere, cosine_hemisphere_pdf

CITATION = (
    "C. Schlick, An inexpensive BRDF model for physically-based rendering, "
    "Computer Graphics Forum 13(3):233-246, 1994."
)

INV_PI = 0.3183098861837907
HALF_PI = 1.5707963267948966
TWO_OVER_PI = 0.6366197723675814
COS_FLOOR = 1e-6


def _params(double: bool) -> tuple[Param, ...]:
    """The parameters of a setting: both have this layout, and differ in the default of ``ly`` only."""
    return (
        Param("sc", (0.7, 0.7, 0.7), 0.0, 1.0, label="Top layer colour C", kind="color"),
        Param("sr", 0.31, 0.0, 1.0, label="Top layer roughness r", doc="0 = mirror, 1 = Lambertian."),
        Param("sp", 1.0, 0.01, 1.0, label="Top layer isotropy p", doc="1 = isotropic."),
        Param(
            "ly",
            1.0 if double else 0.0,
            kind="bool",
            label="Double layer",
            doc="True: a base layer (dc, dr, dp) under the top layer.",
        ),
        Param("dc", (1.0, 1.0, 1.0), 0.0, 1.0, label="Base layer colour C'", kind="color"),
        Param("dr", 0.0, 0.0, 1.0, label="Base layer roughness r'", doc="0 = mirror, 1 = Lambertian."),
        Param("dp", 1.0, 0.01, 1.0, label="Base layer isotropy p'", doc="1 = isotropic."),
    )


PARAMS = _params(double=True)
SC, SR, SP, LY, DC, DR, DP = param_offsets(PARAMS, "sc", "sr", "sp", "ly", "dc", "dr", "dp")
# derive_schlick appends the sampling mixture's weights (cosine, top lobe, base lobe) to the parameters
_W_COS = param_row_size(PARAMS)
_W_TOP, _W_BASE = _W_COS + 1, _W_COS + 2


@njit(inline="always", nogil=True, cache=True)
def _split(r):
    """Schlick's weights ``(a, b)`` of the Lambertian and glossy parts of a layer of roughness ``r``."""
    b = 4.0 * r * (1.0 - r)
    a = 0.0 if r < 0.5 else 1.0 - b
    return a, b


@njit(inline="always", nogil=True, cache=True)
def _zenith(t, r):
    d = 1.0 + r * t * t - t * t
    return r / (d * d)


@njit(inline="always", nogil=True, cache=True)
def _azimuth(w, p):
    return math.sqrt(p / (p * p - p * p * w * w + w * w))


@njit(inline="always", nogil=True, cache=True)
def _smith(v, r):
    return v / (r - r * v + v)


@kernel
def schlick_directional(t, v, vp, w, has_azimuth, r, p):
    """The non-impulsive directional factor ``a/pi + b/(4 pi v v') B`` of one layer."""
    a, b = _split(r)
    out = a * INV_PI
    if b > 0.0:
        gg = _smith(v, r) * _smith(vp, r)
        az = _azimuth(w, p) if has_azimuth else 1.0
        big_b = gg * _zenith(t, r) * az + 1.0 - gg
        out += b * big_b * INV_PI / (4.0 * max(v, COS_FLOOR) * max(vp, COS_FLOOR))
    return out


@kernel
def eval_schlick(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    h_xy = math.hypot(hx, hy)
    h_len = math.hypot(h_xy, hz)
    t = hz / h_len
    u = min(max((wi[0] * hx + wi[1] * hy + wi[2] * hz) / h_len, 0.0), 1.0)
    has_azimuth = h_xy > 0.0
    w = hx / h_xy if has_azimuth else 1.0
    v = min(wo[2], 1.0)
    vp = min(wi[2], 1.0)

    d_top = schlick_directional(t, v, vp, w, has_azimuth, p[SR], p[SP])
    double = p[LY] > 0.5
    d_base = schlick_directional(t, v, vp, w, has_azimuth, p[DR], p[DP]) if double else 0.0

    s0 = fresnel_schlick(u, p[SC])
    s1 = fresnel_schlick(u, p[SC + 1])
    s2 = fresnel_schlick(u, p[SC + 2])
    if not double:
        return s0 * d_top, s1 * d_top, s2 * d_top
    return (
        s0 * d_top + (1.0 - s0) * fresnel_schlick(u, p[DC]) * d_base,
        s1 * d_top + (1.0 - s1) * fresnel_schlick(u, p[DC + 1]) * d_base,
        s2 * d_top + (1.0 - s2) * fresnel_schlick(u, p[DC + 2]) * d_base,
    )


@njit(inline="always", nogil=True, cache=True)
def _azimuth_fold(phi):
    """Distance of azimuth ``phi`` in (-pi, pi] to the nearer of +-pi/2 (where ``A`` peaks), in [0, pi/2]."""
    return abs(abs(phi) - HALF_PI)


@njit(inline="always", nogil=True, cache=True)
def _azimuth_density(psi, p):
    """Density over ``phi`` of Schlick's azimuth mapping (each quadrant drawn with probability 1/4)."""
    g = TWO_OVER_PI * psi
    q = p * p + g * g * (1.0 - p * p)
    return 0.25 * TWO_OVER_PI * p * p / (q * math.sqrt(q))


@kernel
def _lobe_sample(wo, r, p, u1, u2):
    t2 = u1 / (r - r * u1 + u1)
    t = math.sqrt(t2)
    sin_t = math.sqrt(max(0.0, 1.0 - t2))
    quadrant = min(int(4.0 * u2), 3)
    y = 4.0 * u2 - quadrant
    psi = HALF_PI * p * y / math.sqrt(1.0 - y * y + p * p * y * y)
    if quadrant == 0:
        phi = HALF_PI - psi
    elif quadrant == 1:
        phi = HALF_PI + psi
    elif quadrant == 2:
        phi = -HALF_PI - psi
    else:
        phi = -HALF_PI + psi
    h = (sin_t * math.cos(phi), sin_t * math.sin(phi), t)
    c = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]
    return 2.0 * c * h[0] - wo[0], 2.0 * c * h[1] - wo[1], 2.0 * c * h[2] - wo[2]


@kernel
def _lobe_pdf(wo, wi, r, p):
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    h_xy = math.hypot(hx, hy)
    h_len = math.hypot(h_xy, hz)
    if h_len == 0.0:
        return 0.0
    if hz < 0.0:  # the half vector that maps wo to wi is defined up to sign: take the upper one
        hx, hy, hz = -hx, -hy, -hz
    t = hz / h_len
    c = abs(wo[0] * hx + wo[1] * hy + wo[2] * hz) / h_len
    if c == 0.0:
        return 0.0
    psi = _azimuth_fold(math.atan2(hy, hx)) if h_xy > 0.0 else 0.0
    return 2.0 * t * _zenith(t, r) * _azimuth_density(psi, p) / (4.0 * c)


@kernel
def pdf_schlick(wo, wi, p):
    out = p[_W_COS] * cosine_hemisphere_pdf(wi[2])
    if p[_W_TOP] > 0.0:
        out += p[_W_TOP] * _lobe_pdf(wo, wi, p[SR], p[SP])
    if p[_W_BASE] > 0.0:
        out += p[_W_BASE] * _lobe_pdf(wo, wi, p[DR], p[DP])
    return out


@kernel
def sample_schlick(wo, p, u1, u2, u3):
    # A lobe is drawn only if its weight is positive (a layer with b = 0 has no lobe, and r = 0 would make
    # the inversion 0/0); rounding in the cumulative weights falls back to the cosine strategy.
    if u1 >= p[_W_COS] and u1 < p[_W_COS] + p[_W_TOP] and p[_W_TOP] > 0.0:
        x, y, z = _lobe_sample(wo, p[SR], p[SP], u2, u3)
    elif u1 >= p[_W_COS] + p[_W_TOP] and p[_W_BASE] > 0.0:
        x, y, z = _lobe_sample(wo, p[DR], p[DP], u2, u3)
    else:
        x, y, z = cosine_hemisphere(u2, u3)
    wi = (x, y, z)
    return x, y, z, pdf_schlick(wo, wi, p)


def derive_schlick(user: np.ndarray) -> np.ndarray:
    """Append the sampling mixture weights: cosine (Lambertian parts, re-emission), top lobe, base lobe."""
    a_top = 0.0 if user[SR] < 0.5 else 1.0 - 4.0 * user[SR] * (1.0 - user[SR])
    b_top = 4.0 * user[SR] * (1.0 - user[SR])
    double = user[LY] > 0.5
    a_base = (0.0 if user[DR] < 0.5 else 1.0 - 4.0 * user[DR] * (1.0 - user[DR])) if double else 0.0
    b_base = 4.0 * user[DR] * (1.0 - user[DR]) if double else 0.0
    weights = np.array([0.1 + a_top + a_base, b_top, b_base])
    return np.concatenate([user, weights / weights.sum()])


NOTES = (
    "eval excludes the mirror impulse c = 1 - 4r(1-r) of layers with r < 1/2 (with the seed's dr = 0 the "
    "base layer is all impulse, so schlick_d equals schlick_s at the defaults). 1/(v v') floored at 1e-6. "
    "Sampler: cosine + Schlick's Z/A inversions per layer, exact mixture pdf."
)
TRAITS = Traits.RECIPROCAL | Traits.MIRROR_SYMMETRIC
# The two registered settings share the kernels; they differ in the ``ly`` default.
SCHLICK_D = declare(
    globals(), "Schlick (1994), double layer", TRAITS, name="schlick_d", params=_params(double=True)
)
SCHLICK_S = declare(
    globals(), "Schlick (1994), single layer", TRAITS, name="schlick_s", params=_params(double=False)
)
