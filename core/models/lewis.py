"""Lewis's normalized Phong BRDF (R. R. Lewis, "Making shaders more physically plausible",
Computer Graphics Forum 13(2), 1994).

Lewis made Phong's model a physically plausible BRDF: no division by ``cos(theta_i)`` (so it is
reciprocal) and a normalization of the specular lobe,

    f_r(wi, wo) = kd / pi + ks (n + 2) / (2 pi) cos^n(alpha),

with ``alpha`` the angle between ``wi`` and the mirror direction of ``wo``. The specular albedo is largest
at normal incidence, where it equals ``ks`` exactly (the integral of ``cos^(n+1)`` over the hemisphere is
``2 pi / (n + 2)``); so the model conserves energy whenever ``kd + ks <= 1`` per channel. The parameter
bounds allow ``kd + ks`` up to 2, so the trait is not claimed.

Sampled by a mixture of a ``cos^n`` lobe about the mirror direction and the cosine-weighted hemisphere.
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
    "R. R. Lewis, Making shaders more physically plausible, Computer Graphics Forum 13(2):109-120, 1994."
)

INV_TWO_PI = 0.15915494309189535


PARAMS = (
    Param("n", 100.0, 1.0, 1e4, label="Specular exponent", log=True),
    Param("ks", (1.0, 1.0, 1.0), 0.0, 1.0, label="Specular albedo", kind="color"),
    Param("kd", (0.0, 0.0, 0.0), 0.0, 1.0, label="Diffuse albedo", kind="color"),
)
N, KS, KD = param_offsets(PARAMS, "n", "ks", "kd")


@kernel
def eval_lewis(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    n = p[N]
    spec = (n + 2.0) * INV_TWO_PI * cosine_power(mirror(wo), wi, n)
    return diffuse_plus_lobe(p, KD, KS, spec)


@njit(inline="always", nogil=True, cache=True)
def _lobe_probability(wo, p):
    # Specular albedo of a lobe that stays above the horizon: ks * cos(theta_o) exactly.
    return lobe_probability_clamped(luminance_at(p, KS) * max(wo[2], 0.0), luminance_at(p, KD))


@kernel
def pdf_lewis(wo, wi, p):
    return cosine_lobe_mixture_pdf(mirror(wo), p[N], _lobe_probability(wo, p), wi)


@kernel
def sample_lewis(wo, p, u1, u2, u3):
    return cosine_lobe_mixture_sample(mirror(wo), p[N], _lobe_probability(wo, p), u1, u2, u3)


NOTES = (
    "Normalized, reciprocal Phong: f = kd/pi + ks (n+2)/(2 pi) cos^n(alpha). Energy-conserving "
    "when kd + ks <= 1 in every channel (albedo <= kd + ks, with equality of the specular part at "
    "normal incidence); the bounds allow more, so ENERGY_CONSERVING is not declared."
)


LEWIS = declare(globals(), "Lewis (1994)", Traits.ISOTROPIC | Traits.RECIPROCAL)
