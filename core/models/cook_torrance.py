"""Cook-Torrance microfacet model (R. L. Cook and K. E. Torrance, "A Reflectance Model for Computer
Graphics", ACM Transactions on Graphics 1(1), 7-24, 1982; SIGGRAPH '81).

    f_r = kd / pi + ks F(wi.h) D(h) G(wi, wo) / (pi (n.wi) (n.wo))

- ``D``: Beckmann's distribution of microfacet slopes with RMS slope ``m``,
  ``D = exp(-tan^2(alpha) / m^2) / (4 m^2 cos^4(alpha))``, ``alpha`` the angle between ``h`` and ``n``. This
  is the normalization printed in the SIGGRAPH '81 version: with the paper's ``1 / pi`` it makes the specular
  term equal to the microfacet BRDF ``F D_B G / (4 (n.wi)(n.wo))`` with the unit-projected-area Beckmann
  ``D_B = exp(-tan^2 alpha / m^2) / (pi m^2 cos^4 alpha)`` (the TOG 1982 printing drops the 4, which makes
  the specular albedo up to four times the Fresnel reflectance; see Walter et al. 2007, sec. 5.1).
- ``G``: the V-cavity masking-shadowing of Torrance & Sparrow (1967),
  ``G = min(1, 2 (n.h)(n.wo) / (wo.h), 2 (n.h)(n.wi) / (wo.h))``.
- ``F``: the exact unpolarized Fresnel reflectance of a conductor with complex index ``n_real + i n_imag``
  at the microfacet, ``cos = wi.h`` (``core.models._fresnel``); ``ks`` tints it (RGB).

Reciprocal (every factor is symmetric in ``wi, wo``) and isotropic. Not declared energy-conserving: the
diffuse and specular coefficients are independent, so ``kd + ks`` can reach 2.

Sampling: with probability ``P_s = Y(ks) / (Y(ks) + Y(kd))`` (``Y`` = luminance) a half vector from
``D_B(h) cos(theta_h)`` (Beckmann slopes are Gaussian: exact inversion), reflected about ``h``, with the
Jacobian ``d(omega_h) / d(omega_i) = 1 / (4 |wo.h|)``; otherwise the cosine hemisphere. The mixture density
is exact everywhere (samples below the horizon included).
"""

from __future__ import annotations

import math

from core.brdf import Param, Traits, declare, param_offsets
from core.jit import kernel
from core.models._fresnel import fresnel_conductor
from core.models._microfacet import upper_half_vector
from core.models.lobes import (
    beckmann_mixture_pdf,
    beckmann_mixture_sample,
    diffuse_plus_lobe,
    luminance_lobe_probability,
)

CITATION = (
    "R. L. Cook and K. E. Torrance, A Reflectance Model for Computer Graphics, "
    "ACM Transactions on Graphics 1(1):7-24, 1982."
)

PI = math.pi


PARAMS = (
    Param("m", 0.35, 0.005, 1.0, label="RMS microfacet slope", log=True),
    Param("n_real", 0.617, 0.01, 10.0, label="Refractive index (real part)"),
    Param("n_imag", 2.63, 0.0, 10.0, label="Extinction coefficient (imaginary part)"),
    Param("ks", (0.7, 0.7, 0.7), 0.0, 1.0, label="Specular coefficient", kind="color"),
    Param("kd", (0.3, 0.3, 0.3), 0.0, 1.0, label="Diffuse albedo", kind="color"),
)
M, N_REAL, N_IMAG, KS, KD = param_offsets(PARAMS, "m", "n_real", "n_imag", "ks", "kd")


@kernel
def eval_cook_torrance(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    m = p[M]
    hx, hy, hz, _ = upper_half_vector(wo, wi)  # wi.z + wo.z > 0: h = (wi + wo) / |wi + wo|
    c = wi[0] * hx + wi[1] * hy + wi[2] * hz  # = wo.h > 0 when both lie above the horizon
    tan2 = (hx * hx + hy * hy) / (hz * hz)
    e = tan2 / (m * m)
    spec = 0.0
    if e < 700.0:
        d = math.exp(-e) / (4.0 * m * m * hz * hz * hz * hz)
        g = min(1.0, 2.0 * hz * wo[2] / c, 2.0 * hz * wi[2] / c)
        f = fresnel_conductor(c, p[N_REAL], p[N_IMAG])
        spec = f * d * g / (PI * wi[2] * wo[2])
    return diffuse_plus_lobe(p, KD, KS, spec)


@kernel
def pdf_cook_torrance(wo, wi, p):
    return beckmann_mixture_pdf(wo, wi, p[M], p[M], luminance_lobe_probability(p, KS, KD))


@kernel
def sample_cook_torrance(wo, p, u1, u2, u3):
    return beckmann_mixture_sample(wo, p[M], p[M], luminance_lobe_probability(p, KS, KD), u1, u2, u3)


NOTES = "Beckmann D with the SIGGRAPH '81 normalization (see the module docstring)."


COOK_TORRANCE = declare(globals(), "Cook-Torrance (1982)", Traits.ISOTROPIC | Traits.RECIPROCAL)
