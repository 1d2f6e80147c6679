"""Continuous marginal warps of bilinear interpolants on ``[0, 1]^2``, linearly interpolated over two
parameters: the one data structure of an RGL ``.bsdf`` material (Dupuy & Jakob 2018), in numba.

A table of ``h x w`` nodes (rows ``y``, columns ``x``, node ``j`` of ``w`` at ``x = j / (w - 1)``) defines a
bilinear interpolant ``g(x, y)``. A **plain** table is read with :func:`bilinear` (the NDF, the projected
area, the spectra). A **warp** table is normalized to integrate to 1 and carries two cumulative tables so
that it can be sampled and inverted in closed form (the continuous variant of a marginal/conditional
scheme, as Mitsuba 3's ``Marginal2D<..., Continuous=true>`` — same mathematics, our code):

``marg[r]``  (``h - 1`` per slice): the mass of the rows below ``y_{r+1}`` (exact for the bilinear ``g``);
``cond[r, c]`` (``h x (w - 1)``): the mass of row ``r``'s piecewise-linear profile left of ``x_{c+1}``.

The conditional CDF at any ``y`` inside a row of patches is the linear interpolation of its two rows' CDFs
(``g`` is linear in ``y`` there), and the marginal density is linear in ``y`` within a patch: both steps
invert a linear density on a segment (:func:`sample_segment`), so the map is continuous and its density is
exactly ``g`` (normalized).

Tables depend on the conditioning direction through two parameters (``phi_i``, ``theta_i``): slices are
stored ``[phi][theta]`` and every value read is the bilinear blend of the four neighbouring slices
(:func:`slice_weights`), tables and CDFs alike — blending normalized slices keeps the total at 1 and the
blended CDFs the CDFs of the blended density, so sampling, inversion and density stay consistent.

Every table lives in one float64 vector ``p`` (the model kernel's parameter vector) at an offset; the layout
is :mod:`core.rgl.lookup`'s. This module holds only compiled kernels: edits here recompile every loop over
BRDFs (see :mod:`core._numba_cache`).
"""

from __future__ import annotations

import math

from numba import njit

EPS = 1e-7
"""Uniforms are kept within ``[EPS, 1 - EPS]`` so that a draw never lands on a zero-mass boundary row."""


@njit(inline="always", nogil=True, cache=True)
def interval(p, off, n, x):
    """The node interval of ``x`` among ``n`` increasing nodes ``p[off : off + n]``: ``(i, t)`` with ``i`` in
    ``[0, n - 2]`` and ``t`` the weight of node ``i + 1``, clamped to ``[0, 1]`` (``(0, 0)`` when ``n == 1``)."""
    if n <= 1:
        return 0, 0.0
    i = 0
    while i < n - 2 and p[off + i + 1] < x:
        i += 1
    a = p[off + i]
    b = p[off + i + 1]
    t = (x - a) / (b - a) if b > a else 0.0
    return i, min(max(t, 0.0), 1.0)


@njit(inline="always", nogil=True, cache=True)
def slice_weights(p, off_phi, n_phi, off_theta, n_theta, phi, theta):
    """The slice blend at parameters ``(phi, theta)``: ``(s0, d_phi, d_theta, t_phi, t_theta)`` with ``s0``
    the lower corner's slice index and ``d_*`` the slice strides to the upper neighbours (0 for a
    parameter with one node)."""
    i_phi, t_phi = interval(p, off_phi, n_phi, phi)
    i_theta, t_theta = interval(p, off_theta, n_theta, theta)
    d_theta = 1 if n_theta > 1 else 0
    d_phi = n_theta if n_phi > 1 else 0
    return i_phi * n_theta + i_theta, d_phi, d_theta, t_phi, t_theta


@njit(inline="always", nogil=True, cache=True)
def blend(p, off, size, sl, k):
    """Element ``k`` of a table of slices of ``size`` values at ``off``, blended over the slices ``sl``."""
    s0, d_phi, d_theta, t_phi, t_theta = sl
    base = off + k
    v00 = p[base + s0 * size]
    v01 = p[base + (s0 + d_theta) * size]
    v10 = p[base + (s0 + d_phi) * size]
    v11 = p[base + (s0 + d_phi + d_theta) * size]
    lo = v00 + t_theta * (v01 - v00)
    hi = v10 + t_theta * (v11 - v10)
    return lo + t_phi * (hi - lo)


@njit(inline="always", nogil=True, cache=True)
def locate(w, h, x, y):
    """The patch of a ``h x w`` table holding ``(x, y)`` (clamped to ``[0, 1]^2``): its column ``c``, row ``r``
    and the fractions ``(tx, ty)`` inside it."""
    x = min(max(x, 0.0), 1.0) * (w - 1)
    y = min(max(y, 0.0), 1.0) * (h - 1)
    c = min(int(x), w - 2)
    r = min(int(y), h - 2)
    return c, r, x - c, y - r


@njit(inline="always", nogil=True, cache=True)
def patch_columns(p, off, w, h, sl, r, c, ty):
    """The table's values on the patch ``(r, c)``'s left and right edges at fraction ``ty`` of its height
    (blended over ``sl``): the interpolant is linear between them in ``x``."""
    size = w * h
    k = r * w + c
    v00 = blend(p, off, size, sl, k)
    v10 = blend(p, off, size, sl, k + 1)
    v01 = blend(p, off, size, sl, k + w)
    v11 = blend(p, off, size, sl, k + w + 1)
    return v00 + ty * (v01 - v00), v10 + ty * (v11 - v10)


@njit(inline="always", nogil=True, cache=True)
def bilinear(p, off, w, h, sl, x, y):
    """The bilinear interpolant of a ``h x w`` table (blended over ``sl``) at ``(x, y)`` in ``[0, 1]^2``."""
    c, r, tx, ty = locate(w, h, x, y)
    c0, c1 = patch_columns(p, off, w, h, sl, r, c, ty)
    return c0 + tx * (c1 - c0)


@njit(inline="always", nogil=True, cache=True)
def sample_segment(u, inv_width, v0, v1):
    """The fraction ``t`` of a segment of width ``1 / inv_width`` whose linear density ``v0 -> v1`` has
    mass ``u`` left of ``t``."""
    # The root of (v1 - v0) t^2 / 2 + v0 t = u / width in the form without cancellation: exact (to rounding)
    # for every slope, so that invert_segment(sample_segment(u)) == u and draws agree with pdf lookups.
    u *= 2.0 * inv_width
    d = v0 + math.sqrt(max(v0 * v0 + u * (v1 - v0), 0.0))
    t = u / d if d > 0.0 else 0.0
    return min(max(t, 0.0), 1.0)


@njit(inline="always", nogil=True, cache=True)
def invert_segment(t, width, v0, v1):
    """The mass left of fraction ``t`` of a segment of ``width`` with linear density ``v0 -> v1``."""
    return t * (v0 + 0.5 * t * (v1 - v0)) * width


@njit(inline="always", nogil=True, cache=True)
def _cond_at(p, off_cond, w, h, sl, r, c, ty):
    """Row ``r``'s conditional CDF at column boundary ``c + 1``, interpolated to ``ty`` towards row ``r + 1``."""
    size = h * (w - 1)
    a = blend(p, off_cond, size, sl, r * (w - 1) + c)
    b = blend(p, off_cond, size, sl, (r + 1) * (w - 1) + c)
    return a + ty * (b - a)


@njit(inline="always", nogil=True, cache=True)
def _row_masses(p, off_cond, w, h, sl, r):
    """The masses of rows ``r`` and ``r + 1`` (their conditional CDFs' last entries)."""
    size = h * (w - 1)
    return blend(p, off_cond, size, sl, r * (w - 1) + w - 2), blend(
        p, off_cond, size, sl, (r + 1) * (w - 1) + w - 2
    )


@njit(inline="always", nogil=True, cache=True)
def warp_sample(p, off_data, off_marg, off_cond, w, h, sl, u1, u2):
    """Warp uniforms ``(u1, u2)`` to ``(x, y, pdf)``: a point of ``[0, 1]^2`` with density ``pdf`` (the
    normalized interpolant there)."""
    u1 = min(max(u1, EPS), 1.0 - EPS)
    u2 = min(max(u2, EPS), 1.0 - EPS)
    n_marg = h - 1
    # Row of patches: the first whose cumulative mass reaches u2.
    lo = 0
    hi = n_marg - 1
    while lo < hi:
        mid = (lo + hi) // 2
        if blend(p, off_marg, n_marg, sl, mid) < u2:
            lo = mid + 1
        else:
            hi = mid
    r = lo
    if r > 0:
        u2 -= blend(p, off_marg, n_marg, sl, r - 1)
    r0, r1 = _row_masses(p, off_cond, w, h, sl, r)
    ty = sample_segment(u2, h - 1.0, r0, r1)
    u1 *= r0 + ty * (r1 - r0)
    lo = 0
    hi = w - 2
    while lo < hi:
        mid = (lo + hi) // 2
        if _cond_at(p, off_cond, w, h, sl, r, mid, ty) < u1:
            lo = mid + 1
        else:
            hi = mid
    c = lo
    if c > 0:
        u1 -= _cond_at(p, off_cond, w, h, sl, r, c - 1, ty)
    c0, c1 = patch_columns(p, off_data, w, h, sl, r, c, ty)
    tx = sample_segment(u1, w - 1.0, c0, c1)
    return (c + tx) / (w - 1.0), (r + ty) / (h - 1.0), c0 + tx * (c1 - c0)


@njit(inline="always", nogil=True, cache=True)
def warp_invert(p, off_data, off_marg, off_cond, w, h, sl, x, y):
    """The inverse of :func:`warp_sample`: the uniforms ``(u1, u2)`` that map to ``(x, y)``, and the density
    there."""
    c, r, tx, ty = locate(w, h, x, y)
    c0, c1 = patch_columns(p, off_data, w, h, sl, r, c, ty)
    pdf = c0 + tx * (c1 - c0)
    u1 = invert_segment(tx, 1.0 / (w - 1.0), c0, c1)
    if c > 0:
        u1 += _cond_at(p, off_cond, w, h, sl, r, c - 1, ty)
    r0, r1 = _row_masses(p, off_cond, w, h, sl, r)
    row_mass = r0 + ty * (r1 - r0)
    u1 = u1 / row_mass if row_mass > 0.0 else 0.0
    u2 = invert_segment(ty, 1.0 / (h - 1.0), r0, r1)
    if r > 0:
        u2 += blend(p, off_marg, h - 1, sl, r - 1)
    return u1, u2, pdf
