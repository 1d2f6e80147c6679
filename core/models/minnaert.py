"""Minnaert's limb-darkening law (M. Minnaert, "The reciprocity principle in lunar photometry",
Astrophysical Journal 93, 403-410, 1941).

Minnaert observed that the Moon's radiance factor follows ``(cos_i)^k (cos_o)^(k-1)``; written as a BRDF
(divide the reflected radiance by the irradiance ``E cos_i``) the law is symmetric in the two directions:

    f_r(wi, wo) = kd / pi * (cos_i * cos_o)^(k - 1).

``k = 1`` is Lambert's law; ``k < 1`` brightens the limb (grazing view and light), ``k > 1`` darkens it.

The horizon for ``k < 1``
    The exponent ``k - 1`` is negative, so ``f_r`` is finite for every direction with ``z > 0`` but grows
    without bound as either direction approaches the horizon. The kernel clamps both cosines at
    ``COS_FLOOR = 1e-6`` (a band of 5.7e-5 degrees above the horizon) so that even ``z = 1e-300`` gives a
    finite value (at most ``kd / pi * 1e12`` for the smallest ``k = 0``); directions at or below the horizon
    (``z <= 0``, e.g. exactly 90 degrees) give 0, as for every model. The clamp is symmetric, so the model
    stays reciprocal, and it changes nothing for ``theta < 89.99994`` degrees (89.9 degrees is exact).

Directional albedo
    ``rho(theta_o) = integral f_r cos_i d(omega_i) = 2 kd / (k + 1) * cos_o^(k - 1)``: finite for every
    ``theta_o < 90`` degrees whatever ``k``, but it exceeds 1 near grazing for ``k < 1`` and at normal
    incidence for ``k > 1`` (``2k / (k + 1) > 1``). The model is therefore not energy-conserving in
    general (only ``k = 1``, Lambert, is), and the traits say so.

Parameters: ``k`` (the seed's 0.8) and the albedo scale ``kd`` (RGB, the seed's 1). No analytic sampler of
its own; the generic cosine-weighted sampler applies.
"""

from __future__ import annotations

from core.brdf import Param, Traits, declare, param_offsets
from core.jit import kernel

CITATION = (
    "M. Minnaert, The reciprocity principle in lunar photometry, Astrophysical Journal 93:403-410, 1941."
)

INV_PI = 0.3183098861837907
COS_FLOOR = 1e-6
"""Cosines below this (but above 0) are raised to it before the power: see the module docstring."""


PARAMS = (
    Param(
        "k",
        0.8,
        0.0,
        2.0,
        label="Limb-darkening exponent",
        doc="1 = Lambert; below 1 the limb brightens, above 1 it darkens.",
    ),
    Param(
        "kd",
        (1.0, 1.0, 1.0),
        0.0,
        1.0,
        label="Diffuse reflectance",
        kind="color",
        doc="Scale of the law; equals the albedo when k = 1.",
    ),
)
K, KD = param_offsets(PARAMS, "k", "kd")


@kernel
def eval_minnaert(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    k = p[K]
    cos_i = max(min(wi[2], 1.0), COS_FLOOR)
    cos_o = max(min(wo[2], 1.0), COS_FLOOR)
    # Both cosines are >= COS_FLOOR > 0, so the power is finite for any exponent (no pow(0, negative)).
    shape = (cos_i * cos_o) ** (k - 1.0) * INV_PI
    return p[KD] * shape, p[KD + 1] * shape, p[KD + 2] * shape


NOTES = (
    "Cosines are clamped at 1e-6 before the power (finite everywhere, reciprocal, exact below "
    "89.99994 deg). Albedo 2 kd/(k+1) cos_o^(k-1): not energy-conserving unless k = 1."
)


MINNAERT = declare(globals(), "Minnaert (1941)", Traits.ISOTROPIC | Traits.RECIPROCAL)
