"""A tree's records and what is done to one node: its stencil, its rules, its split.

The compiled steps pass the tree's arrays as records (structures of arrays, like a wavefront's work items):

- :class:`Target`: what ``g`` is evaluated from (the model's dispatch id, its parameters, the square's
  projection);
- :class:`Nodes`: the nodes in creation order and their stencils at the node's own view;
- :class:`CellViews`: the views of the cell a tree serves, the mixture's weights and the views' scales;
- :class:`Normalizer`: the exact mode's normalizer as the draws read it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from core.jit import kernel
from core.sampling.adaptive.maps import HALF_VECTOR, direction_to_square
from core.sampling.adaptive.target import g_at

FLOOR = 1e-3
"""Share of the normalizer spread evenly over the square as the rejection-free density's floor: a feature
that the stencils missed still gets a positive density (unbiased estimates), at 0.1 % of the samples."""

SIMPSON = np.array([1.0, 4.0, 1.0, 4.0, 16.0, 4.0, 1.0, 4.0, 1.0]) / 36.0
CORNERS = (0, 2, 6, 8)

NEW_POINTS = (5, 4, 4, 3)
"""Stencil points child ``q`` evaluates: its corners are its parent's points, and the middles of the edges
inside the parent are its earlier siblings' (16 new points a split, not 20)."""

SPLIT_EVALUATIONS = 16


class Target(NamedTuple):
    """What ``g`` (:func:`core.sampling.adaptive.target.g_at`) is evaluated from."""

    mid: int
    """The model's dispatch id."""
    p: np.ndarray
    """Its kernel parameter vector."""
    projection: int
    """The square's map (:mod:`core.sampling.adaptive.maps`)."""


class Nodes(NamedTuple):
    """A tree's nodes in creation order (the root is 0; a node's four children are contiguous, ordered
    ``(x0, y0), (x0 + h, y0), (x0, y0 + h), (x0 + h, y0 + h)``), room for ``len(child)`` of them."""

    child: np.ndarray
    """int32: index of the first of a node's four children, or ``-1`` for a leaf (``-1 - leaf`` once the
    leaves are numbered)."""
    x0: np.ndarray
    """float64: the node's lower-left corner on the square."""
    y0: np.ndarray
    level: np.ndarray
    """int32: depth (side ``2^-level``)."""
    st: np.ndarray
    """``(room, 9)``: ``g`` at the node view on each node's stencil."""


class CellViews(NamedTuple):
    """The views of a tree's cell (view 0 is the node itself; the others span the cell)."""

    views: np.ndarray
    """``(v, 6)`` view rows (:func:`core.sampling.adaptive.target.make_view`)."""
    weights: np.ndarray
    """``(v,)``: the views' weights in the cell's mixture."""
    scales: np.ndarray
    """``(v,)``: ``1 / I_v``, each view's integral on the tree's stencils (the mixture's normalization)."""
    bscales: np.ndarray
    """``(v,)``: ``1 / c_v`` as the bounds take it (0 for a tree without bounds)."""
    angles: np.ndarray
    """``(v, 2)``: each view's ``(theta, phi)``."""


class Normalizer(NamedTuple):
    """The exact mode's normalizer (:func:`core.sampling.adaptive.tree.bounds.inv_norm`)."""

    table: np.ndarray
    meta: np.ndarray
    """``(symmetry, log)``."""


@njit(inline="always", nogil=True, cache=True)
def _point(x0, y0, h, k):
    """Square coordinates of stencil point ``k`` of the node ``(x0, y0, h)``."""
    return x0 + 0.5 * h * (k % 3), y0 + 0.5 * h * (k // 3)


@kernel
def _stencil(tg, view, x0, y0, h, out):
    for k in range(9):
        a, b = _point(x0, y0, h, k)
        out[k] = g_at(tg.mid, tg.p, a, b, tg.projection, view)


@njit(inline="always", nogil=True, cache=True)
def _shared_point(q, k):
    """``(sibling, k')``: stencil point ``k`` of child ``q`` is point ``k'`` of the earlier child ``sibling``
    (the middles of the edges inside the parent, each shared by two children), or ``(-1, -1)``."""
    if q == 1 and k == 3:
        return 0, 5
    if q == 2 and k == 1:
        return 0, 7
    if q == 3 and k == 1:
        return 1, 7
    if q == 3 and k == 3:
        return 2, 5
    return -1, -1


@kernel
def _child_stencil(tg, view, st, parent, first, q, x0, y0, h):
    """The stencil of child ``q`` (node ``first + q``) from its parent's corners, its earlier siblings'
    shared points (:func:`_shared_point`) and new evaluations."""
    qi = q % 2
    qj = q // 2
    out = st[first + q]
    for k in range(9):
        i = k % 3
        j = k // 3
        if i % 2 == 0 and j % 2 == 0:
            out[k] = st[parent, (qj + j // 2) * 3 + qi + i // 2]
            continue
        sib, ks = _shared_point(q, k)
        if sib >= 0:
            out[k] = st[first + sib, ks]
        else:
            a, b = _point(x0, y0, h, k)
            out[k] = g_at(tg.mid, tg.p, a, b, tg.projection, view)


@njit(inline="always", nogil=True, cache=True)
def _bilinear_at_stencil(st, k, floor):
    """The bilinear interpolant of the stencil's corners (each plus ``floor``) at stencil point ``k``."""
    i = k % 3
    j = k // 3
    tx = 0.5 * i
    ty = 0.5 * j
    return (
        (1.0 - tx) * (1.0 - ty) * (st[0] + floor)
        + tx * (1.0 - ty) * (st[2] + floor)
        + (1.0 - tx) * ty * (st[6] + floor)
        + tx * ty * (st[8] + floor)
    )


@njit(inline="always", nogil=True, cache=True)
def _on_diagonal(x0, y0, h):
    """Whether a diagonal of the square crosses the node (along the node's own diagonal): there the
    concentric map, hence ``g``, has a kink."""
    return x0 == y0 or x0 + y0 + h == 1.0


@kernel
def _rule(st, x0, y0, h):
    """The integral of ``g`` over the node from its stencil: Simpson's rule, or where a diagonal of the square
    crosses the node, the quadratic rule on each of the two triangles it makes (their edges' midpoints are
    stencil points), which the kink along the diagonal does not spoil."""
    area = h * h
    if _on_diagonal(x0, y0, h):
        return area / 6.0 * (st[1] + st[3] + st[5] + st[7] + 2.0 * st[4])
    s = 0.0
    for k in range(9):
        s += SIMPSON[k] * st[k]
    return s * area


@kernel
def _trapezoids(st, area):
    """The four quarter-squares' trapezoid rules (what the stencil gives without Simpson's weights)."""
    s = st[0] + st[2] + st[6] + st[8] + 2.0 * (st[1] + st[3] + st[5] + st[7]) + 4.0 * st[4]
    return s * area / 16.0


@kernel
def _warp_error(st, area, floor):
    """``int_L (g - q)^2 / q`` by Simpson's rule on the stencil (``q`` the corners' bilinear interpolant)."""
    e = 0.0
    for k in range(9):
        if k == 0 or k == 2 or k == 6 or k == 8:
            continue
        q = _bilinear_at_stencil(st, k, floor)
        d = st[k] + floor - q
        e += SIMPSON[k] * d * d / q
    return e * area


@kernel
def _children(nodes, i, n):
    """Make nodes ``n .. n + 3`` the children of leaf ``i`` (their squares and levels); returns their side."""
    child, x0, y0, level = nodes.child, nodes.x0, nodes.y0, nodes.level
    h = 0.5 ** (level[i] + 1)
    child[i] = n
    for q in range(4):
        c = n + q
        x0[c] = x0[i] + h * (q % 2)
        y0[c] = y0[i] + h * (q // 2)
        level[c] = level[i] + 1
        child[c] = -1
    return h


@kernel
def _split(tg, view, nodes, i, n):
    """Split leaf ``i`` into nodes ``n .. n + 3`` (node-view stencils included); returns the new count."""
    h = _children(nodes, i, n)
    for q in range(4):
        _child_stencil(tg, view, nodes.st, i, n, q, nodes.x0[n + q], nodes.y0[n + q], h)
    return n + 4


@njit(nogil=True, cache=True)
def _split_worst(tg, view, nodes, errs, excess, max_level, n):
    """Split the leaves with the largest ``errs`` until their errors add up to ``excess`` (as room and depth
    allow); returns ``(nodes, leaves split, evaluations)``."""
    child, level = nodes.child, nodes.level
    cap = child.shape[0]
    order = np.argsort(-errs[:n])
    removed = 0.0
    split = 0
    evals = 0
    for r in range(order.shape[0]):
        i = order[r]
        if removed >= excess or errs[i] <= 0.0 or n + 4 > cap:
            break
        if child[i] != -1 or level[i] >= max_level:
            continue
        n = _split(tg, view, nodes, i, n)
        evals += SPLIT_EVALUATIONS
        removed += errs[i]
        split += 1
    return n, split, evals


@kernel
def _leaf_holding(nodes, a, b):
    """The leaf (node index) holding square point ``(a, b)``."""
    child, x0, y0, level = nodes.child, nodes.x0, nodes.y0, nodes.level
    i = 0
    while child[i] >= 0:
        c = child[i]
        h = 0.5 ** (level[i] + 1)
        i = c + int(a >= x0[i] + h) + 2 * int(b >= y0[i] + h)
    return i


@njit(inline="always", nogil=True, cache=True)
def _mirror_point(view, projection):
    """The square point of the view's mirror direction (the normal, for half-vector trees)."""
    if projection == HALF_VECTOR:
        return 0.5, 0.5
    a, b, _ = direction_to_square(-view[0], -view[1], view[2], projection)
    return a, b


@kernel
def _mixture(stv_i, scales, weights, x0, y0, h, out):
    """The cell's mixture on a node's stencil: ``sum_v w_v g_v / I_v`` (it integrates to 1), its corners on
    the square's edge lifted (:func:`_rim_lift`)."""
    for k in range(9):
        acc = 0.0
        for v in range(weights.shape[0]):
            acc += weights[v] * stv_i[v, k] * scales[v]
        out[k] = acc
    _rim_lift(out, x0, y0, h)


@njit(inline="always", nogil=True, cache=True)
def _rim_lift(mix, x0, y0, h):
    """On the square's edge (the horizon) a corner takes at least the value half a leaf inward. Where ``g``
    vanishes at the horizon like ``cos^k`` with ``k < 1`` (Minnaert's), the bilinear interpolant of the true
    corner values falls below it by a factor that grows without bound toward the rim, and no envelope
    ``K q`` could cover ``g`` there; lifted, ``q`` is at least ``g`` half a leaf in, so ``g / q`` stays
    bounded (by 2^k). Where ``g`` vanishes linearly (``f cos`` of a bounded ``f``) it costs a few samples
    near the horizon."""
    left = x0 == 0.0
    right = x0 + h == 1.0
    bottom = y0 == 0.0
    top = y0 + h == 1.0
    for corner in range(4):
        k = CORNERS[corner]
        i = k % 3
        j = k // 3
        di = 0
        dj = 0
        if i == 0 and left:
            di = 1
        if i == 2 and right:
            di = -1
        if j == 0 and bottom:
            dj = 1
        if j == 2 and top:
            dj = -1
        if di != 0 or dj != 0:
            mix[k] = max(mix[k], mix[(j + dj) * 3 + i + di])
