"""GGX microfacet conductor (B. Walter, S. R. Marschner, H. Li and K. E. Torrance, "Microfacet Models for
Refraction through Rough Surfaces", EGSR 2007), today's reference model, with a Lambertian base.

    f_r = kd / pi + F(wi.h) D(h) G1(wi) G1(wo) / (4 (n.wi)(n.wo))

- ``D``: GGX (Trowbridge-Reitz), ``D(h) = 1 / (pi alpha^2 (h.x^2/alpha^2 + h.y^2/alpha^2 + h.z^2)^2)``
  for unit ``h`` (Walter et al. eq. 33 rewritten without tangents, finite at ``h.z = 0``).
- ``G``: Smith's *separable* masking-shadowing ``G1(wi) G1(wo)`` (Walter et al. eq. 23 and 34), with
  ``G1(v) = 2 v.z / (v.z + sqrt(v.z^2 + alpha^2 (v.x^2 + v.y^2)))`` (zero where ``v.h`` and ``v.z`` differ
  in sign). This is the form Mitsuba 3's ``roughconductor`` evaluates, so the two can be cross-checked
  (``tests/core/test_mitsuba_crosscheck.py``). We evaluate ``G1(v) / v.z`` in the stable form
  ``2 / (v.z + sqrt(...))``, finite at grazing angles.
- ``F``: exact unpolarized Fresnel reflectance of a conductor ``eta + i k`` per RGB channel
  (``core.models._fresnel``). The defaults are copper's indices at about 650, 550 and 450 nm.

Reciprocal and isotropic. Not declared energy-conserving: the single-scattering specular lobe has albedo
<= 1, but ``kd`` is added independently.

Sampling: the distribution of visible normals (E. Heitz, "Sampling the GGX Distribution of Visible Normals",
JCGT 7(4), 2018): ``h`` with density ``D_v(h) = G1(wo) max(0, wo.h) D(h) / wo.z``, ``wi`` = ``wo``
reflected about ``h``; the exact density is ``D_v(h) / (4 wo.h) = G1(wo) D(h) / (4 wo.z)``. Mixed with the
cosine hemisphere (probability of the lobe ``Y(F(1)) / (Y(F(1)) + Y(kd))``, ``F(1)`` the normal-incidence
reflectance). For ``wo`` below the horizon (no reflection) only the cosine hemisphere is sampled.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.brdf import Param, Traits, declare, param_offsets, param_row_size
from core.jit import kernel
from core.models._fresnel import fresnel_conductor
from core.models._microfacet import ggx_visible_normal, reflect_about, upper_half_vector
from core.models.lobes import (
    cosine_hemisphere,
    cosine_hemisphere_pdf,
    lobe_probability,
    luminance3,
    mixture_pdf,
)

CITATION = (
    "B. Walter, S. R. Marschner, H. Li and K. E. Torrance, Microfacet Models for Refraction through "
    "Rough Surfaces, Eurographics Symposium on Rendering 2007; E. Heitz, Sampling the GGX "
    "Distribution of Visible Normals, JCGT 7(4), 2018."
)

PI = math.pi
INV_PI = 1.0 / math.pi


PARAMS = (
    Param("alpha", 0.2, 0.001, 1.0, label="Roughness (GGX alpha)", log=True),
    Param("eta", (0.200, 0.924, 1.102), 0.01, 10.0, label="Conductor index (real part)", kind="color"),
    Param("k", (3.912, 2.452, 2.142), 0.0, 10.0, label="Conductor extinction coefficient", kind="color"),
    Param("kd", (0.0, 0.0, 0.0), 0.0, 1.0, label="Diffuse albedo", kind="color"),
)
ALPHA, ETA, K, KD = param_offsets(PARAMS, "alpha", "eta", "k", "kd")
P_LOBE = param_row_size(PARAMS)
"""Appended by ``derive_ggx``: the probability of the specular lobe."""


@njit(inline="always", nogil=True, cache=True)
def ggx_d(hx, hy, hz, alpha):
    """GGX distribution at unit ``h`` (0 below the horizon)."""
    if hz <= 0.0:
        return 0.0
    a2 = alpha * alpha
    t = (hx * hx + hy * hy) / a2 + hz * hz
    return 1.0 / (PI * a2 * t * t)


@njit(inline="always", nogil=True, cache=True)
def smith_g1_over_cos(v, alpha):
    """``G1(v) / v.z`` for ``v.z >= 0``: ``2 / (v.z + sqrt(v.z^2 + alpha^2 (v.x^2 + v.y^2)))``."""
    z = v[2]
    return 2.0 / (z + math.sqrt(z * z + alpha * alpha * (v[0] * v[0] + v[1] * v[1])))


@kernel
def eval_ggx(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    alpha = p[ALPHA]
    hx, hy, hz, _ = upper_half_vector(wo, wi)  # wi.z + wo.z > 0: h = (wi + wo) / |wi + wo|
    c = wi[0] * hx + wi[1] * hy + wi[2] * hz  # = wo.h > 0: both masking terms are non-zero
    common = 0.25 * ggx_d(hx, hy, hz, alpha) * smith_g1_over_cos(wi, alpha) * smith_g1_over_cos(wo, alpha)
    return (
        p[KD] * INV_PI + common * fresnel_conductor(c, p[ETA], p[K]),
        p[KD + 1] * INV_PI + common * fresnel_conductor(c, p[ETA + 1], p[K + 1]),
        p[KD + 2] * INV_PI + common * fresnel_conductor(c, p[ETA + 2], p[K + 2]),
    )


@kernel
def visible_normal(wo, alpha, u1, u2):
    """Heitz (2018): a microfacet normal from ``D_v`` for ``wo.z >= 0``
    (:func:`core.models._microfacet.ggx_visible_normal` with ``ax = ay = alpha``)."""
    return ggx_visible_normal(wo, alpha, alpha, u1, u2)


@kernel
def _lobe_pdf(wo, wi, alpha):
    # Visible normals face wo, so wo.h = |wi + wo| / 2 > 0 always holds for h = (wi + wo) / |wi + wo|;
    # D is 0 below the horizon, so pairs with (wi + wo).z <= 0 have density 0 (no flip to the upper side).
    if wi[2] + wo[2] <= 0.0:
        return 0.0
    hx, hy, hz, _ = upper_half_vector(wo, wi)
    return 0.25 * smith_g1_over_cos(wo, alpha) * ggx_d(hx, hy, hz, alpha)


@kernel
def pdf_ggx(wo, wi, p):
    if wo[2] < 0.0:
        return cosine_hemisphere_pdf(wi[2])
    ps = p[P_LOBE]
    lobe = _lobe_pdf(wo, wi, p[ALPHA]) if ps > 0.0 else 0.0
    return mixture_pdf(ps, lobe, wi[2])


@kernel
def sample_ggx(wo, p, u1, u2, u3):
    if wo[2] >= 0.0 and u3 < p[P_LOBE]:
        hx, hy, hz = visible_normal(wo, p[ALPHA], u1, u2)
        wi = reflect_about(wo, hx, hy, hz)
    else:
        wi = cosine_hemisphere(u1, u2)
    return wi[0], wi[1], wi[2], pdf_ggx(wo, wi, p)


def derive_ggx(p_user: np.ndarray) -> np.ndarray:
    """Append the probability of sampling the specular lobe (from the normal-incidence albedos)."""
    f0 = [fresnel_conductor(1.0, float(p_user[ETA + c]), float(p_user[K + c])) for c in range(3)]
    ps = lobe_probability(
        luminance3(f0[0], f0[1], f0[2]), luminance3(p_user[KD], p_user[KD + 1], p_user[KD + 2])
    )
    return np.append(p_user, ps)


GGX = declare(globals(), "GGX (Walter et al. 2007)", Traits.ISOTROPIC | Traits.RECIPROCAL)
