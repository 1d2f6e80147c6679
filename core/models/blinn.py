"""Blinn's half-vector specular model (J. F. Blinn, "Models of light reflection for computer synthesized
pictures", SIGGRAPH 1977), the Blinn-Phong BRDF.

Blinn replaces Phong's ``cos^n`` of the angle to the mirror direction by the ``cos^n`` of the angle between
the normal and the half vector ``h = (wi + wo) / |wi + wo|``:

    f_r(wi, wo) = kd / pi + ks (n . h)^n.

Used as a BRDF directly, without dividing by ``cos(theta_i)`` as the ``phong`` model does (the usual
Blinn-Phong BRDF), the value depends on ``wi`` and ``wo`` only through ``h``: reciprocal and isotropic. It is not normalized, so not
energy-conserving for every setting (at n = 1, ks = kd = 1 the albedo exceeds 1).

Sampled by a mixture of the cosine-weighted hemisphere and the half-vector lobe: ``h`` drawn with density
``(n+1)/(2 pi) (n . h)^n`` about the normal, reflected about ``h``, with the Jacobian ``1 / (4 wo . h)``.
"""

from __future__ import annotations

from numba import njit

from core.brdf import Param, Traits, declare, param_offsets
from core.geometry import half_vector
from core.jit import kernel
from core.models.lobes import (
    diffuse_plus_lobe,
    half_vector_mixture_pdf,
    half_vector_mixture_sample,
    lobe_probability_clamped,
    luminance_at,
)

CITATION = (
    "J. F. Blinn, Models of light reflection for computer synthesized pictures, "
    "Computer Graphics (SIGGRAPH '77) 11(2):192-198, 1977."
)

EIGHT_PI = 25.132741228718345


PARAMS = (
    Param("n", 100.0, 1.0, 1e4, label="Specular exponent", log=True),
    Param("ks", (1.0, 1.0, 1.0), 0.0, 1.0, label="Specular coefficient", kind="color"),
    Param("kd", (0.67, 0.67, 0.67), 0.0, 1.0, label="Diffuse albedo", kind="color"),
)
N, KS, KD = param_offsets(PARAMS, "n", "ks", "kd")


@kernel
def eval_blinn(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    # Both directions are above the horizon, so wi + wo has a positive z and h is well defined.
    cos_h = min(half_vector(wi, wo)[2], 1.0)
    spec = cos_h ** p[N]
    return diffuse_plus_lobe(p, KD, KS, spec)


@njit(inline="always", nogil=True, cache=True)
def _lobe_probability(wo, p):
    # Estimated specular albedo: for a narrow lobe h ~ n, d(omega_i) = 4 (wo.h) d(omega_h) and
    # cos(theta_i) ~ wo.z, so the integral of (n.h)^n cos(theta_i) is about 8 pi wo.z^2 / (n + 2).
    cz = max(wo[2], 0.0)
    return lobe_probability_clamped(
        luminance_at(p, KS) * EIGHT_PI * cz * cz / (p[N] + 2.0), luminance_at(p, KD)
    )


@kernel
def pdf_blinn(wo, wi, p):
    return half_vector_mixture_pdf(wo, p[N], _lobe_probability(wo, p), wi)


@kernel
def sample_blinn(wo, p, u1, u2, u3):
    return half_vector_mixture_sample(wo, p[N], _lobe_probability(wo, p), u1, u2, u3)


NOTES = (
    "Blinn-Phong BRDF f = kd/pi + ks (n.h)^n, used as a BRDF directly (no division by "
    "cos(theta_i)), hence reciprocal. Not normalized: not energy-conserving for every setting."
)


BLINN = declare(globals(), "Blinn (1977)", Traits.ISOTROPIC | Traits.RECIPROCAL)
