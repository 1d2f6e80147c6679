"""The compiled kernels of an RGL ``.bsdf`` material: ``eval``, and the luminance warp over the
visible-normal parameterization (Dupuy & Jakob 2018) as ``sample``/``pdf`` with its exact density.

Conventions of the format (as Mitsuba 3's ``measured`` plugin and pbrt-v4's ``MeasuredBxDF`` read it): the
tables are conditioned on one direction — the one a renderer arrives from, our outgoing ``wo`` — and indexed by
the half vector ``m`` of the pair. With ``u(theta) = sqrt(theta / (pi/2))`` and ``u(phi) = (phi + pi) / 2pi``:

* ``vndf``: a warp of ``[0, 1]^2`` onto ``(u(theta_m), u(phi_m))`` (``phi_m`` relative to ``phi_o`` for an
  isotropic material), conditioned on ``(phi_o, theta_o)``; its inverse maps a pair to a point ``s`` of the
  *sample square*, where the spectra are tabulated;
* ``rgb``: the stored value ``S(s)``; the BRDF times ``cos theta_i`` is ``S`` times ``D(m) / (4 sigma(wo))``
  when the file's ``jacobian`` flag is set (``D`` the ``ndf`` table, ``sigma`` the projected-area table), and
  ``S`` itself otherwise;
* ``luminance``: a warp of ``[0, 1]^2`` onto the sample square, applied before the VNDF's, so that a draw
  follows the luminance of ``f cos / pdf_vndf`` — the paper's sampler;
* anisotropic files cover ``phi_o`` in ``[-pi, -pi + 2pi / reduction]``; the pair is mirrored into that range
  first (``reduction`` 2: ``y <= 0``; 4: ``x, y <= 0``).

The whole material is one float64 vector (the kernel parameter vector ``p``): a header of :data:`HEADER`
slots (sizes and offsets, named by the ``H_*`` constants) and the tables, with the warps' cumulative tables
precomputed (:func:`core.rgl.material.kernel_vector` packs it).
"""

from __future__ import annotations

import math

from numba import njit

from core.jit import kernel
from core.rgl.marginal import bilinear, slice_weights, warp_invert, warp_sample

MAGIC = 2018.0
"""``p[0]`` of an RGL kernel vector (any other vector evaluates to 0)."""

H_MAGIC = 0
H_N_PHI = 1
H_N_THETA = 2
H_REDUCTION = 3
H_ISOTROPIC = 4
H_JACOBIAN = 5
H_NDF_W = 6
H_NDF_H = 7
H_SIGMA_W = 8
H_SIGMA_H = 9
H_VNDF_W = 10
H_VNDF_H = 11
H_SAMPLE_W = 12
H_SAMPLE_H = 13
H_OFF_PHI = 14
H_OFF_THETA = 15
H_OFF_NDF = 16
H_OFF_SIGMA = 17
H_OFF_VNDF = 18
H_OFF_VNDF_MARG = 19
H_OFF_VNDF_COND = 20
H_OFF_LUM = 21
H_OFF_LUM_MARG = 22
H_OFF_LUM_COND = 23
H_OFF_RGB = 24
HEADER = 32
# A warp's data, marginal and conditional offsets are consecutive slots, and so are a table's width and height
# (read so by _warp).

PI = math.pi
JACOBIAN_FLOOR = 1e-6
"""Floor of ``2 pi^2 u sin theta_m`` (the ``u -> m`` Jacobian) at the pole, as the reference readers use."""


@njit(inline="always", nogil=True, cache=True)
def _elevation(x, y, z):
    """``theta`` of a unit vector, accurate near the pole (from the chord to the normal)."""
    d = math.sqrt(x * x + y * y + (z - 1.0) * (z - 1.0))
    return 2.0 * math.asin(min(0.5 * d, 1.0))


@njit(inline="always", nogil=True, cache=True)
def _fold(p, wx, wy):
    """Signs that mirror the conditioning direction ``(wx, wy)`` into the file's range of ``phi``. A zero
    counts by its sign bit: ``+0`` flips to ``-0``, so that ``phi_o = 0`` folds to ``-pi`` (``atan2(-0, -x)``),
    the first stored azimuth, and not to ``+pi``, outside the stored range."""
    sx = 1.0
    sy = 1.0
    if p[H_ISOTROPIC] == 0.0:
        reduction = int(p[H_REDUCTION])
        if reduction >= 2:
            sy = -1.0 if math.copysign(1.0, wy) > 0.0 else 1.0
            if reduction == 4:
                sx = -1.0 if math.copysign(1.0, wx) > 0.0 else 1.0
    return sx, sy


@njit(inline="always", nogil=True, cache=True)
def _slices(p, phi_o, theta_o):
    """The blend of the slices around the conditioning direction ``(phi_o, theta_o)``."""
    return slice_weights(
        p, int(p[H_OFF_PHI]), int(p[H_N_PHI]), int(p[H_OFF_THETA]), int(p[H_N_THETA]), phi_o, theta_o
    )


@njit(inline="always", nogil=True, cache=True)
def _warp(p, slot, size_slot):
    """The layout of a warp: ``(off_data, off_marg, off_cond, w, h)`` from its offsets at header slots
    ``slot .. slot + 2`` and its width and height at ``size_slot``, ``size_slot + 1``."""
    return int(p[slot]), int(p[slot + 1]), int(p[slot + 2]), int(p[size_slot]), int(p[size_slot + 1])


@njit(inline="always", nogil=True, cache=True)
def _frame(p, wo, wi):
    """Common part of ``eval`` and ``pdf``: ``(ok, sl, ux_m, uy_m, ux_o, uy_o, sin_m, o_dot_m)``."""
    sx, sy = _fold(p, wo[0], wo[1])
    ox, oy, oz = wo[0] * sx, wo[1] * sy, wo[2]
    ix, iy, iz = wi[0] * sx, wi[1] * sy, wi[2]
    mx, my, mz = ox + ix, oy + iy, oz + iz
    n = math.sqrt(mx * mx + my * my + mz * mz)
    if n == 0.0:
        return False, (0, 0, 0, 0.0, 0.0), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    mx, my, mz = mx / n, my / n, mz / n
    if mz < 0.0:  # wi far below the horizon: the reflection about the upper-hemisphere normal -m (see sample)
        mx, my, mz = -mx, -my, -mz
    theta_o = _elevation(ox, oy, oz)
    phi_o = math.atan2(oy, ox)
    theta_m = _elevation(mx, my, mz)
    phi_m = math.atan2(my, mx)
    if p[H_ISOTROPIC] != 0.0:
        phi_m -= phi_o
    uy_m = (phi_m + PI) / (2.0 * PI)
    uy_m -= math.floor(uy_m)
    ux_m = math.sqrt(theta_m * (2.0 / PI))
    ux_o = math.sqrt(theta_o * (2.0 / PI))
    uy_o = (phi_o + PI) / (2.0 * PI)
    sl = _slices(p, phi_o, theta_o)
    sin_m = math.sqrt(mx * mx + my * my)
    o_dot_m = ox * mx + oy * my + oz * mz
    return True, sl, ux_m, uy_m, ux_o, uy_o, sin_m, o_dot_m


@kernel
def eval_rgl(wi, wo, p):
    """``f_r(wi, wo)`` as RGB from an RGL kernel vector ``p`` (0 below the horizon; stored values clamped at
    0 as pbrt-v4 does)."""
    if wi[2] <= 0.0 or wo[2] <= 0.0 or p.shape[0] < HEADER or p[H_MAGIC] != MAGIC:
        return 0.0, 0.0, 0.0
    ok, sl, ux_m, uy_m, ux_o, uy_o, sin_m, o_dot_m = _frame(p, wo, wi)
    if not ok:
        return 0.0, 0.0, 0.0
    off, marg, cond, vw, vh = _warp(p, H_OFF_VNDF, H_VNDF_W)
    sx, sy, _ = warp_invert(p, off, marg, cond, vw, vh, sl, ux_m, uy_m)
    w = int(p[H_SAMPLE_W])
    h = int(p[H_SAMPLE_H])
    off = int(p[H_OFF_RGB])
    s0, d_phi, d_theta, t_phi, t_theta = sl
    scale = 1.0 / wi[2]
    if p[H_JACOBIAN] != 0.0:
        one = (0, 0, 0, 0.0, 0.0)
        ndf = bilinear(p, int(p[H_OFF_NDF]), int(p[H_NDF_W]), int(p[H_NDF_H]), one, ux_m, uy_m)
        sigma = bilinear(p, int(p[H_OFF_SIGMA]), int(p[H_SIGMA_W]), int(p[H_SIGMA_H]), one, ux_o, uy_o)
        scale *= ndf / (4.0 * sigma) if sigma > 0.0 else 0.0
    r = bilinear(p, off, w, h, (3 * s0, 3 * d_phi, 3 * d_theta, t_phi, t_theta), sx, sy)
    g = bilinear(p, off, w, h, (3 * s0 + 1, 3 * d_phi, 3 * d_theta, t_phi, t_theta), sx, sy)
    b = bilinear(p, off, w, h, (3 * s0 + 2, 3 * d_phi, 3 * d_theta, t_phi, t_theta), sx, sy)
    return max(r * scale, 0.0), max(g * scale, 0.0), max(b * scale, 0.0)


@kernel
def sample_rgl(wo, p, u1, u2, u3):
    """The luminance warp over the VNDF parameterization: ``(x, y, z, pdf_solid_angle)`` for outgoing ``wo``;
    ``pdf = 0`` when nothing could be drawn (``wo`` below the horizon). The density integrates to 1 over the
    sphere (some draws land below the horizon)."""
    if wo[2] <= 0.0 or p.shape[0] < HEADER or p[H_MAGIC] != MAGIC:
        return 0.0, 0.0, 1.0, 0.0
    fx, fy = _fold(p, wo[0], wo[1])
    ox, oy, oz = wo[0] * fx, wo[1] * fy, wo[2]
    theta_o = _elevation(ox, oy, oz)
    phi_o = math.atan2(oy, ox)
    sl = _slices(p, phi_o, theta_o)
    off, marg, cond, lw, lh = _warp(p, H_OFF_LUM, H_SAMPLE_W)
    sx, sy, lum_pdf = warp_sample(p, off, marg, cond, lw, lh, sl, u1, u2)
    off, marg, cond, vw, vh = _warp(p, H_OFF_VNDF, H_VNDF_W)
    ux, uy, vndf_pdf = warp_sample(p, off, marg, cond, vw, vh, sl, sx, sy)
    theta_m = ux * ux * (0.5 * PI)
    phi_m = (2.0 * uy - 1.0) * PI
    if p[H_ISOTROPIC] != 0.0:
        phi_m += phi_o
    st = math.sin(theta_m)
    mx, my, mz = math.cos(phi_m) * st, math.sin(phi_m) * st, math.cos(theta_m)
    o_dot_m = ox * mx + oy * my + oz * mz
    if o_dot_m == 0.0:
        return 0.0, 0.0, 1.0, 0.0
    # A half vector facing away from wo (o.m < 0: the bilinear VNDF spills over the visibility boundary) still
    # reflects wo, to a direction below the horizon (wi.z = 2 (o.m) m.z - o.z < 0) that carries no energy; m
    # is the upper-hemisphere one of +-(wo + wi), so the map stays one-to-one and the density exact.
    jac = max(2.0 * PI * PI * ux * st, JACOBIAN_FLOOR) * 4.0 * abs(o_dot_m)
    pdf = vndf_pdf * lum_pdf / jac
    ix = 2.0 * o_dot_m * mx - ox
    iy = 2.0 * o_dot_m * my - oy
    iz = 2.0 * o_dot_m * mz - oz
    n = math.sqrt(ix * ix + iy * iy + iz * iz)
    return ix / n * fx, iy / n * fy, iz / n, pdf


@kernel
def pdf_rgl(wo, wi, p):
    """The density of :func:`sample_rgl` per unit solid angle at any unit ``wi`` (either hemisphere)."""
    if wo[2] <= 0.0 or p.shape[0] < HEADER or p[H_MAGIC] != MAGIC:
        return 0.0
    ok, sl, ux_m, uy_m, ux_o, uy_o, sin_m, o_dot_m = _frame(p, wo, wi)
    if not ok or o_dot_m == 0.0:
        return 0.0
    off, marg, cond, vw, vh = _warp(p, H_OFF_VNDF, H_VNDF_W)
    sx, sy, vndf_pdf = warp_invert(p, off, marg, cond, vw, vh, sl, ux_m, uy_m)
    lum = bilinear(p, int(p[H_OFF_LUM]), int(p[H_SAMPLE_W]), int(p[H_SAMPLE_H]), sl, sx, sy)
    jac = max(2.0 * PI * PI * ux_m * sin_m, JACOBIAN_FLOOR) * 4.0 * abs(o_dot_m)
    return max(vndf_pdf * lum / jac, 0.0)
