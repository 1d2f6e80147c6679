"""The function a tree approximates: ``g(s) = f(wo, wi(s)) cos(theta_i) pi / (dA/d(omega))`` on the square,
for one *view* of the material.

A view is an outgoing direction as a tree sees it. Trees live in a frame turned so that ``wo`` lies in the
x-z plane, ``wo_tree = (sin theta_o, 0, cos theta_o)``; a view adds the azimuth ``phi_o`` the frame was turned
by, so that ``g_view(s) = f(R(phi) wo_tree, R(phi) wi_tree(s)) ...`` (``R`` the rotation about the normal).
An isotropic BRDF does not see ``phi`` (its trees serve every azimuth); an anisotropic one does, but its lobe
turns with ``phi`` nearly as a whole, so a tree made for one azimuth fits its neighbours' (only the lobe's
shape against the anisotropy's axes changes), and a few azimuth nodes serve the whole circle.

Views are rows of a ``(n, 6)`` array: ``wo`` in the tree frame (3), ``cos phi``, ``sin phi``, and a scale
``1 / c`` that divides ``g`` (the normalizer estimate of the view; bounds are kept on ``g / c``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.dispatch import eval_model
from core.sampling.adaptive.maps import ORTHOGRAPHIC, PI, square_to_direction

LUM_R = 0.2126
LUM_G = 0.7152
LUM_B = 0.0722

RIM_Z = 1e-7
"""Where the orthographic disk's rim (the square's edge) is evaluated: ``f`` just above the horizon."""


@njit(inline="always", nogil=True, cache=True)
def luminance3(r, g, b):
    return LUM_R * r + LUM_G * g + LUM_B * b


def make_view(theta: float, phi: float, scale: float = 1.0) -> np.ndarray:
    """One view row: ``wo`` at polar angle ``theta`` in the tree frame, the frame's azimuth ``phi``."""
    return np.array([math.sin(theta), 0.0, math.cos(theta), math.cos(phi), math.sin(phi), scale])


def make_views(thetas: np.ndarray, phis: np.ndarray) -> np.ndarray:
    """Views ``(len(thetas) * len(phis), 6)`` of every pair, theta-major."""
    rows = [make_view(t, p) for t in np.asarray(thetas, dtype=np.float64) for p in np.asarray(phis)]
    return np.array(rows, dtype=np.float64).reshape(-1, 6)


@njit(nogil=True, cache=True)
def g_at(mid, p, a, b, projection, view):
    """``g`` of the view at square point ``(a, b)`` (not divided by the view's scale).

    Not inlined into its callers: the model switch it holds is then compiled once for all of them (the
    construction's compile time is the switch's, times the number of functions that inline it)."""
    x, y, z, jac = square_to_direction(a, b, projection)
    if projection == ORTHOGRAPHIC:
        if z < RIM_Z:  # the square's edge is the disk's rim: take the limit of f there, not f's 0 below it
            z = RIM_Z
            t = math.sqrt((1.0 - z * z) / max(x * x + y * y, 1e-300))
            x *= t
            y *= t
    elif z <= 0.0 or jac <= 0.0:
        return 0.0
    c = view[3]
    s = view[4]
    wi = (c * x - s * y, s * x + c * y, z)
    wo = (c * view[0] - s * view[1], s * view[0] + c * view[1], view[2])
    r, g, bb = eval_model(mid, wi, wo, p)
    lum = luminance3(r, g, bb)
    if not lum > 0.0:  # also NaN
        return 0.0
    if projection == ORTHOGRAPHIC:
        return PI * lum
    return PI * lum * z / jac
