"""Coupled specular-matte microfacet BRDF (C. Kelemen and L. Szirmay-Kalos, "A microfacet based coupled
specular-matte BRDF model with importance sampling", Eurographics 2001 short presentations).

Specular part: microfacet reflection with the paper's simplified geometry. Kelemen and Szirmay-Kalos replace
``G / (cos theta_L cos theta_V)`` of the Torrance-Sparrow form by ``1 / (L.H)^2``, which gives

    f_s(L, V) = P(H) F(L.H) / |L + V|^2          (|L + V|^2 = 2 (1 + L.V) = 4 (L.H)^2),

with ``P`` the Beckmann distribution of facet normals of rms slope ``m``, normalized over projected area
(``int P(H) (N.H) d omega_H = 1``), and ``F`` Schlick's Fresnel approximation with normal reflectance ``R0``.
It keeps the mirror limit (``m -> 0``) and, unlike the full Torrance-Sparrow term, its albedo stays below 1.

Matte part: light that is not reflected specularly (albedo ``1 - a(V)``, with ``a`` the specular albedo) is
re-emitted diffusely, coupled so that the result stays symmetric:

    f_m(L, V) = R_m (1 - a(L)) (1 - a(V)) / (pi (1 - a_avg)),     a_avg = 2 int_0^1 a(mu) mu dmu.

The normalization makes the matte albedo exactly ``R_m (1 - a(V))``, so the total albedo is
``a(V) + R_m (1 - a(V)) <= 1`` for ``R_m <= 1`` (equal to 1 for ``R_m = 1``: no absorption). ``a`` depends on
``m`` and ``R0``; ``derive`` tabulates it (``_kelemen_albedo``: quadrature accurate to ~1e-7, graded nodes,
Catmull-Rom interpolation) and ``a_avg`` is integrated from the same interpolant, so the identity above holds
to the table's accuracy (the tests measure the albedo against 1).

Importance sampling (the paper's): the halfway vector is drawn with density ``P(H) (N.H)``
(``tan^2 theta_H = -m^2 ln(1 - u)``), ``L`` is its mirror of ``V``, density ``P(H) (N.H) / (4 |V.H|)``; the
matte part is sampled by the cosine lobe. The lobe is chosen with probability proportional to the luminance
of the two albedos at ``V`` (``a(V)`` and ``R_m (1 - a(V))``), so ``pdf`` is the exact mixture density.

Parameters. The seed lists ``COUPLED R_m = 1, R_o = 0.05``. We read ``R_o`` as ``R0``, the specular (Fresnel)
reflectance at normal incidence, and ``R_m`` as the matte reflectance (the paper's factor for the part of the
non-specularly reflected light that is re-emitted rather than absorbed): both are reflectances, as their
symbols say. The seed fixes no roughness; the default ``m = 0.35`` is the seed's Cook-Torrance value.
(If ``R_m`` is instead read as the roughness, set ``m = 1``; ``R_m = 1`` as matte reflectance is the neutral
choice either way.)
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.brdf import Param, Traits, declare, param_offsets, param_row_size
from core.jit import kernel
from core.models._kelemen_albedo import N_TABLE, albedo_tables, hemispherical_average, table_map
from core.models._microfacet import beckmann_d, reflect_about
from core.models.lobes import LUMA, cosine_hemisphere, cosine_hemisphere_pdf, lobe_probability, luminance3

CITATION = (
    "C. Kelemen and L. Szirmay-Kalos, A microfacet based coupled specular-matte BRDF model with "
    "importance sampling, Eurographics 2001 Short Presentations."
)

INV_PI = 0.3183098861837907
TWO_PI = 6.283185307179586


PARAMS = (
    Param(
        "m",
        0.35,
        0.01,
        1.5,
        label="Roughness (Beckmann rms slope)",
        log=True,
        doc="RMS slope of the Beckmann facet distribution.",
    ),
    Param(
        "r0",
        (0.05, 0.05, 0.05),
        0.0,
        1.0,
        label="Specular reflectance at normal incidence",
        kind="color",
        doc="Schlick's R0: Fresnel reflectance of the facets at normal incidence (the seed's R_o).",
    ),
    Param(
        "rm",
        (1.0, 1.0, 1.0),
        0.0,
        1.0,
        label="Matte reflectance",
        kind="color",
        doc="Fraction of the non-specularly reflected light re-emitted diffusely (the seed's R_m).",
    ),
)
_M, _R0, _RM = param_offsets(PARAMS, "m", "r0", "rm")
# derive_coupled appends mu0, K, A_avg, B_avg, table A (N+2), table B (N+2) to the parameters
_MU0 = param_row_size(PARAMS)
_K, _A_AVG, _B_AVG, _TABLE_A = _MU0 + 1, _MU0 + 2, _MU0 + 3, _MU0 + 4
_TABLE_B = _TABLE_A + N_TABLE + 2


def derive_coupled(p: np.ndarray) -> np.ndarray:
    """Append the specular albedo tables for roughness ``m`` and their hemispherical averages."""
    m = float(p[_M])
    table_a, table_b = albedo_tables(m)
    mu0, k = table_map()
    head = [mu0, k, hemispherical_average(table_a), hemispherical_average(table_b)]
    return np.concatenate([p[:_MU0], head, table_a, table_b])


@njit(inline="always", nogil=True, cache=True)
def _lookup(p, offset, mu):
    """Catmull-Rom interpolation of a table at ``mu = cos(theta)`` (nodes graded geometrically towards 0)."""
    s = math.log1p(max(mu, 0.0) / p[_MU0]) / p[_K]
    x = min(max(s, 0.0), 1.0) * (N_TABLE - 1)
    j = min(int(x), N_TABLE - 2)
    t = x - j
    i = offset + j
    p0 = p[i]
    p1 = p[i + 1]
    p2 = p[i + 2]
    p3 = p[i + 3]
    t2 = t * t
    return 0.5 * (
        2.0 * p1
        + (p2 - p0) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t2 * t
    )


@njit(inline="always", nogil=True, cache=True)
def _albedo(p, channel, table_a, table_b):
    """Specular albedo of one colour channel from the two table values: ``R0 A + B``."""
    return min(p[_R0 + channel] * table_a + table_b, 1.0)


@kernel
def eval_coupled(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    m = p[_M]
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    hh = hx * hx + hy * hy + hz * hz
    spec = beckmann_d(m, hx, hy, hz) / hh
    cos_vh = min(0.5 * math.sqrt(hh), 1.0)
    c = 1.0 - cos_vh
    c2 = c * c
    schlick = c2 * c2 * c

    ta_i = _lookup(p, _TABLE_A, wi[2])
    tb_i = _lookup(p, _TABLE_B, wi[2])
    ta_o = _lookup(p, _TABLE_A, wo[2])
    tb_o = _lookup(p, _TABLE_B, wo[2])
    out_r = 0.0
    out_g = 0.0
    out_b = 0.0
    for ch in range(3):
        r0 = p[_R0 + ch]
        fresnel = r0 + (1.0 - r0) * schlick
        a_avg = min(r0 * p[_A_AVG] + p[_B_AVG], 1.0)
        one_minus_i = max(0.0, 1.0 - _albedo(p, ch, ta_i, tb_i))
        one_minus_o = max(0.0, 1.0 - _albedo(p, ch, ta_o, tb_o))
        matte = p[_RM + ch] * one_minus_i * one_minus_o * INV_PI / max(1.0 - a_avg, 1e-300)
        v = spec * fresnel + matte
        if ch == 0:
            out_r = v
        elif ch == 1:
            out_g = v
        else:
            out_b = v
    return out_r, out_g, out_b


@kernel
def _specular_probability(wo, p):
    """Probability of the specular lobe for view ``wo``: luminance share of its albedo."""
    if wo[2] <= 0.0:
        return 0.0
    ta = _lookup(p, _TABLE_A, wo[2])
    tb = _lookup(p, _TABLE_B, wo[2])
    a_r = _albedo(p, 0, ta, tb)
    a_g = _albedo(p, 1, ta, tb)
    a_b = _albedo(p, 2, ta, tb)
    spec = luminance3(a_r, a_g, a_b)
    # Not luminance3 of the products: this order of the multiplications is the one the model always used.
    matte = (
        LUMA[0] * p[_RM] * (1.0 - a_r)
        + LUMA[1] * p[_RM + 1] * (1.0 - a_g)
        + LUMA[2] * p[_RM + 2] * (1.0 - a_b)
    )
    return lobe_probability(spec, max(matte, 0.0))


@kernel
def _specular_pdf(wo, wi, m):
    """Density of ``wi`` when ``H ~ P(H) (N.H)`` (upper hemisphere) and ``wi`` mirrors ``wo`` about ``H``."""
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    n = math.sqrt(hx * hx + hy * hy + hz * hz)
    if n < 1e-12:
        return 0.0
    if hz < 0.0:  # the sampled H is the upper one of +-(wi + wo)
        hx, hy, hz = -hx, -hy, -hz
    cos_h = hz / n
    cos_vh = abs(wo[0] * hx + wo[1] * hy + wo[2] * hz) / n
    if cos_h <= 0.0 or cos_vh < 1e-12:
        return 0.0
    return beckmann_d(m, hx, hy, hz) * cos_h / (4.0 * cos_vh)


@kernel
def pdf_coupled(wo, wi, p):
    ps = _specular_probability(wo, p)
    pdf = (1.0 - ps) * cosine_hemisphere_pdf(wi[2])
    if ps > 0.0:
        pdf += ps * _specular_pdf(wo, wi, p[_M])
    return pdf


@kernel
def sample_coupled(wo, p, u1, u2, u3):
    ps = _specular_probability(wo, p)
    if u3 < ps:
        m = p[_M]
        tan2 = -m * m * math.log(1.0 - u1)
        cos_h = 1.0 / math.sqrt(1.0 + tan2)
        sin_h = math.sqrt(max(0.0, 1.0 - cos_h * cos_h))
        phi = TWO_PI * u2
        wi = reflect_about(wo, sin_h * math.cos(phi), sin_h * math.sin(phi), cos_h)
    else:
        wi = cosine_hemisphere(u1, u2)
    return wi[0], wi[1], wi[2], pdf_coupled(wo, wi, p)


NOTES = (
    "Specular P(H) F / |L+V|^2 (Beckmann, Schlick) plus the coupled matte term with the tabulated "
    "specular albedo (computed per roughness in derive, ~1e-7 accurate). Albedo = a + R_m (1 - a) <= 1. "
    "Sampler: halfway-vector Beckmann sampling mixed with the cosine lobe, exact mixture pdf."
)


COUPLED = declare(
    globals(),
    "Kelemen & Szirmay-Kalos coupled (2001)",
    Traits.ISOTROPIC | Traits.RECIPROCAL | Traits.ENERGY_CONSERVING,
)
