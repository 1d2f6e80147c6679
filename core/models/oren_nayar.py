"""Oren-Nayar rough diffuse reflection, the full model with interreflections (M. Oren and S. K. Nayar,
"Generalization of Lambert's reflectance model", SIGGRAPH 1994, 239-246).

The surface is a collection of long symmetric V-cavities whose facets are Lambertian with albedo ``rho``;
the facet slopes are Gaussian with standard deviation ``sigma`` (radians). With
``alpha = max(theta_i, theta_o)``, ``beta = min(theta_i, theta_o)`` and ``cos_phi = cos(phi_o - phi_i)``
the BRDF is ``f_r = (L1 + L2) / (E0 cos theta_i)``:

    L1 / (E0 cos_i) = rho/pi [C1 + cos_phi C2 tan(beta) + (1 - |cos_phi|) C3 tan((alpha + beta)/2)]
    L2 / (E0 cos_i) = 0.17 rho^2/pi * sigma^2/(sigma^2 + 0.13) * [1 - cos_phi (2 beta/pi)^2]

    C1 = 1 - 0.5 sigma^2/(sigma^2 + 0.33)
    C2 = 0.45 sigma^2/(sigma^2 + 0.09) sin(alpha)                          if cos_phi >= 0
    C2 = 0.45 sigma^2/(sigma^2 + 0.09) (sin(alpha) - (2 beta/pi)^3)        otherwise
    C3 = 0.125 sigma^2/(sigma^2 + 0.09) (4 alpha beta/pi^2)^2

``L1`` is the direct (single-bounce) term, ``L2`` the approximate two-bounce interreflection term.
``sigma = 0`` gives Lambert with albedo ``rho``. The formula is symmetric in the two directions
(reciprocal) and depends on the azimuths only through their difference (isotropic).

Numerical care
    * Normal incidence: the azimuth of a direction along the normal is undefined. Every term that uses
      ``cos_phi`` is multiplied by ``tan(beta)``, ``beta^2`` or ``(alpha beta)^2``, all of which vanish when
      either direction is the normal, so ``f_r`` has a limit there that does not depend on the azimuth.
      The kernel takes ``cos_phi = 0`` when either direction has no horizontal component and otherwise
      normalizes the two horizontal components separately (no underflow for nearly normal directions):
      the result is continuous and NaN-free.
    * Grazing: ``tan(beta)`` grows as both directions approach the horizon (the model's own behaviour; it
      stays finite for ``z > 0`` because the angles come from ``acos``, and the term is integrable).
    * Non-negativity bounds ``sigma``: with ``cos_phi = -1`` and both directions near the horizon,
      ``C2 tan(beta)`` tends to ``0.45 sigma^2/(sigma^2 + 0.09) * 6/pi``, which exceeds ``C1`` for
      ``sigma > 0.6644`` rad; the paper's formula then gives negative values (for small ``rho``). The
      parameter is therefore limited to ``[0, 0.66]`` rad (0 to 37.8 degrees), where the formula as published
      is non-negative for every pair of directions; no clamping is applied.

Energy: the interreflection term is an approximation, and for ``rho = 1`` the directional albedo reaches
about 1.04 near grazing (``sigma`` = 0.2 to 0.4 rad, measured by quadrature), so the model does not claim
energy conservation.

Seed parameters: ``OREN s = 0, r = 1``, i.e. ``sigma = 0`` and ``rho = 1``. No analytic sampler of its own;
the generic cosine-weighted sampler applies.
"""

from __future__ import annotations

import math

from core.brdf import Param, Traits, declare, param_offsets
from core.jit import kernel

CITATION = (
    "M. Oren and S. K. Nayar, Generalization of Lambert's reflectance model, Proc. SIGGRAPH 1994, 239-246."
)

INV_PI = 0.3183098861837907
TWO_OVER_PI = 0.6366197723675814
SIGMA_MAX = 0.66
"""Largest slope deviation (radians) for which the published formula is non-negative everywhere."""


PARAMS = (
    Param(
        "sigma",
        0.0,
        0.0,
        SIGMA_MAX,
        unit="rad",
        label="Facet slope deviation",
        doc="Standard deviation of the V-cavity facet slopes; 0 is Lambert (the seed's s).",
    ),
    Param(
        "rho",
        (1.0, 1.0, 1.0),
        0.0,
        1.0,
        label="Facet albedo",
        kind="color",
        doc="Albedo of the Lambertian facets (the seed's r).",
    ),
)
SIGMA, RHO = param_offsets(PARAMS, "sigma", "rho")


@kernel
def _cos_azimuth_difference(wi, wo):
    s_i = math.sqrt(wi[0] * wi[0] + wi[1] * wi[1])
    s_o = math.sqrt(wo[0] * wo[0] + wo[1] * wo[1])
    if s_i == 0.0 or s_o == 0.0:
        return 0.0  # a direction along the normal: every cos_phi term is multiplied by zero there
    c = (wi[0] / s_i) * (wo[0] / s_o) + (wi[1] / s_i) * (wo[1] / s_o)
    return min(max(c, -1.0), 1.0)


@kernel
def eval_oren_nayar(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    sigma = p[SIGMA]
    s2 = sigma * sigma
    theta_i = math.acos(min(wi[2], 1.0))
    theta_o = math.acos(min(wo[2], 1.0))
    alpha = max(theta_i, theta_o)
    beta = min(theta_i, theta_o)
    cos_phi = _cos_azimuth_difference(wi, wo)

    c1 = 1.0 - 0.5 * s2 / (s2 + 0.33)
    g = 0.45 * s2 / (s2 + 0.09)
    b = TWO_OVER_PI * beta
    if cos_phi >= 0.0:
        c2 = g * math.sin(alpha)
    else:
        c2 = g * (math.sin(alpha) - b * b * b)
    ab = 4.0 * alpha * beta * INV_PI * INV_PI
    c3 = 0.125 * s2 / (s2 + 0.09) * ab * ab
    direct = c1 + cos_phi * c2 * math.tan(beta) + (1.0 - abs(cos_phi)) * c3 * math.tan(0.5 * (alpha + beta))
    inter = 0.17 * s2 / (s2 + 0.13) * (1.0 - cos_phi * b * b)

    r, gg, bb = p[RHO], p[RHO + 1], p[RHO + 2]
    return (
        r * INV_PI * (direct + r * inter),
        gg * INV_PI * (direct + gg * inter),
        bb * INV_PI * (direct + bb * inter),
    )


NOTES = (
    "Full model with the C1, C2, C3 direct terms and the interreflection term. sigma is limited "
    "to 0.66 rad, where the published formula is non-negative for all directions. Azimuth terms "
    "vanish at normal incidence (continuous, NaN-free). Albedo up to ~1.04 near grazing for rho = 1: "
    "not energy-conserving."
)


OREN_NAYAR = declare(globals(), "Oren-Nayar (1994)", Traits.ISOTROPIC | Traits.RECIPROCAL)
