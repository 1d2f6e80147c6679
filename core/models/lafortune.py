"""Lafortune's generalized cosine lobe (E. P. F. Lafortune, S.-C. Foo, K. E. Torrance, D. P. Greenberg,
"Non-linear approximation of reflectance functions", SIGGRAPH 1997), one lobe plus a diffuse term.

In the local frame a lobe is a power of a weighted dot product of the two directions,

    f_r(wi, wo) = kd / pi + kp * max(0, cx wi.x wo.x + cy wi.y wo.y + cz wi.z wo.z)^n.

``cx = cy = -1, cz = 1`` gives Phong's lobe about the mirror direction, ``cx = cy > 0`` a retro-reflective
lobe, ``|cx| < |cz|`` an off-specular lobe that moves towards the horizon. The paper absorbs the lobe's
albedo and normalization into the magnitude of ``C``; here ``kp`` (the seed's lobe weight) scales it and
``C`` keeps the shape. The expression is symmetric in ``wi`` and ``wo``: reciprocal. It is isotropic only
when ``cx == cy``, so the trait is not claimed.

Traps handled: the base ``cx wi.x wo.x + ...`` is negative for some directions; with a non-integer ``n``
its power is undefined (NaN), so the base is clamped at 0 (the lobe is zero there, as Phong's
``max(0, cos)``). ``pow(0, 0)`` cannot occur: ``n >= 0.1``. The bounds ``|c| <= 1.1`` and ``n <= 5000``
keep ``|C|^n`` finite (at most ``1.1^5000 ~ 1e207``); fitted lobes have ``|C|`` close to 1.

Sampled by a mixture of a ``cos^n`` lobe about the lobe axis ``normalize(cx wo.x, cy wo.y, cz wo.z)``
(for which ``f_lobe cos(theta_i) / pdf = kp |C wo|^n 2 pi / (n + 1) cos(theta_i)``) and the cosine-weighted
hemisphere.
"""

from __future__ import annotations

import math

from numba import njit

from core.brdf import Param, Traits, declare, param_offsets
from core.geometry import normalize
from core.jit import kernel
from core.models.lobes import (
    cosine_lobe_mixture_pdf,
    cosine_lobe_mixture_sample,
    diffuse_plus_lobe,
    lobe_probability_clamped,
    luminance_at,
)

CITATION = (
    "E. P. F. Lafortune, S.-C. Foo, K. E. Torrance, D. P. Greenberg, Non-linear approximation "
    "of reflectance functions, SIGGRAPH '97, pp. 117-126, 1997."
)

TWO_PI = 6.283185307179586


PARAMS = (
    Param("cx", -1.0, -1.1, 1.1, label="Lobe weight Cx"),
    Param("cy", -1.0, -1.1, 1.1, label="Lobe weight Cy"),
    Param("cz", 1.0, -1.1, 1.1, label="Lobe weight Cz"),
    Param("n", 100.0, 0.1, 5000.0, label="Lobe exponent", log=True),
    Param("kp", (0.96, 0.96, 0.96), 0.0, 1.0, label="Lobe coefficient", kind="color"),
    Param("kd", (0.0, 0.0, 0.0), 0.0, 1.0, label="Diffuse albedo", kind="color"),
)
CX, CY, CZ, N, KP, KD = param_offsets(PARAMS, "cx", "cy", "cz", "n", "kp", "kd")


@kernel
def eval_lafortune(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    base = p[CX] * wi[0] * wo[0] + p[CY] * wi[1] * wo[1] + p[CZ] * wi[2] * wo[2]
    lobe = base ** p[N] if base > 0.0 else 0.0
    return diffuse_plus_lobe(p, KD, KP, lobe)


@njit(inline="always", nogil=True, cache=True)
def _lobe_axis(wo, p):
    """The lobe's axis (unit) and the length ``|C wo|`` of the unnormalized one."""
    ax = p[CX] * wo[0]
    ay = p[CY] * wo[1]
    az = p[CZ] * wo[2]
    length = math.sqrt(ax * ax + ay * ay + az * az)
    return normalize((ax, ay, az)), length


@njit(inline="always", nogil=True, cache=True)
def _lobe_probability(axis, length, p):
    # Estimated lobe albedo: kp |C wo|^n times the integral of (axis.wi)^n cos(theta_i) over the lobe's cap,
    # 2 pi axis.z / (n + 2) when the cap stays above the horizon.
    # The cosine factor is floored at 0.05 so a lobe leaning over the horizon keeps some share.
    n = p[N]
    w_lobe = 0.0
    if length > 0.0:
        w_lobe = luminance_at(p, KP) * length**n * TWO_PI / (n + 2.0) * max(axis[2], 0.05)
    return lobe_probability_clamped(w_lobe, luminance_at(p, KD))


@kernel
def pdf_lafortune(wo, wi, p):
    axis, length = _lobe_axis(wo, p)
    return cosine_lobe_mixture_pdf(axis, p[N], _lobe_probability(axis, length, p), wi)


@kernel
def sample_lafortune(wo, p, u1, u2, u3):
    axis, length = _lobe_axis(wo, p)
    return cosine_lobe_mixture_sample(axis, p[N], _lobe_probability(axis, length, p), u1, u2, u3)


NOTES = (
    "One generalized cosine lobe plus Lambert: f = kd/pi + kp max(0, Cx ux vx + Cy uy vy + "
    "Cz uz vz)^n. A negative base is clamped at 0 (its non-integer power is undefined). kd is not in the "
    "seed's table (default 0, the seed's setting). Anisotropic when cx != cy; not normalized."
)


LAFORTUNE = declare(globals(), "Lafortune (1997)", Traits.RECIPROCAL | Traits.MIRROR_SYMMETRIC)
