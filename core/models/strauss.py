"""Strauss's lighting model for animators (P. S. Strauss, "A realistic lighting model for computer
animators", IEEE Computer Graphics and Applications 10(6):56-64, 1990).

Strauss replaces the usual ambient/diffuse/specular coefficients by four intuitive material properties:
a colour ``C``, a smoothness ``s``, a metalness ``m`` and a transparency ``t`` (0 to 1 each). For one light of
unit intensity the reflected intensity is ``Q_d + Q_s`` with

    Q_d = cos_i * d * r_d * C,        d = 1 - m s,      r_d = (1 - s^3)(1 - t)
    Q_s = max(0, R . wo)^h * r_j * C_s,                 h = 3 / (1 - s)
    r_n = (1 - t) - r_d,    j = F(x_i) G(x_i) G(x_o),    r_j = min(1, r_n + (r_n + k_j) j),   k_j = 0.1
    C_s = 1 + m (1 - F(x_i)) (C - 1)

where ``R`` is the mirror direction of the light (``wi`` reflected about the normal), ``x = theta / (pi/2)``
is a polar angle normalized to [0, 1], and Strauss's approximations of the Fresnel and shadowing factors are

    F(x) = [1/(x - k_f)^2 - 1/k_f^2] / [1/(1 - k_f)^2 - 1/k_f^2],   k_f = 1.12
    G(x) = [1/(1 - k_g)^2 - 1/(x - k_g)^2] / [1/(1 - k_g)^2 - 1/k_g^2],   k_g = 1.01.

From a shading model to a BRDF
    Strauss's ``Q`` is a reflected intensity per unit light intensity, with the cosine of incidence built
    into the diffuse term only. A BRDF is reflected radiance over irradiance ``E cos_i``; we divide ``Q`` by
    ``pi cos_i`` so that the diffuse term becomes the Lambertian ``d r_d C / pi`` (its albedo is Strauss's
    diffuse reflectance ``d r_d C``) and the specular term becomes ``r_j C_s max(0, R . wo)^h / (pi cos_i)``.
    The result is **not reciprocal** (the lobe, ``j`` and ``C_s`` treat light and view differently, and the
    specular term carries ``1 / cos_i``) and **not energy-conserving** in general (the specular lobe is not
    normalized). The ``1 / cos_i`` grows without bound toward a grazing light; the kernel divides by
    ``max(cos_i, COS_FLOOR)`` with ``COS_FLOOR = 1e-6`` so that values stay finite for any ``wi`` with
    ``z > 0`` (exact for ``theta_i < 89.99994`` degrees). ``f cos_i`` itself is bounded, so albedos are finite.

Seed parameters
    The seed lists ``STRAUSS s = 0.76, m = 0.91, ks = 0.64, kd = 0.5``. Strauss's model has no ``ks``/``kd``;
    as in the seed's other models (Phong, Blinn, Ward, ...) we read them as weights of the specular and
    diffuse terms: ``f = kd * (diffuse term) + ks * (specular term)``; ``ks = kd = 1`` is Strauss's model as
    published. ``C`` defaults to white and ``t`` to 0 (opaque), neither being listed in the seed.
    ``s`` stops at 0.999 (``h = 3000``): ``s = 1`` would be a perfect mirror, an impulse a BRDF cannot hold.

No analytic sampler of its own; the generic samplers apply.
"""

from __future__ import annotations

import math

from numba import njit

from core.brdf import Param, Traits, declare, param_offsets
from core.jit import kernel

CITATION = (
    "P. S. Strauss, A realistic lighting model for computer animators, "
    "IEEE Computer Graphics and Applications 10(6):56-64, 1990."
)

INV_PI = 0.3183098861837907
TWO_OVER_PI = 0.6366197723675814
COS_FLOOR = 1e-6
K_F = 1.12
K_G = 1.01
K_J = 0.1


PARAMS = (
    Param("s", 0.76, 0.0, 0.999, label="Smoothness", doc="0 = rough diffuse, toward 1 = mirror."),
    Param("m", 0.91, 0.0, 1.0, label="Metalness", doc="Tints the highlight with the colour."),
    Param("t", 0.0, 0.0, 1.0, label="Transparency", doc="Light not reflected (transmitted)."),
    Param("color", (1.0, 1.0, 1.0), 0.0, 1.0, label="Surface colour", kind="color"),
    Param(
        "kd",
        (0.5, 0.5, 0.5),
        0.0,
        1.0,
        label="Diffuse weight",
        kind="color",
        doc="Seed's weight of the diffuse term (1 = Strauss as published).",
    ),
    Param(
        "ks",
        (0.64, 0.64, 0.64),
        0.0,
        1.0,
        label="Specular weight",
        kind="color",
        doc="Seed's weight of the specular term (1 = Strauss as published).",
    ),
)
S, M, T, COLOR, KD, KS = param_offsets(PARAMS, "s", "m", "t", "color", "kd", "ks")


@njit(inline="always", nogil=True, cache=True)
def strauss_fresnel(x):
    """Strauss's Fresnel approximation of a normalized angle ``x`` in [0, 1]: 0 at 0, 1 at 1."""
    a = 1.0 / (K_F * K_F)
    return (1.0 / ((x - K_F) * (x - K_F)) - a) / (1.0 / ((1.0 - K_F) * (1.0 - K_F)) - a)


@njit(inline="always", nogil=True, cache=True)
def strauss_shadow(x):
    """Strauss's shadowing approximation of a normalized angle ``x`` in [0, 1]: 1 at 0, 0 at 1."""
    b = 1.0 / ((1.0 - K_G) * (1.0 - K_G))
    return (b - 1.0 / ((x - K_G) * (x - K_G))) / (b - 1.0 / (K_G * K_G))


@njit(inline="always", nogil=True, cache=True)
def _normalized_angle(w):
    # The polar angle from atan2(|w_xy|, w_z) keeps full precision near the normal and the horizon.
    sin_theta = math.sqrt(w[0] * w[0] + w[1] * w[1])
    return min(max(TWO_OVER_PI * math.atan2(sin_theta, w[2]), 0.0), 1.0)


@kernel
def eval_strauss(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    s = p[S]
    m = p[M]
    t = p[T]
    cos_i = min(wi[2], 1.0)

    d = 1.0 - m * s
    r_d = (1.0 - s * s * s) * (1.0 - t)
    r_n = (1.0 - t) - r_d
    h = 3.0 / (1.0 - s)
    x_i = _normalized_angle(wi)
    x_o = _normalized_angle(wo)
    f_i = strauss_fresnel(x_i)
    j = f_i * strauss_shadow(x_i) * strauss_shadow(x_o)
    r_j = min(1.0, r_n + (r_n + K_J) * j)

    # Mirror direction of the light about the normal: (-wi.x, -wi.y, wi.z).
    c = -wi[0] * wo[0] - wi[1] * wo[1] + wi[2] * wo[2]
    lobe = max(c, 0.0) ** h
    spec = lobe * r_j * INV_PI / max(cos_i, COS_FLOOR)
    diff = d * r_d * INV_PI
    w_metal = m * (1.0 - f_i)

    out_r = p[KD] * diff * p[COLOR] + p[KS] * spec * (1.0 + w_metal * (p[COLOR] - 1.0))
    out_g = p[KD + 1] * diff * p[COLOR + 1] + p[KS + 1] * spec * (1.0 + w_metal * (p[COLOR + 1] - 1.0))
    out_b = p[KD + 2] * diff * p[COLOR + 2] + p[KS + 2] * spec * (1.0 + w_metal * (p[COLOR + 2] - 1.0))
    return out_r, out_g, out_b


NOTES = (
    "Shading model made a BRDF by dividing Strauss's intensity by pi cos(theta_i) (cos_i floored "
    "at 1e-6): not reciprocal, not energy-conserving. Seed ks/kd weight the specular/diffuse terms."
)


STRAUSS = declare(globals(), "Strauss (1990)", Traits.ISOTROPIC)
