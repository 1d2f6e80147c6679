"""Ashikhmin-Shirley anisotropic Phong model (M. Ashikhmin and P. Shirley, "An Anisotropic Phong BRDF
Model", Journal of Graphics Tools 5(2), 25-32, 2000).

With ``h`` the normalized half vector, ``c = wi.h = wo.h`` and Schlick's Fresnel
``F(c) = ks + (1 - ks) (1 - c)^5`` (RGB):

    f_s = sqrt((nu + 1)(nv + 1)) / (8 pi) * (n.h)^E(h) / (c max(n.wi, n.wo)) * F(c),
    E(h) = (nu (h.x)^2 + nv (h.y)^2) / (1 - (n.h)^2),
    f_d = 28 kd / (23 pi) (1 - ks) (1 - (1 - n.wi / 2)^5) (1 - (1 - n.wo / 2)^5),
    f_r = f_s + f_d.

The exponent is 0/0 at ``h = n`` when ``nu != nv``; there ``(n.h)^E = 1`` for any bounded ``E``
(``nu <= E <= nv``), which is the limit along every path. We compute ``E`` with ``h.x^2 + h.y^2`` in the
denominator (the same quantity as ``1 - (n.h)^2`` but free of cancellation near ``h = n``).

Reciprocal; anisotropic unless ``nu = nv``. Not declared energy-conserving: the paper's normalization is
exact only for the specular lobe's peak direction and ``ks`` and ``kd`` are bounded separately.

Sampling (the paper, sec. 3): ``phi_h = atan(sqrt((nu+1)/(nv+1)) tan(pi xi_1 / 2))`` on the first quadrant,
which we write for the whole circle as ``phi_h = atan2(sqrt(nu+1) sin(2 pi xi_1), sqrt(nv+1) cos(2 pi xi_1))``
(same density, no quadrant remapping), and ``cos(theta_h) = (1 - xi_2)^(1 / (nu cos^2 phi_h + nv sin^2 phi_h
+ 1))``. Its density is ``p_h(h) = sqrt((nu+1)(nv+1)) / (2 pi) (n.h)^E(h)`` per unit solid angle of ``h``
(``d xi_1 / d phi_h = sqrt((nu+1)(nv+1)) / (2 pi (E + 1))`` times ``(E + 1) cos^E`` in ``cos(theta_h)``); ``wi``
is ``wo`` reflected about ``h``, ``p(wi) = p_h / (4 |wo.h|)``. Mixed with the cosine hemisphere for the diffuse term with
probability ``P_s = Y(ks) / (Y(ks) + Y(kd))``. ``pdf`` is the exact mixture density.
"""

from __future__ import annotations

import math

from numba import njit

from core.brdf import Param, Traits, declare, param_offsets
from core.jit import kernel
from core.models._microfacet import reflect_about, upper_half_vector
from core.models.lobes import cosine_hemisphere, lobe_probability, luminance_at, mixture_pdf

CITATION = (
    "M. Ashikhmin and P. Shirley, An Anisotropic Phong BRDF Model, "
    "Journal of Graphics Tools 5(2):25-32, 2000."
)

PI = math.pi
TWO_PI = 2.0 * math.pi
DIFFUSE_NORM = 28.0 / (23.0 * math.pi)


PARAMS = (
    Param("nu", 25.0, 0.1, 1e5, label="Phong exponent along x", log=True),
    Param("nv", 25.0, 0.1, 1e5, label="Phong exponent along y", log=True),
    Param(
        "ks",
        (0.39, 0.39, 0.39),
        0.0,
        1.0,
        label="Specular reflectance at normal incidence",
        kind="color",
    ),
    Param("kd", (0.6, 0.6, 0.6), 0.0, 1.0, label="Diffuse reflectance", kind="color"),
)
NU, NV, KS, KD = param_offsets(PARAMS, "nu", "nv", "ks", "kd")


@njit(inline="always", nogil=True, cache=True)
def anisotropic_exponent(hx, hy, nu, nv):
    """``E(h)`` for a unit ``h``; at ``h = n`` (0/0) any value gives ``1^E = 1``: return ``nu``."""
    s2 = hx * hx + hy * hy
    if s2 <= 0.0:
        return nu
    return (nu * hx * hx + nv * hy * hy) / s2


@njit(inline="always", nogil=True, cache=True)
def _pow_cos(hz, e):
    # hz in (0, 1]; 0^0 cannot occur (hz = 0 only when wi and wo both lie on the horizon, opposite).
    if hz >= 1.0:
        return 1.0
    return hz**e


@kernel
def eval_ashikhmin_shirley(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    nu = p[NU]
    nv = p[NV]
    hx, hy, hz, _ = upper_half_vector(wo, wi)  # wi.z + wo.z > 0: h = (wi + wo) / |wi + wo|
    c = wi[0] * hx + wi[1] * hy + wi[2] * hz  # = |wi + wo| / 2 > 0
    lobe = (
        math.sqrt((nu + 1.0) * (nv + 1.0))
        / (8.0 * PI)
        * _pow_cos(hz, anisotropic_exponent(hx, hy, nu, nv))
        / (c * max(wi[2], wo[2]))
    )
    m = 1.0 - c
    schlick = m * m * m * m * m
    ti = 1.0 - 0.5 * wi[2]
    to = 1.0 - 0.5 * wo[2]
    diffuse_shape = DIFFUSE_NORM * (1.0 - ti**5) * (1.0 - to**5)
    out0 = p[KS] + (1.0 - p[KS]) * schlick
    out1 = p[KS + 1] + (1.0 - p[KS + 1]) * schlick
    out2 = p[KS + 2] + (1.0 - p[KS + 2]) * schlick
    return (
        lobe * out0 + p[KD] * (1.0 - p[KS]) * diffuse_shape,
        lobe * out1 + p[KD + 1] * (1.0 - p[KS + 1]) * diffuse_shape,
        lobe * out2 + p[KD + 2] * (1.0 - p[KS + 2]) * diffuse_shape,
    )


@kernel
def _half_vector_sample(nu, nv, u1, u2):
    xi = TWO_PI * u1
    phi = math.atan2(math.sqrt(nu + 1.0) * math.sin(xi), math.sqrt(nv + 1.0) * math.cos(xi))
    cp = math.cos(phi)
    sp = math.sin(phi)
    e = nu * cp * cp + nv * sp * sp
    cos_t = (1.0 - u2) ** (1.0 / (e + 1.0))
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    return sin_t * cp, sin_t * sp, cos_t


@kernel
def _lobe_pdf(wo, wi, nu, nv):
    hx, hy, hz, norm = upper_half_vector(wo, wi)  # the sampled half vector is the upper one
    if hz <= 0.0:  # also at wi = -wo, where norm = 0
        return 0.0
    p_h = math.sqrt((nu + 1.0) * (nv + 1.0)) / TWO_PI * _pow_cos(hz, anisotropic_exponent(hx, hy, nu, nv))
    return p_h / (2.0 * norm)  # 4 |wo.h| = 2 |wi + wo|


@njit(inline="always", nogil=True, cache=True)
def _lobe_probability(p):
    return lobe_probability(luminance_at(p, KS), luminance_at(p, KD))


@kernel
def pdf_ashikhmin_shirley(wo, wi, p):
    ps = _lobe_probability(p)
    lobe = _lobe_pdf(wo, wi, p[NU], p[NV]) if ps > 0.0 else 0.0
    return mixture_pdf(ps, lobe, wi[2])


@kernel
def sample_ashikhmin_shirley(wo, p, u1, u2, u3):
    if u3 < _lobe_probability(p):
        hx, hy, hz = _half_vector_sample(p[NU], p[NV], u1, u2)
        wi = reflect_about(wo, hx, hy, hz)
    else:
        wi = cosine_hemisphere(u1, u2)
    return wi[0], wi[1], wi[2], pdf_ashikhmin_shirley(wo, wi, p)


ASHIKHMIN_SHIRLEY = declare(
    globals(), "Ashikhmin-Shirley (2000)", Traits.RECIPROCAL | Traits.MIRROR_SYMMETRIC
)
