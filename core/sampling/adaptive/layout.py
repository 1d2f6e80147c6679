"""Where a material's trees are: nodes over the outgoing direction, their cells, and the normalizer between them.

Nodes sit at polar angles ``thetas`` (and, for an anisotropic BRDF, azimuths ``phis``); each node's tree
serves its *cell*, the outgoing directions nearer to it than to any other node (in theta, and in phi). The
seed stored one tree per incident angle; a fixed grid of 1-degree bins (104 with the horizon's, 1 872 for an
anisotropic BRDF) made building a material slow. Here the layout is made per material: it starts coarse and
an interval is halved only where the material asks for it (:mod:`core.sampling.adaptive.table`):

- the rejection-free density of a node, used at its cell's edge, would have a relative variance (chi^2)
  above ``warp_chi2`` (the lobe moves or changes too much across the cell);
- a node's envelope cannot reach the acceptance ``1/n_max`` over its cell;
- the normalizer ``I(wo)`` would not be interpolated between the nodes to ``norm_tol``.

Symmetry (the frame the trees are kept in, :mod:`core.sampling.adaptive.target`):

========== ============================================= =================================================
ISOTROPIC  ``f`` is invariant under rotation about the    one azimuth node; ``wo`` is turned to ``phi = 0``
           normal (trait, or measured numerically)
MIRROR     also under mirroring both directions in the    azimuth nodes over ``[0, pi/2]``; ``wo`` is folded
           x-z and the y-z planes (trait)                  into that quadrant and the draw unfolded
FULL       anything else                                  azimuth nodes over the whole circle
========== ============================================= =================================================

The normalizer (the exact mode's ``I(wo)``) is interpolated from the nodes' integrals: a cubic through the
four nearest nodes in ``s = -log(cos theta)`` (Lagrange, on the non-uniform layout), tabulated once at
``cos theta`` spaced by octaves (read linearly, no logarithm), and in phi the cosine series in ``2 phi`` through the quadrant's equally spaced nodes (MIRROR:
``I`` is even about 0 and pi/2) or a periodic cubic (FULL).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

ISOTROPIC = 0
MIRROR = 1
FULL = 2
SYMMETRIES = ("isotropic", "mirror", "full")

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi

THETA_END = math.radians(89.9)
"""The last node. Beyond it the exact mode draws the cosine density (every model's ``I(wo)`` tends to 0 at the
horizon, and the rejection-free mode goes on with the last node's tree)."""

INITIAL_THETAS_DEG = (0.0, 30.0, 55.0, 72.0, 82.0, 87.0, 89.9)
"""The layout a material starts from (coarse; denser toward the horizon, where lobes change fastest): a
Lambertian material keeps it, a glossy one has its intervals halved where it asks."""


def phi_nodes(symmetry: int, count: int) -> np.ndarray:
    """Equally spaced azimuth nodes: ``[0]`` (isotropic), ``count`` over ``[0, pi/2]`` ends included
    (mirror), ``count`` over ``[0, 2 pi)`` (full)."""
    if symmetry == ISOTROPIC:
        return np.zeros(1)
    if symmetry == MIRROR:
        return np.linspace(0.0, HALF_PI, max(int(count), 2))
    return np.arange(int(count)) * (TWO_PI / int(count))


def cell_edges(nodes: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """``(len(nodes) + 1,)`` edges of the cells of sorted ``nodes`` within ``[lo, hi]`` (midpoints inside)."""
    mids = 0.5 * (nodes[1:] + nodes[:-1])
    return np.concatenate([[lo], mids, [hi]])


# ------------------------------------------------------------------------------------------ normalizer
def series_coefficients(values: np.ndarray) -> np.ndarray:
    """Coefficients ``a_m`` of ``sum_m a_m cos(2 m phi)`` through ``values (..., J)`` at ``J`` equally spaced
    azimuths over ``[0, pi/2]`` (ends included): the DCT-I of the values."""
    values = np.asarray(values, dtype=np.float64)
    j = values.shape[-1]
    if j == 1:
        return values.copy()
    n = j - 1
    k = np.arange(j)
    w = np.ones(j)
    w[0] = w[-1] = 0.5
    basis = np.cos(np.pi * np.outer(k, k) / n)  # [m, node]
    coef = (values * w) @ basis.T * (2.0 / n)
    coef[..., 0] *= 0.5
    coef[..., -1] *= 0.5
    return coef


@njit(inline="always", nogil=True, cache=True)
def _periodic_cubic(table, row, frac, phi):
    """Cubic Lagrange interpolation at ``phi`` through values at equally spaced azimuths over the whole
    circle: the values ``table[row] + frac (table[row + 1] - table[row])`` (a row of the normalizer's table
    read linearly in ``cos theta``), formed where they are needed (no array: the draws' kernels allocate
    nothing, :mod:`core.jit`)."""
    j = table.shape[1]
    if j == 1:
        return table[row, 0] + frac * (table[row + 1, 0] - table[row, 0])
    t = phi / TWO_PI * j
    i = int(math.floor(t))
    x = t - i
    s = 0.0
    for a in range(-1, 3):
        w = 1.0
        for b in range(-1, 3):
            if b != a:
                w *= (x - b) / (a - b)
        k = (i + a) % j
        s += w * (table[row, k] + frac * (table[row + 1, k] - table[row, k]))
    return s


@njit(inline="always", nogil=True, cache=True)
def locate(edges_or_nodes, x):
    """Index ``k`` with ``a[k] <= x < a[k + 1]`` in sorted ``a`` (clamped to ``[0, len(a) - 2]``)."""
    lo = 0
    hi = edges_or_nodes.shape[0] - 1
    if x <= edges_or_nodes[0]:
        return 0
    if x >= edges_or_nodes[hi]:
        return hi - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if edges_or_nodes[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


def norm_coordinate(theta: np.ndarray | float) -> np.ndarray:
    """``s = -log(cos theta)``, the coordinate the normalizer is interpolated in (see
    :func:`normalizer_at`)."""
    return -np.log(np.cos(np.asarray(theta, dtype=np.float64)))


NORM_OCTAVES = 10
"""Octaves of ``cos theta`` the normalizer's table spans: ``[2^-10, 1]``, which holds ``cos(THETA_END)``
(1.7e-3)."""
NORM_STEPS = 256
"""Rows of the normalizer's table per octave: ``cos theta = 2^e (1 + k / NORM_STEPS)``, so that neighbouring
rows are at most ``1 / NORM_STEPS`` apart relative to ``cos theta`` (``dcos / cos = ds``: as fine as a
uniform step of 0.0039 in ``s``, and finest where ``I(theta)`` changes fastest, at the horizon)."""
NORM_ROWS = NORM_OCTAVES * NORM_STEPS + 1
"""The last row is ``cos theta = 1``."""
NORM_MU_MIN = 2.0**-NORM_OCTAVES


def normalizer_grid() -> np.ndarray:
    """``(NORM_ROWS,)``: the ``cos theta`` of the normalizer table's rows (:func:`normalizer_at`)."""
    octave = np.repeat(np.arange(NORM_OCTAVES) - NORM_OCTAVES, NORM_STEPS)
    step = np.tile(np.arange(NORM_STEPS), NORM_OCTAVES)
    return np.append(np.ldexp(1.0 + step / NORM_STEPS, octave), 1.0)


def normalizer_table(thetas: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The table ``(NORM_ROWS, J)`` of the cubic interpolant through the nodes' ``values (K, J)`` (Lagrange
    through the four nearest nodes, in ``s = -log cos theta``) at the ``cos theta`` of
    :func:`normalizer_grid`; :func:`normalizer_at` reads it linearly in ``cos theta``: no logarithm, no search,
    two rows. The rows below ``cos(THETA_END)`` (no view reads them: the exact mode draws the cosine density
    there) continue the line from the row above through the last node's value, so that the interval holding
    ``THETA_END`` reads the last node's value there."""
    mu = normalizer_grid()
    s_end = float(norm_coordinate(THETA_END))
    s = np.minimum(-np.log(mu), s_end)
    out = _lagrange_rows(norm_coordinate(thetas), values, s)
    below = mu < math.cos(THETA_END)
    if np.any(below):
        r = int(np.flatnonzero(below)[-1])  # the row below the last node; r + 1 is above it
        end = _lagrange_rows(norm_coordinate(thetas), values, np.array([s_end]))[0]
        mu_end = math.cos(THETA_END)
        slope = (out[r + 1] - end) / (mu[r + 1] - mu_end)
        out[below] = end + slope * (mu[r] - mu_end)
    return out


def _lagrange_rows(nodes: np.ndarray, values: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """``(len(xs), J)``: at each ``x``, the Lagrange interpolant through the (up to) four nodes nearest to it
    (the interval holding ``x`` and one on each side, shifted inside at the ends). All rows at once: this runs
    once per table, on the thread that builds it, and a loop over the rows in Python held the interpreter for
    ~0.1 s a table."""
    k = len(nodes)
    if k == 1:
        return np.repeat(values[:1], len(xs), axis=0)
    i = np.clip(np.searchsorted(nodes, xs, side="right") - 1, 0, k - 2)
    first = np.minimum(np.maximum(i - 1, 0), max(k - 4, 0))
    m = min(4, k)
    idx = first[:, None] + np.arange(m)[None, :]
    at = nodes[idx]
    out = np.zeros((len(xs), values.shape[1]))
    for a in range(m):
        w = np.ones(len(xs))
        for b in range(m):
            if b != a:
                w *= (xs - at[:, b]) / (at[:, a] - at[:, b])
        out += w[:, None] * values[idx[:, a]]
    return out


def _lagrange_weight(nodes: np.ndarray, idx: Sequence[int], a: int, x: float) -> float:
    """The weight of node ``a`` in the Lagrange interpolant through the nodes ``idx``, at ``x``."""
    w = 1.0
    for b in idx:
        if b != a:
            w *= (x - nodes[b]) / (nodes[a] - nodes[b])
    return w


@njit(inline="always", nogil=True, cache=True)
def _norm_row(rows, cos_theta):
    """The row of the normalizer's table at or below ``cos_theta`` and the fraction of the way to the next:
    ``cos theta = 2^e m`` with ``m`` in ``[1, 2)`` is octave ``e`` and step ``(m - 1) NORM_STEPS`` (exact: a
    power-of-two scale). Below the table, and for NaN, its first row; at or above 1, its last."""
    if not cos_theta >= NORM_MU_MIN:
        return 0, 0.0
    m, e = math.frexp(cos_theta)  # cos_theta = m 2^e, m in [1/2, 1)
    x = (2.0 * m - 1.0) * NORM_STEPS
    k = int(x)
    row = (e - 1 + NORM_OCTAVES) * NORM_STEPS + k
    if row >= rows - 1:
        return rows - 2, 1.0
    return row, x - k


@njit(inline="always", nogil=True, cache=True)
def normalizer_at(symmetry, table, log_scale, cos_theta, c, s):
    """``I`` at ``(theta, phi)`` from the ``table`` of :func:`normalizer_table`, ``(c, s)`` the unit vector
    of ``phi`` (folded into the layout's range; ignored when isotropic): linear in ``cos theta`` between the
    two rows around it, then, for MIRROR, the cosine series in ``2 phi`` (``cos 2 phi = c^2 - s^2`` and its
    Chebyshev recurrence: no trigonometry), for FULL the periodic cubic through the row's azimuths;
    ``exp`` of that when the table holds ``log I`` (``log_scale``). An isotropic table holds ``I`` itself
    (:func:`~core.sampling.adaptive.table._norm_table`): no logarithm and no exponential at run time (a
    Catmull-Rom cubic in ``s = -log cos theta`` of ``log I`` takes ~35 ns a view, ~65 ns with the azimuth's
    arc tangent and cosine)."""
    i, t = _norm_row(table.shape[0], cos_theta)
    j = table.shape[1]
    if symmetry == ISOTROPIC:
        v = table[i, 0] + t * (table[i + 1, 0] - table[i, 0])
    elif symmetry == MIRROR:
        c2 = c * c - s * s
        prev = 1.0
        cur = c2
        v = 0.0
        for k in range(j):
            coef = table[i, k] + t * (table[i + 1, k] - table[i, k])
            if k == 0:
                v += coef
            else:
                v += coef * cur
                nxt = 2.0 * c2 * cur - prev
                prev = cur
                cur = nxt
    else:
        phi = math.atan2(s, c)
        if phi < 0.0:
            phi += TWO_PI
        v = _periodic_cubic(table, i, t, phi)
    return math.exp(v) if log_scale else v


def interpolation_errors(coords: np.ndarray, values: np.ndarray) -> np.ndarray:
    """For each node, the error of predicting its value from the other nodes (cubic through the nearest
    four), scaled to the spacing of the layout itself (``/ 8``: a cubic's error at the middle of its nodes'
    interval against at a node skipped between them, ``(1/2)(1/2)(3/2)(3/2) = 9/16`` against ``2 * 1 * 1 * 2``).

    ``coords, values (K,)`` (as :func:`normalizer_at` interpolates: ``log I`` errors are relative already);
    returns ``(K,)``; the first and last nodes get 0."""
    thetas = coords
    k = len(thetas)
    out = np.zeros(k)
    if k < 5:
        return out
    for i in range(1, k - 1):
        others = [j for j in range(k) if j != i]
        near = sorted(others, key=lambda j: abs(thetas[j] - thetas[i]))[:4]
        near.sort()
        x = thetas[i]
        pred = sum(_lagrange_weight(thetas, near, a, x) * values[a] for a in near)
        out[i] = abs(pred - values[i]) / 8.0
    return out
