"""The function a tree approximates: ``g(s) = f(wo, wi(s)) cos(theta_i) pi / (dA/d(omega))`` on the square,
for one *view* of the material.

A view is an outgoing direction as a tree sees it. Trees live in a frame turned so that ``wo`` lies in the
x-z plane, ``wo_tree = (sin theta_o, 0, cos theta_o)``; a view adds the azimuth ``phi_o`` the frame was turned
by, so that ``g_view(s) = f(R(phi) wo_tree, R(phi) wi_tree(s)) ...`` (``R`` the rotation about the normal).
An isotropic BRDF does not see ``phi`` (its trees serve every azimuth); an anisotropic one does, but its lobe
turns with ``phi`` nearly as a whole, so a tree made for one azimuth fits its neighbours' (only the lobe's
shape against the anisotropy's axes changes), and a few azimuth nodes serve the whole circle.

Views are rows of a ``(n, 6)`` array: ``wo`` in the tree frame (3), ``cos phi``, ``sin phi`` (the frame's
turn; 1 and 0 for trees kept in the local frame, as half-vector trees of anisotropic BRDFs are: their lobe
does not turn with ``wo``), and 1 (unused).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.dispatch import eval_model
from core.jit import kernel
from core.sampling.adaptive.maps import HALF_VECTOR, ORTHOGRAPHIC, PI, RIM, square_to_direction

LUM_R = 0.2126
LUM_G = 0.7152
LUM_B = 0.0722

RIM_Z = 1e-5
"""Where the square's edge (the disk's rim, the horizon) is evaluated: ``cos(theta) = 1e-5``. Several models
keep ``f cos`` finite and positive up to the horizon (Phong, Schlick), and some floor a ``1 / cos`` within
1e-6 of it; ``g`` at the rim is their limit, not the 0 of ``f`` below the horizon (which made every leaf along
the rim look discontinuous)."""


@njit(inline="always", nogil=True, cache=True)
def luminance3(r, g, b):
    return LUM_R * r + LUM_G * g + LUM_B * b


def make_view(theta: float, phi: float, follow: bool = True) -> np.ndarray:
    """One view row: ``wo`` at polar angle ``theta`` in the tree frame, the frame turned by the azimuth
    ``phi`` (``follow``); or, for a tree kept in the local frame, ``wo`` at ``(theta, phi)`` itself."""
    if follow:
        return np.array([math.sin(theta), 0.0, math.cos(theta), math.cos(phi), math.sin(phi), 1.0])
    st = math.sin(theta)
    return np.array([st * math.cos(phi), st * math.sin(phi), math.cos(theta), 1.0, 0.0, 1.0])


@njit(inline="always", nogil=True, cache=True)
def square_point(a, b, projection):
    """``(x, y, z, w)``: the tree-frame direction of square point ``(a, b)`` (``wi``, or ``h`` for
    HALF_VECTOR) and the factor ``w`` with ``g = w f_lum`` there (``pi`` on the orthographic disk, ``2 pi cos``
    on the equal-area one, ``4 pi cos^1.5`` on the rim disk; for HALF_VECTOR ``2 pi``, the rest depends on
    ``wo``: see :func:`g_dir`)."""
    x, y, z, jac = square_to_direction(a, b, projection)
    if z < RIM_Z:  # the square's edge is the horizon: take the limit of g there, not f's 0 below it
        z = RIM_Z
        t = math.sqrt((1.0 - z * z) / max(x * x + y * y, 1e-300))
        x *= t
        y *= t
    if projection == ORTHOGRAPHIC:
        return x, y, z, PI
    if projection == HALF_VECTOR:
        return x, y, z, PI / jac
    if projection == RIM:  # pi cos / (dA/d(omega)) = 4 pi cos^1.5, also at the clamped rim
        return x, y, z, 4.0 * PI * z * math.sqrt(z)
    return x, y, z, PI * z / jac


@kernel
def g_dir(mid, p, x, y, z, w, view, projection):
    """``g`` of the view at the tree-frame direction ``(x, y, z)`` with factor ``w`` (see
    :func:`square_point`); not divided by the view's scale. For HALF_VECTOR the direction is the half vector
    ``h``, ``wi = 2 (wo.h) h - wo`` and ``g = w f_lum cos(theta_i) 4 (wo.h)``.

    Not inlined into its callers: the model switch it holds is then compiled once for all of them (the
    construction's compile time is the switch's, times the number of functions that inline it)."""
    if w <= 0.0:
        return 0.0
    c = view[3]
    s = view[4]
    wi = (c * x - s * y, s * x + c * y, z)
    wo = (c * view[0] - s * view[1], s * view[0] + c * view[1], view[2])
    if projection == HALF_VECTOR:
        d = wo[0] * wi[0] + wo[1] * wi[1] + wo[2] * wi[2]  # wi holds h here
        wz = 2.0 * d * wi[2] - wo[2]
        if d <= 0.0 or wz <= 0.0:
            return 0.0
        w *= 4.0 * d * wz
        wi = (2.0 * d * wi[0] - wo[0], 2.0 * d * wi[1] - wo[1], wz)
    r, g, bb = eval_model(mid, wi, wo, p)
    lum = luminance3(r, g, bb)
    if not lum > 0.0:  # also NaN
        return 0.0
    return w * lum


@njit(inline="always", nogil=True, cache=True)
def g_at(mid, p, a, b, projection, view):
    """``g`` of the view at square point ``(a, b)`` (not divided by the view's scale)."""
    x, y, z, w = square_point(a, b, projection)
    return g_dir(mid, p, x, y, z, w, view, projection)
