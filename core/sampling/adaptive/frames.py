"""Where a view's tree is and how its square is turned: the symmetries' folds, the polar and azimuth cells
of ``wo``, and the frames between the local frame and a tree's (inlined into the draws,
:mod:`core.sampling.adaptive.draw`)."""

from __future__ import annotations

import math

from numba import njit

from core.sampling.adaptive.layout import FULL, ISOTROPIC, MIRROR, TWO_PI


@njit(inline="always", nogil=True, cache=True)
def _fold(symmetry, wx, wy):
    """``(cos, sin, sx, sy)``: ``wo``'s azimuth as a unit vector (folded into the quadrant when
    mirror-symmetric) and the mirror signs; no trigonometry."""
    sx = 1.0
    sy = 1.0
    if symmetry == MIRROR:
        if wx < 0.0:
            sx = -1.0
        if wy < 0.0:
            sy = -1.0
        wx = abs(wx)
        wy = abs(wy)
    rho = math.sqrt(wx * wx + wy * wy)
    if rho > 0.0:
        inv = 1.0 / rho
        return wx * inv, wy * inv, sx, sy
    return 1.0, 0.0, sx, sy


@njit(inline="always", nogil=True, cache=True)
def _azimuth(symmetry, c, s):
    """The azimuth of :func:`_fold`'s unit vector (``[0, pi/2]`` folded, ``[0, 2 pi)`` else; 0 when
    isotropic, where nothing reads it)."""
    if symmetry == ISOTROPIC:
        return 0.0
    phi = math.atan2(s, c)
    if phi < 0.0:
        phi += TWO_PI
    return phi


@njit(inline="always", nogil=True, cache=True)
def _frame(symmetry, wx, wy, wz):
    """``(mu, phi, cos, sin, sx, sy)``: ``-cos theta``, the azimuth the trees see (folded into the quadrant
    when mirror-symmetric; 0 for an isotropic table, which does not need it), the rotation to the tree frame
    and the mirror signs (:func:`_fold` and :func:`_azimuth`; for :mod:`~core.sampling.adaptive.inspect`)."""
    c, s, sx, sy = _fold(symmetry, wx, wy)
    return -wz, _azimuth(symmetry, c, s), c, s, sx, sy


@njit(inline="always", nogil=True, cache=True)
def _phi_cell(symmetry, phis, edge_cos, edge_sin, c, s):
    """The azimuth node whose cell holds the azimuth of unit vector ``(c, s)``: for a mirror-symmetric table
    the count of inner cell edges ``e`` at or below it, ``sin(phi - e) >= 0`` (``phi - e`` within
    ``[-pi/2, pi/2]``), no arc tangent."""
    j = phis.shape[0]
    if symmetry == ISOTROPIC or j == 1:
        return 0
    if symmetry == FULL:
        return int(math.floor(_azimuth(symmetry, c, s) / TWO_PI * j + 0.5)) % j
    k = 0
    for e in range(1, j):
        if s * edge_cos[e] - c * edge_sin[e] >= 0.0:
            k = e
    return k


# The kernels take the table (a tuple of arrays) and hand the functions they call per row only the arrays
# they need: a table passed to a function inlined by numba is copied with a reference count taken and dropped
# on every array (~50 ns a call), and to one that is not, copied by value (~120 ns): handed only its arrays,
# the tree lookup per row takes 4 ns instead of 56, and a rejection-free draw of Phong with f half the time
# (the row loops written out, :func:`sample_rows`).
@njit(inline="always", nogil=True, cache=True)
def _tree_frame(symmetry, follow, cell_lut, cell_mu, phis, edge_cos, edge_sin, wx, wy, wz):
    """The tree serving ``wo`` and its frame: ``(t, cos, sin, sx, sy, cos_o, sin_o)``, the last two
    ``wo``'s folded azimuth (:func:`_fold`; the frame's turn is ``(1, 0)`` for a tree kept in the local
    frame)."""
    c, s, sx, sy = _fold(symmetry, wx, wy)
    t = _theta_cell(cell_lut, cell_mu, -wz) * phis.shape[0] + _phi_cell(
        symmetry, phis, edge_cos, edge_sin, c, s
    )
    if follow[t] == 0:
        return t, 1.0, 0.0, sx, sy, c, s
    return t, c, s, sx, sy, c, s


@njit(inline="always", nogil=True, cache=True)
def _reflect(hx, hy, hz, wx, wy, wz):
    """``wi = 2 (wo.h) h - wo`` and ``wo.h``."""
    d = hx * wx + hy * wy + hz * wz
    return 2.0 * d * hx - wx, 2.0 * d * hy - wy, 2.0 * d * hz - wz, d


@njit(inline="always", nogil=True, cache=True)
def _to_local(x, y, z, c, s, sx, sy):
    return sx * (c * x - s * y), sy * (s * x + c * y), z


@njit(inline="always", nogil=True, cache=True)
def _to_tree(wx, wy, wz, c, s, sx, sy):
    x = sx * wx
    y = sy * wy
    return c * x + s * y, -s * x + c * y, wz


@njit(inline="always", nogil=True, cache=True)
def _theta_cell(cell_lut, cell_mu, mu):
    """The polar node whose cell holds ``mu = -cos theta``."""
    n = cell_lut.shape[0]
    k = cell_lut[min(max(int((mu + 1.0) * n), 0), n - 1)]
    last = cell_mu.shape[0] - 2
    while k < last and mu >= cell_mu[k + 1]:
        k += 1
    return k
