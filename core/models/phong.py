"""Phong's shading model (B. T. Phong, "Illumination for computer generated pictures", CACM 18(6), 1975),
written as a BRDF.

Phong's model gives the reflected intensity for a light of intensity ``I_l`` from direction ``wi``:
``I = I_l (kd cos(theta_i) + ks cos^n(alpha))`` with ``alpha`` the angle between ``wo`` and the mirror
direction of ``wi`` (the ambient term is not part of a BRDF). Dividing by the irradiance ``I_l cos(theta_i)``
gives the BRDF

    f_r(wi, wo) = kd / pi + ks cos^n(alpha) / cos(theta_i),

with the diffuse term normalized as Lambert's so that ``kd`` is the diffuse albedo. The division by
``cos(theta_i)`` makes the model *not reciprocal* (the project notes' reading of the shading models Phong
and Strauss; Disney's BRDF Explorer offers the same division as an option). The reciprocal, normalized
variant (Lewis 1994) is the separate ``lewis`` model, as in the seed's list of models.

Sampled by a mixture of a ``cos^n`` lobe about the mirror direction of ``wo`` (for which
``f_spec cos(theta_i) / pdf`` is the constant ``2 pi ks / (n + 1)``) and the cosine-weighted hemisphere.
"""

from __future__ import annotations

from numba import njit

from core.brdf import Param, Traits, declare, param_offsets
from core.geometry import mirror
from core.jit import kernel
from core.models.lobes import (
    cosine_lobe_mixture_pdf,
    cosine_lobe_mixture_sample,
    cosine_power,
    diffuse_plus_lobe,
    lobe_probability_clamped,
    luminance_at,
)

CITATION = (
    "B. T. Phong, Illumination for computer generated pictures, Communications of the ACM "
    "18(6):311-317, 1975."
)

TWO_PI = 6.283185307179586
COS_THETA_I_FLOOR = 1e-6
"""The specular term divides by ``max(cos(theta_i), 1e-6)``: exact for ``theta_i <= 89.99994`` degrees, and
bounded by ``ks * 1e6`` instead of overflowing to Inf as ``cos(theta_i) -> 0``."""


PARAMS = (
    Param("n", 100.0, 1.0, 1e4, label="Specular exponent", log=True),
    Param("ks", (0.4, 0.4, 0.4), 0.0, 1.0, label="Specular coefficient", kind="color"),
    Param("kd", (0.6, 0.6, 0.6), 0.0, 1.0, label="Diffuse albedo", kind="color"),
)
N, KS, KD = param_offsets(PARAMS, "n", "ks", "kd")


@kernel
def eval_phong(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    spec = cosine_power(mirror(wo), wi, p[N]) / max(wi[2], COS_THETA_I_FLOOR)
    return diffuse_plus_lobe(p, KD, KS, spec)


@njit(inline="always", nogil=True, cache=True)
def _lobe_probability(p):
    # Estimated albedos: the lobe's f cos integrates to ks * 2 pi / (n + 1) over its cap, the diffuse to kd.
    return lobe_probability_clamped(luminance_at(p, KS) * TWO_PI / (p[N] + 1.0), luminance_at(p, KD))


@kernel
def pdf_phong(wo, wi, p):
    return cosine_lobe_mixture_pdf(mirror(wo), p[N], _lobe_probability(p), wi)


@kernel
def sample_phong(wo, p, u1, u2, u3):
    return cosine_lobe_mixture_sample(mirror(wo), p[N], _lobe_probability(p), u1, u2, u3)


NOTES = (
    "A shading model made a BRDF by dividing the reflected intensity by the irradiance "
    "cos(theta_i): f = kd/pi + ks cos^n(alpha)/cos(theta_i). Not reciprocal (the cos(theta_i) division), "
    "not energy-conserving (albedo up to kd + 2 pi ks/(n+1)). cos(theta_i) is floored at 1e-6 so the "
    "value stays finite at grazing incidence. For the reciprocal, normalized Phong use 'lewis'."
)


PHONG = declare(globals(), "Phong (1975)", Traits.ISOTROPIC)
