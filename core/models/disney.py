"""Disney's principled BRDF (B. Burley, "Physically-Based Shading at Disney", SIGGRAPH 2012 course notes,
Practical Physically-Based Shading in Film and Game Production), with the parameters, defaults and
constants of the model as Disney's BRDF Explorer ships it.

Eleven artist-facing parameters in [0, 1]: ``baseColor`` (RGB), ``metallic``, ``subsurface``, ``specular``,
``roughness``, ``specularTint``, ``anisotropic``, ``sheen``, ``sheenTint``, ``clearcoat``, ``clearcoatGloss``.
``baseColor`` is linear RGB, as every colour of this program: BRDF Explorer raises it to the power 2.2 first
("monitor to linear"); we do not (the same numbers give a lighter material here).

With ``h`` the normalized half vector, ``c_i = n.wi``, ``c_o = n.wo``, ``c_d = wi.h`` and Schlick's weight
``S(x) = (1 - x)^5``:

- tints: ``lum = 0.3 R + 0.6 G + 0.1 B`` of ``baseColor`` (Burley's approximate luminance), ``tint =
  baseColor / lum`` (white when ``lum = 0``), ``C_spec0 = mix(0.08 specular mix(1, tint, specularTint),
  baseColor, metallic)``, ``C_sheen = mix(1, tint, sheenTint)``;
- diffuse, with retro-reflection growing with roughness: ``F_D90 = 0.5 + 2 roughness c_d^2``,
  ``F_d = mix(1, F_D90, S(c_i)) mix(1, F_D90, S(c_o))``;
- subsurface (Hanrahan-Krueger-like flattening): ``F_ss90 = roughness c_d^2``, ``F_ss = mix(1, F_ss90,
  S(c_i)) mix(1, F_ss90, S(c_o))``, ``ss = 1.25 (F_ss (1 / (c_i + c_o) - 0.5) + 0.5)``;
- specular: anisotropic GGX (Burley's GTR with exponent 2, :mod:`core.models._microfacet`) with
  ``aspect = sqrt(1 - 0.9 anisotropic)``, ``ax = max(0.001, roughness^2 / aspect)``, ``ay = max(0.001,
  roughness^2 aspect)``, Smith's separable masking for those roughnesses, ``F_s = mix(C_spec0, 1, S(c_d))``;
- sheen: ``S(c_d) sheen C_sheen``;
- clearcoat: GTR1 ``D_c(h) = (a^2 - 1) / (pi ln(a^2) (a^2 cos^2(theta_h) + sin^2(theta_h)))`` with ``a =
  mix(0.1, 0.001, clearcoatGloss)`` (``1 / pi`` at ``a = 1``), ``F_c = mix(0.04, 1, S(c_d))`` (index 1.5),
  Smith's GGX masking with roughness 0.25, weight ``0.25 clearcoat``;

    f_r = (1 - metallic) (baseColor mix(F_d, ss, subsurface) / pi + sheen term)
          + F_s D_s G_s / (4 c_i c_o) + 0.25 clearcoat F_c D_c G_c / (4 c_i c_o).

Numerics. ``D_c``'s denominator is written with ``sin^2(theta_h) = h.x^2 + h.y^2`` (Burley's own form; the
form ``1 + (a^2 - 1) cos^2(theta_h)`` loses digits near ``h = n`` when ``a`` is small). The masking terms
are evaluated as ``G1(v) / v.z``, finite at grazing angles; ``ax, ay >= 0.001`` keeps ``D_s`` finite at
roughness 0. Zero when either direction is at or below the horizon (there ``1 / (c_i + c_o)`` would be
infinite, and ``f cos`` is 0 anyway).

Traits: reciprocal (every term is symmetric in ``wi`` and ``wo``); mirror-symmetric (the anisotropy enters
through ``h.x^2``, ``h.y^2``, ``v.x^2``, ``v.y^2`` only); isotropic only at ``anisotropic = 0``, which the
adaptive sampler finds by itself (:func:`core.sampling.adaptive.table.symmetry_of`), so the model does not
declare it. Not energy-conserving: the diffuse retro-reflection (``F_D90`` up to 2.5) and the terms added on
top of one another exceed albedo 1 (``tests/core/models/test_disney.py``).

Sampling: a mixture of three lobes, chosen by ``u3``:

- the visible normals of the specular GGX (Heitz 2018, anisotropic: stretched by ``ax``, ``ay``), ``wo``
  reflected about them; density ``G1(wo) D_s(h) / (4 wo.z)``;
- the clearcoat's GTR1 half vectors, drawn in proportion to ``D_c(h) cos(theta_h)`` by Burley's inversion
  ``cos^2(theta_h) = (1 - a^(2 (1 - u))) / (1 - a^2)`` and a uniform azimuth, ``wo`` reflected about them;
  density ``D_c(h) cos(theta_h) / (4 |wo.h|)``;
- the cosine hemisphere (diffuse, subsurface and sheen).

Their probabilities are proportional to estimates of each lobe's hemispherical albedo, computed once per
parameter setting in :func:`derive_disney`: specular ``Y(C_spec0) + (1 - Y(C_spec0)) / 21`` (Schlick's
Fresnel averaged over the cosine-weighted hemisphere; at least 1/21, so the specular lobe, whose density is
positive over the whole upper hemisphere, is always drawn); clearcoat ``0.25 clearcoat (0.04 + 0.96 / 21)``;
cosine ``(1 - metallic) (Y(baseColor) + SHEEN_ALBEDO sheen Y(C_sheen))`` (``Y`` the Rec. 709 luminance). For
``wo`` below the horizon only the cosine hemisphere is drawn. ``pdf`` is the exact mixture density.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.brdf import Param, Traits, declare, param_offsets, param_row_size
from core.jit import kernel
from core.models._microfacet import (
    ggx_anisotropic_d,
    ggx_anisotropic_g1_over_cos,
    ggx_visible_normal,
    ggx_visible_normal_reflection_pdf,
    reflect_about,
    upper_half_vector,
)
from core.models.lobes import cosine_hemisphere, cosine_hemisphere_pdf, luminance3

CITATION = (
    'B. Burley, "Physically-Based Shading at Disney", SIGGRAPH 2012 course notes (Practical '
    "Physically-Based Shading in Film and Game Production)."
)

PI = math.pi
INV_PI = 1.0 / math.pi
TWO_PI = 2.0 * math.pi

PARAMS = (
    Param(
        "baseColor",
        (0.82, 0.67, 0.16),
        0.0,
        1.0,
        label="Base color",
        kind="color",
        doc="Linear RGB (BRDF Explorer's files take it as a monitor colour and raise it to 2.2).",
    ),
    Param("metallic", 0.0, label="Metallic", doc="Blends the dielectric model into a metal."),
    Param("subsurface", 0.0, label="Subsurface", doc="Blends the diffuse term into a flattened one."),
    Param("specular", 0.5, label="Specular", doc="Dielectric reflectance at normal incidence / 0.08."),
    Param("roughness", 0.5, label="Roughness", doc="Specular and diffuse roughness."),
    Param("specularTint", 0.0, label="Specular tint", doc="Tints the dielectric specular by the base."),
    Param("anisotropic", 0.0, label="Anisotropic", doc="Aspect of the specular lobe (x wider)."),
    Param("sheen", 0.0, label="Sheen", doc="A grazing-angle lobe for cloth."),
    Param("sheenTint", 0.5, label="Sheen tint", doc="Tints the sheen by the base colour."),
    Param("clearcoat", 0.0, label="Clearcoat", doc="Strength of a second, white specular lobe."),
    Param("clearcoatGloss", 1.0, label="Clearcoat gloss", doc="0: satin (a = 0.1); 1: gloss (0.001)."),
)
# Kernel vector: the parameters in declaration order ...
(
    BASE_COLOR,
    METALLIC,
    SUBSURFACE,
    SPECULAR,
    ROUGHNESS,
    SPECULAR_TINT,
    ANISOTROPIC,
    SHEEN,
    SHEEN_TINT,
    CLEARCOAT,
    CLEARCOAT_GLOSS,
) = param_offsets(
    PARAMS,
    "baseColor",
    "metallic",
    "subsurface",
    "specular",
    "roughness",
    "specularTint",
    "anisotropic",
    "sheen",
    "sheenTint",
    "clearcoat",
    "clearcoatGloss",
)
# ... then what derive_disney computes from them, in this order.
DIFFUSE_COLOR = param_row_size(PARAMS)
"""``(1 - metallic) baseColor`` (3 slots)."""
SHEEN_COLOR = DIFFUSE_COLOR + 3
"""``(1 - metallic) sheen C_sheen`` (3 slots)."""
SPECULAR_F0 = SHEEN_COLOR + 3
"""``C_spec0``, the specular reflectance at normal incidence (3 slots)."""
ALPHA_X = SPECULAR_F0 + 3
ALPHA_Y = ALPHA_X + 1
COAT_A2 = ALPHA_Y + 1
"""``a^2`` of the clearcoat's GTR1 (1 selects the ``a = 1`` case)."""
COAT_NORM = COAT_A2 + 1
"""``(a^2 - 1) / (pi ln(a^2))``, GTR1's normalization (``1 / pi`` at ``a = 1``)."""
COAT_WEIGHT = COAT_NORM + 1
"""``0.25 clearcoat``."""
P_SPECULAR = COAT_WEIGHT + 1
"""Probability of the specular (visible-normal) lobe."""
P_SPECULAR_OR_COAT = P_SPECULAR + 1
"""That plus the clearcoat lobe's probability; the cosine hemisphere takes the rest."""
KERNEL_SIZE = P_SPECULAR_OR_COAT + 1


COAT_MASKING_ALPHA = 0.25
"""The clearcoat's fixed roughness in its masking term."""
SHEEN_ALBEDO = 0.0116
"""``int S(wi.h) cos(theta_i) d(omega_i)`` averaged over the cosine-weighted ``wo`` (by Monte Carlo, 4e6
pairs: 0.01161 +- 0.00003): the sheen term's albedo per unit ``sheen C_sheen``, for the mixture weights."""
SCHLICK_AVERAGE = 1.0 / 21.0
"""``int S(cos) 2 cos d(cos)`` over [0, 1]: the cosine-weighted mean of Schlick's weight."""


@njit(inline="always", nogil=True, cache=True)
def schlick_weight(cos_theta):
    """``(1 - cos)^5``, clamped to [0, 1]."""
    m = min(1.0, max(0.0, 1.0 - cos_theta))
    m2 = m * m
    return m2 * m2 * m


@njit(inline="always", nogil=True, cache=True)
def gtr1_d(hx, hy, hz, a2, norm):
    """Burley's GTR1 at unit ``h``: ``norm / (a^2 cos^2(theta_h) + sin^2(theta_h))`` (``a2 = 1``, ``norm =
    1 / pi``: the constant ``1 / pi``)."""
    return norm / (a2 * hz * hz + (hx * hx + hy * hy))


@kernel
def eval_disney(wi, wo, p):
    cos_i = wi[2]
    cos_o = wo[2]
    if cos_i <= 0.0 or cos_o <= 0.0:
        return 0.0, 0.0, 0.0
    hx, hy, hz, _ = upper_half_vector(wo, wi)  # cos_i + cos_o > 0: h = (wi + wo) / |wi + wo|
    cos_d = wi[0] * hx + wi[1] * hy + wi[2] * hz
    roughness = p[ROUGHNESS]
    s_i = schlick_weight(cos_i)
    s_o = schlick_weight(cos_o)
    s_d = schlick_weight(cos_d)

    fd90 = 0.5 + 2.0 * roughness * cos_d * cos_d
    fd = (1.0 + (fd90 - 1.0) * s_i) * (1.0 + (fd90 - 1.0) * s_o)
    fss90 = roughness * cos_d * cos_d
    fss = (1.0 + (fss90 - 1.0) * s_i) * (1.0 + (fss90 - 1.0) * s_o)
    ss = 1.25 * (fss * (1.0 / (cos_i + cos_o) - 0.5) + 0.5)
    diffuse = (fd + (ss - fd) * p[SUBSURFACE]) * INV_PI

    ax = p[ALPHA_X]
    ay = p[ALPHA_Y]
    specular = (
        0.25
        * ggx_anisotropic_d(hx, hy, hz, ax, ay)
        * ggx_anisotropic_g1_over_cos(wi, ax, ay)
        * ggx_anisotropic_g1_over_cos(wo, ax, ay)
    )
    coat = 0.0
    if p[COAT_WEIGHT] > 0.0:
        coat = (
            0.25
            * p[COAT_WEIGHT]
            * gtr1_d(hx, hy, hz, p[COAT_A2], p[COAT_NORM])
            * (0.04 + 0.96 * s_d)
            * ggx_anisotropic_g1_over_cos(wi, COAT_MASKING_ALPHA, COAT_MASKING_ALPHA)
            * ggx_anisotropic_g1_over_cos(wo, COAT_MASKING_ALPHA, COAT_MASKING_ALPHA)
        )
    out0 = _channel(p, 0, diffuse, specular, s_d) + coat
    out1 = _channel(p, 1, diffuse, specular, s_d) + coat
    out2 = _channel(p, 2, diffuse, specular, s_d) + coat
    return out0, out1, out2


@njit(inline="always", nogil=True, cache=True)
def _channel(p, c, diffuse, specular, s_d):
    """One colour channel of the diffuse, sheen and specular terms."""
    f0 = p[SPECULAR_F0 + c]
    return p[DIFFUSE_COLOR + c] * diffuse + p[SHEEN_COLOR + c] * s_d + specular * (f0 + (1.0 - f0) * s_d)


@kernel
def gtr1_sample_h(a2, u1, u2):
    """A half vector with density ``D_c(h) cos(theta_h)`` per unit solid angle (Burley's inversion of GTR1's
    distribution of ``cos^2(theta_h)``; uniform in ``cos^2`` at ``a = 1``)."""
    if a2 < 1.0:
        t = a2 ** (1.0 - u1)
        cos2 = (1.0 - t) / (1.0 - a2)
        sin2 = (t - a2) / (1.0 - a2)
    else:
        cos2 = 1.0 - u1
        sin2 = u1
    cos_h = math.sqrt(max(0.0, cos2))
    sin_h = math.sqrt(max(0.0, sin2))
    phi = TWO_PI * u2
    return sin_h * math.cos(phi), sin_h * math.sin(phi), cos_h


@njit(inline="always", nogil=True, cache=True)
def _coat_reflection_pdf(wo, wi, a2, norm):
    """Density per unit solid angle of ``wo`` reflected about a :func:`gtr1_sample_h` half vector: the
    half-vector density at the upper half vector of the pair times ``1 / (4 |wo.h|) = 1 / (2 |wi + wo|)``;
    0 at ``wi = -wo`` (measure zero)."""
    hx, hy, hz, norm_sum = upper_half_vector(wo, wi)
    if norm_sum == 0.0:
        return 0.0
    return gtr1_d(hx, hy, hz, a2, norm) * hz / (2.0 * norm_sum)


@kernel
def pdf_disney(wo, wi, p):
    cosine = cosine_hemisphere_pdf(wi[2])
    if wo[2] < 0.0:
        return cosine
    q_spec = p[P_SPECULAR]
    q_coat = p[P_SPECULAR_OR_COAT] - q_spec
    density = (1.0 - p[P_SPECULAR_OR_COAT]) * cosine
    if q_spec > 0.0:
        density += q_spec * ggx_visible_normal_reflection_pdf(wo, wi, p[ALPHA_X], p[ALPHA_Y])
    if q_coat > 0.0:
        density += q_coat * _coat_reflection_pdf(wo, wi, p[COAT_A2], p[COAT_NORM])
    return density


@kernel
def sample_disney(wo, p, u1, u2, u3):
    if wo[2] >= 0.0 and u3 < p[P_SPECULAR]:
        hx, hy, hz = ggx_visible_normal(wo, p[ALPHA_X], p[ALPHA_Y], u1, u2)
        wi = reflect_about(wo, hx, hy, hz)
    elif wo[2] >= 0.0 and u3 < p[P_SPECULAR_OR_COAT]:
        hx, hy, hz = gtr1_sample_h(p[COAT_A2], u1, u2)
        wi = reflect_about(wo, hx, hy, hz)
    else:
        wi = cosine_hemisphere(u1, u2)
    return wi[0], wi[1], wi[2], pdf_disney(wo, wi, p)


def derive_disney(p_user: np.ndarray) -> np.ndarray:
    """The kernel vector: the user parameters, then the colours, roughnesses and clearcoat constants the
    kernels read, and the mixture's probabilities (see the module docstring)."""
    base = np.asarray(p_user[BASE_COLOR : BASE_COLOR + 3], dtype=np.float64)
    metallic = float(p_user[METALLIC])
    roughness = float(p_user[ROUGHNESS])
    lum = 0.3 * base[0] + 0.6 * base[1] + 0.1 * base[2]
    tint = base / lum if lum > 0.0 else np.ones(3)
    dielectric_f0 = 0.08 * p_user[SPECULAR] * (1.0 + (tint - 1.0) * p_user[SPECULAR_TINT])
    specular_f0 = dielectric_f0 + (base - dielectric_f0) * metallic
    sheen_color = (1.0 - metallic) * p_user[SHEEN] * (1.0 + (tint - 1.0) * p_user[SHEEN_TINT])
    diffuse_color = (1.0 - metallic) * base

    aspect = math.sqrt(1.0 - 0.9 * float(p_user[ANISOTROPIC]))
    alpha_x = max(0.001, roughness * roughness / aspect)
    alpha_y = max(0.001, roughness * roughness * aspect)
    coat_a = 0.1 + (0.001 - 0.1) * float(p_user[CLEARCOAT_GLOSS])
    if coat_a >= 1.0:
        coat_a2, coat_norm = 1.0, INV_PI
    else:
        coat_a2 = coat_a * coat_a
        coat_norm = (coat_a2 - 1.0) / (PI * math.log(coat_a2))
    coat_weight = 0.25 * float(p_user[CLEARCOAT])

    y_f0 = float(luminance3(*specular_f0))
    w_spec = y_f0 + (1.0 - y_f0) * SCHLICK_AVERAGE
    w_coat = coat_weight * (0.04 + 0.96 * SCHLICK_AVERAGE)
    w_cosine = float(luminance3(*diffuse_color)) + SHEEN_ALBEDO * float(luminance3(*sheen_color))
    total = w_spec + w_coat + w_cosine
    p_spec = w_spec / total
    p_spec_or_coat = min(1.0, (w_spec + w_coat) / total)
    if w_cosine <= 0.0:
        p_spec_or_coat = 1.0  # no cosine lobe at all, not a rounding residue of one

    derived = np.concatenate(
        [
            diffuse_color,
            sheen_color,
            specular_f0,
            [alpha_x, alpha_y, coat_a2, coat_norm, coat_weight, p_spec, p_spec_or_coat],
        ]
    )
    return np.concatenate([np.asarray(p_user, dtype=np.float64), derived])


NOTES = (
    "baseColor is linear RGB (no 2.2 power as in BRDF Explorer). Isotropic at anisotropic = 0 "
    "(measured so by the adaptive sampler)."
)


DISNEY = declare(globals(), "Disney principled (Burley 2012)", Traits.RECIPROCAL | Traits.MIRROR_SYMMETRIC)
