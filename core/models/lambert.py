"""Lambert's ideal diffuse reflector (J. H. Lambert, *Photometria*, 1760).

``f_r = kd / pi``: the same radiance in every direction. Sampled by the cosine-weighted hemisphere
(Malley's method), whose density ``cos(theta_i) / pi`` makes ``f cos / pdf = kd`` constant.
"""

from __future__ import annotations

from core.brdf import Param, Traits, declare, param_offsets
from core.jit import kernel
from core.models.lobes import cosine_hemisphere, cosine_hemisphere_pdf

CITATION = "J. H. Lambert, Photometria, 1760."

INV_PI = 0.3183098861837907

PARAMS = (Param("kd", (0.8, 0.8, 0.8), 0.0, 1.0, label="Diffuse albedo", kind="color"),)
(KD,) = param_offsets(PARAMS, "kd")


@kernel
def eval_lambert(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    return p[KD] * INV_PI, p[KD + 1] * INV_PI, p[KD + 2] * INV_PI


@kernel
def sample_lambert(wo, p, u1, u2, u3):
    x, y, z = cosine_hemisphere(u1, u2)
    return x, y, z, cosine_hemisphere_pdf(z)


@kernel
def pdf_lambert(wo, wi, p):
    return cosine_hemisphere_pdf(wi[2])


LAMBERT = declare(
    globals(), "Lambert (1760)", Traits.ISOTROPIC | Traits.RECIPROCAL | Traits.ENERGY_CONSERVING
)
