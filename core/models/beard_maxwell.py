"""Beard-Maxwell reflection model for painted surfaces, in the NEF form (J. R. Maxwell, J. Beard, S. Weiner,
D. Ladd and S. Ladd, "Bidirectional reflectance model validation and utilization", Technical Report
AFAL-TR-73-303, Environmental Research Institute of Michigan, 1973; the modified form of the
Nonconventional Exploitation Factors database as presented by H. B. Westlund and G. W. Meyer, "A BRDF
database employing the Beard-Maxwell reflection model", Graphics Interface 2002, and "Applying
appearance standards to light reflection models", SIGGRAPH 2001).

The BRDF is a first-surface term (specular reflection by the facets of the paint's top surface) plus two
volumetric terms (light scattered inside the paint layer):

    f_r = R(beta)/R(0) * rho_fs(theta_N) * cos^2(theta_N) / (cos_i cos_o) * SO(theta_N, beta)
          + rho_D + 2 rho_V / (cos_i + cos_o)

with ``h`` the half vector, ``theta_N`` the angle between ``h`` and the normal (the tilt of the facets that
mirror ``wi`` into ``wo``) and ``beta`` the angle between ``wi`` and ``h`` (half the angle between the two
directions). ``R`` is the exact Fresnel reflectance of the complex index ``n_real + i n_imag``
(:func:`core.models._fresnel.fresnel_conductor`); dividing by ``R(0)`` makes ``rho_fs`` the first-surface
reflection at normal incidence, as Beard and Maxwell measure it (for the non-material ``n = 1, k = 0``,
where ``R`` vanishes, the ratio is taken as 1). The shadowing and obscuration factor is

    SO(theta_N, beta) = (1 + (theta_N/Omega) exp(-2 beta/tau)) / (1 + theta_N/Omega):

``Omega`` sets how fast facets tilted by ``theta_N`` are obscured, ``tau`` how fast the shadowing grows away
from retro-reflection (``beta = 0``, where SO = 1). Both are angles in radians here. ``tau = 0`` (the seed's
value) is the limit ``exp(-2 beta/tau) = 0``, i.e. ``SO = 1 / (1 + theta_N/Omega)`` for every ``beta > 0``
(the single point ``beta = 0`` is given the same value, keeping ``f_r`` continuous and isotropic).

The facet term ``rho_fs``
    Beard and Maxwell tabulate ``rho_fs(theta_N)`` from an in-plane measurement; NEF fits it with a
    two-parameter lobe. We use Beckmann's facet distribution ``D`` with RMS slope ``m`` scaled by ``rs``:
    ``rho_fs(theta_N) cos^2(theta_N) = rs D(theta_N) / 4``, i.e.

        rho_fs(theta_N) = rs * exp(-tan^2(theta_N)/m^2) / (4 pi m^2 cos^6(theta_N)),

    so the first-surface term reads ``R(beta)/R(0) rs D SO / (4 cos_i cos_o)`` (the Torrance-Sparrow form with
    SO as the geometric factor) and ``rs`` is the first-surface hemispherical reflectance at normal incidence
    when SO and the Fresnel ratio are 1. The seed lists no lobe width; ``m`` defaults to 0.3.

Units of the volumetric terms
    NEF's ``rho_D`` and ``rho_V`` are BRDF values (per steradian). Here ``rd`` and ``rv`` are reflectances
    (RGB, 0 to 1) and the terms are ``rd / pi`` and ``2 rv / (pi (cos_i + cos_o))``: ``rd`` is the albedo of
    the Lambertian term and ``rv / pi`` the volumetric BRDF at normal incidence and view.

Grazing directions
    ``1/(cos_i cos_o)`` and ``1/(cos_i + cos_o)`` grow without bound toward the horizon; each cosine in those
    denominators is floored at ``COS_FLOOR = 1e-6`` so values stay finite for every ``z > 0`` (exact for
    angles below 89.99994 degrees). Directions on or below the horizon give 0.

Traits: reciprocal and isotropic (every factor is symmetric in ``wi, wo``); not energy-conserving (the seed's
``rd = 0.75`` and ``rv = 0.5`` alone give an albedo of about 1.36 at normal incidence). No analytic sampler.
"""

from __future__ import annotations

import math

from core.brdf import Param, Traits, declare, param_offsets
from core.jit import kernel
from core.models._fresnel import fresnel_conductor

CITATION = (
    "J. R. Maxwell, J. Beard, S. Weiner, D. Ladd, S. Ladd, Bidirectional reflectance model validation "
    "and utilization, AFAL-TR-73-303, ERIM, 1973; NEF form after H. B. Westlund and G. W. Meyer, "
    "A BRDF database employing the Beard-Maxwell reflection model, Graphics Interface 2002."
)

INV_PI = 0.3183098861837907
COS_FLOOR = 1e-6


PARAMS = (
    Param(
        "omega",
        1.0,
        1e-3,
        10.0,
        unit="rad",
        label="Obscuration (Omega)",
        log=True,
        doc="Facet tilt scale of the obscuration: SO = 1/(1 + theta_N/Omega) away from retro.",
    ),
    Param(
        "tau",
        0.0,
        0.0,
        10.0,
        unit="rad",
        label="Shadowing (tau)",
        doc="Angular scale of the shadowing away from retro-reflection; 0 = the sharp limit.",
    ),
    Param("n_real", 0.37, 0.05, 10.0, label="Refractive index n", doc="Real part of the index."),
    Param("n_imag", 2.82, 0.0, 10.0, label="Extinction k", doc="Imaginary part of the index."),
    Param(
        "rs",
        (0.4, 0.4, 0.4),
        0.0,
        1.0,
        label="First-surface reflectance",
        kind="color",
        doc="Scale of the facet term (its hemispherical reflectance at normal incidence, SO = 1).",
    ),
    Param(
        "rd",
        (0.75, 0.75, 0.75),
        0.0,
        1.0,
        label="Diffuse reflectance",
        kind="color",
        doc="Albedo of the Lambertian volumetric term rd/pi.",
    ),
    Param(
        "rv",
        (0.5, 0.5, 0.5),
        0.0,
        1.0,
        label="Volumetric reflectance",
        kind="color",
        doc="Scale of the directional volumetric term 2 rv / (pi (cos_i + cos_o)).",
    ),
    Param(
        "m",
        0.3,
        0.01,
        1.0,
        label="Facet RMS slope",
        log=True,
        doc="Width of the Beckmann facet lobe (not in the seed's table).",
    ),
)
OMEGA, TAU, N_REAL, N_IMAG, RS, RD, RV, M = param_offsets(
    PARAMS, "omega", "tau", "n_real", "n_imag", "rs", "rd", "rv", "m"
)


@kernel
def eval_beard_maxwell(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    omega = p[OMEGA]
    tau = p[TAU]
    n_real = p[N_REAL]
    n_imag = p[N_IMAG]
    m = p[M]
    cos_i = max(min(wi[2], 1.0), COS_FLOOR)
    cos_o = max(min(wo[2], 1.0), COS_FLOOR)

    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]  # > 0: both directions are above the horizon
    # hypot, not sqrt of squares: for nearly grazing mirror pairs h is ~1e-300 long and its square underflows.
    h_xy = math.hypot(hx, hy)
    theta_n = math.atan2(h_xy, hz)
    h_len = math.hypot(h_xy, hz)
    cos_n = hz / h_len
    sin_n = h_xy / h_len
    # beta = half the angle between wi and wo, from atan2 of |wi x wo| and wi.wo (accurate near 0).
    cx = wi[1] * wo[2] - wi[2] * wo[1]
    cy = wi[2] * wo[0] - wi[0] * wo[2]
    cz = wi[0] * wo[1] - wi[1] * wo[0]
    dot_io = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2]
    beta = 0.5 * math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), dot_io)
    cos_beta = math.cos(beta)

    r0 = fresnel_conductor(1.0, n_real, n_imag)
    ratio = fresnel_conductor(cos_beta, n_real, n_imag) / r0 if r0 > 0.0 else 1.0

    tilt = theta_n / omega
    shadow = 0.0 if tau <= 0.0 else math.exp(-2.0 * beta / tau)
    so = (1.0 + tilt * shadow) / (1.0 + tilt)

    # Beckmann facet density D = exp(-tan^2/m^2) / (pi m^2 cos^4); zero once the exponent underflows.
    cos2 = cos_n * cos_n
    sin2 = sin_n * sin_n
    expo = sin2 / (cos2 * m * m) if cos2 > 0.0 else math.inf
    d = 0.0 if expo > 700.0 else math.exp(-expo) * INV_PI / (m * m * cos2 * cos2)
    first = ratio * d * so / (4.0 * cos_i * cos_o)

    vol = 2.0 * INV_PI / (cos_i + cos_o)
    return (
        p[RS] * first + p[RD] * INV_PI + p[RV] * vol,
        p[RS + 1] * first + p[RD + 1] * INV_PI + p[RV + 1] * vol,
        p[RS + 2] * first + p[RD + 2] * INV_PI + p[RV + 2] * vol,
    )


NOTES = (
    "First-surface facet lobe: Beckmann with RMS slope m scaled by rs (the seed gives no width). "
    "rd, rv are reflectances (terms divided by pi). Cosines in denominators floored at 1e-6. "
    "Omega and tau in radians; tau = 0 is the sharp-shadowing limit."
)


BEARD_MAXWELL = declare(globals(), "Beard-Maxwell (1973, NEF form)", Traits.ISOTROPIC | Traits.RECIPROCAL)
