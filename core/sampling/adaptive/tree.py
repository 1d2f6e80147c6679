"""One node's quadtree over the square: built in compiled code, in the three steps it takes.

A tree serves the outgoing directions of one *cell* around its node (:mod:`core.sampling.adaptive.layout`).
It is built from ``g`` (:mod:`core.sampling.adaptive.target`) sampled on each node's 3 x 3 *stencil*: the
corners, the edges' midpoints and the centre of the node's square (Simpson's rule on the stencil gives the
node's integral). The cell is represented by a few *views*: view 0 is the node itself; the others span the
cell (its edges and the points between).

1. :func:`grow` (the rejection-free density). Down to ``base_level`` every node splits; below, a leaf splits
   while its share of the warp's relative variance, ``int_L (g - q)^2 / q`` with ``q`` the bilinear
   interpolant of its corners, exceeds ``warp_tol * I``. The leaves' corner values (plus a floor of
   ``FLOOR * I``, so that the density is positive wherever ``f`` can be) define a piecewise-bilinear density
   with exact integrals: the rejection-free mode draws from it and its pdf is exact for its own samples.
2. :func:`bound` (the seed's exact mode). Every leaf gets ``M_L >= g_view / c_view`` over the whole cell,
   ``c`` the exact mode's normalizer as the draws read it (:func:`inv_norm`; the table builds it first):
   the largest value over its stencil at every view, plus a quarter of the largest second difference along
   a line of the stencil (twice what a parabola through them rises between its points), plus the lobe's
   *ridge*: the mirror direction of views across the cell (:func:`make_ridge`), and the peak of the node's
   ``g`` moved with it, clamped into each leaf near them (a narrow lobe that moves across the cell passes
   there); then a safety factor. Then :func:`probe`: random points at random views of the cell, and from the
   best of them and the stencils' best a compass climb of the ratio ``g / (c q)`` over the leaf and the
   cell's views (:func:`_climb`): a peak between the points seen is found where its basin holds a start.
   A climb stalls on a front where ``g`` is cut from a positive value to 0 (the horizon's boundary on a
   half-vector disk, moving with ``wo``): there the ratio is largest on the front's near side, and a
   leaf's bound can still fall short (see ``docs/adaptive.md``, section 4).
   ``f`` is a black box (model files), so no interval or Lipschitz bound is available: the bounds are
   searched, not proven; every trial with ``g > c M`` is counted at run time, the tests assert none
   (``tests/core/test_adaptive.py``, ``tests/core/test_adaptive_bounds.py``) and ``bench/bounds.py`` counts
   them over every model at six ``theta_o`` and three ``phi_o``.
3. :func:`refine` (the seed's ``n_max``). While the envelope's mass ``V = sum area_L M_L`` (in units of the
   normalizer, so the acceptance is ``1 / V`` at every view) exceeds ``n_max / (1 + ACCEPT_MARGIN)``, the leaves
   with the largest excess ``V_L - I_L / c`` are split and bounded again. The seed asks it of every leaf
   (``n_max I_L / V_L >= 1``); the mean number of trials only needs it of the sum, which takes fewer leaves.

The steps run in two calls: :func:`shape` (step 1, every leaf's stencils at every view, and the refinement
for the cell's mixture: the rejection-free mode's whole tree) and :func:`add_bounds` (steps 2 and 3, the
exact mode's), which continues from the first's :class:`TreeShape`. The table lays its nodes out with the
first and adds the bounds only to the trees it keeps (:func:`core.sampling.adaptive.table.build_table`).

A tree's own integrals are Simpson sums over its leaves; the normalizer's values, to ``quad_tol``, come from
:func:`view_integral` (step 1's tree for one view, then :func:`quadrature`), at polar angles of their own.

Nodes are created in order: the root is 0, a node's four children are contiguous and ordered
``(x0, y0), (x0 + h, y0), (x0, y0 + h), (x0 + h, y0 + h)`` (``h`` half the parent's side).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from core.jit import kernel
from core.rng import next_u01, stream
from core.sampling.adaptive.layout import normalizer_at
from core.sampling.adaptive.maps import HALF_VECTOR, direction_to_square
from core.sampling.adaptive.target import g_at, g_dir, square_point

FLOOR = 1e-3
"""Share of the normalizer spread evenly over the square as the rejection-free density's floor: a feature
that the stencils missed still gets a positive density (unbiased estimates), at 0.1 % of the samples."""

BOUND_SAFETY = 1.1
"""Factor on each leaf's bound (covers what lies between the stencils' points and the views)."""

ANISOTROPIC_BOUND_SAFETY = 1.1
"""The same for an anisotropic material, whose cells span azimuths as well (the lobe turns across them)."""

RIM_BOUND_SAFETY = 1.5
"""A further factor on the bound of a leaf on the square's edge, the horizon, where lobes sharpen and turn
fastest with ``wo`` (Ashikhmin-Shirley nu=10 nv=200 at 74 degrees: a rim leaf's ratio between the nine views
is 1.3x what they see). Rim leaves hold little of the density (``cos theta_i`` vanishes there), so a
generous factor costs little acceptance, where 1.5 on every leaf of an anisotropic table filled its trees
(1.5 M leaves)."""

CURVATURE = 0.25
"""A leaf's bound adds this times the largest second difference of a stencil (twice a parabola's rise)."""

ACCEPT_MARGIN = 0.02
"""The envelope aims at an acceptance of ``(1 + ACCEPT_MARGIN) / n_max``."""

SIMPSON = np.array([1.0, 4.0, 1.0, 4.0, 16.0, 4.0, 1.0, 4.0, 1.0]) / 36.0
CORNERS = (0, 2, 6, 8)


class BuildSettings(NamedTuple):
    """What a tree's construction is asked for (see the module docstring)."""

    n_max: float
    warp_tol: float
    quad_tol: float
    base_level: int
    max_level: int
    capacity: int
    """Nodes a tree may have."""
    bound_safety: float = BOUND_SAFETY
    """Factor on each leaf's bound (:data:`ANISOTROPIC_BOUND_SAFETY` for an anisotropic material's trees);
    0: no bounds at all (steps 3 and 3b skipped: a table for the rejection-free mode only)."""


class TreeArrays(NamedTuple):
    """A built tree in creation order (``n`` nodes, ``k`` leaves)."""

    child: np.ndarray
    """``(n,)`` int32: index of the first of a node's four children, or ``-1 - leaf`` for a leaf."""
    x0: np.ndarray
    """``(n,)`` float64: the node's lower-left corner on the square."""
    y0: np.ndarray
    level: np.ndarray
    """``(n,)`` int32: depth (side ``2^-level``)."""
    corners: np.ndarray
    """``(k, 4)`` float64: the rejection-free density's values at the leaf's corners (floor included), in
    the order of :data:`CORNERS`."""
    bound: np.ndarray
    """``(k,)`` float64: ``M_L``, a bound of ``g_view / c_view`` on the leaf for every view of the cell."""
    integrals: np.ndarray
    """``(n_views,)``: ``I`` of every view by Simpson's rule over the leaves."""
    errors: np.ndarray
    """``(n_views,)``: estimated quadrature error of ``integrals`` (Simpson against the leaves' trapezoids)."""
    chi2: np.ndarray
    """``(n_views,)``: the rejection-free density's chi^2 divergence from ``g_view / I_view``: the relative
    variance of its weight in a furnace, were this tree alone to serve the view."""
    envelope: float
    """``V``: the envelope's mass in units of the normalizer (the exact mode's acceptance is ``1 / V``)."""
    evaluations: int


@njit(inline="always", nogil=True, cache=True)
def _point(x0, y0, h, k):
    """Square coordinates of stencil point ``k`` of the node ``(x0, y0, h)``."""
    return x0 + 0.5 * h * (k % 3), y0 + 0.5 * h * (k // 3)


@kernel
def _stencil(mid, p, projection, view, x0, y0, h, out):
    for k in range(9):
        a, b = _point(x0, y0, h, k)
        out[k] = g_at(mid, p, a, b, projection, view)


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


NEW_POINTS = (5, 4, 4, 3)
"""Stencil points child ``q`` evaluates: its corners are its parent's points, and the middles of the edges
inside the parent are its earlier siblings' (16 new points a split, not 20)."""

SPLIT_EVALUATIONS = 16


@kernel
def _child_stencil(mid, p, projection, view, st, parent, first, q, x0, y0, h):
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
            out[k] = g_at(mid, p, a, b, projection, view)


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
def _children(i, n, child, x0, y0, level):
    """Make nodes ``n .. n + 3`` the children of leaf ``i`` (their squares and levels); returns their side."""
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
def _split(mid, p, projection, view, i, n, child, x0, y0, level, st):
    """Split leaf ``i`` into nodes ``n .. n + 3`` (node-view stencils included); returns the new count."""
    h = _children(i, n, child, x0, y0, level)
    for q in range(4):
        _child_stencil(mid, p, projection, view, st, i, n, q, x0[n + q], y0[n + q], h)
    return n + 4


@njit(nogil=True, cache=True)
def _split_worst(mid, p, projection, view, errs, excess, max_level, n, child, x0, y0, level, st):
    """Split the leaves with the largest ``errs`` until their errors add up to ``excess`` (as room and depth
    allow); returns ``(nodes, leaves split, evaluations)``."""
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
        n = _split(mid, p, projection, view, i, n, child, x0, y0, level, st)
        evals += SPLIT_EVALUATIONS
        removed += errs[i]
        split += 1
    return n, split, evals


@kernel
def _leaf_holding(child, x0, y0, level, a, b):
    """The leaf (node index) holding square point ``(a, b)``."""
    i = 0
    while child[i] >= 0:
        c = child[i]
        h = 0.5 ** (level[i] + 1)
        i = c + int(a >= x0[i] + h) + 2 * int(b >= y0[i] + h)
    return i


@kernel
def _chase_peak(mid, p, projection, view, max_level, n, child, x0, y0, level, st):
    """Split the leaf holding the view's mirror direction (the normal, for half-vector trees) while the
    bilinear interpolant of its corners is far below ``g`` there: a lobe much narrower than the leaves the
    uniform levels made is then resolved before anything is measured on the stencils (they would step over
    it). Returns ``(nodes, evaluations)``."""
    cap = child.shape[0]
    a, b = _mirror_point(view, projection)
    g = g_at(mid, p, a, b, projection, view)
    evals = 1
    if not g > 0.0:
        return n, evals
    for _ in range(max_level):
        i = _leaf_holding(child, x0, y0, level, a, b)
        h = 0.5 ** level[i]
        tx = (a - x0[i]) / h
        ty = (b - y0[i]) / h
        st_i = st[i]
        q = (
            (1.0 - tx) * (1.0 - ty) * st_i[0]
            + tx * (1.0 - ty) * st_i[2]
            + (1.0 - tx) * ty * st_i[6]
            + tx * ty * st_i[8]
        )
        if q >= 0.5 * g or level[i] >= max_level or n + 4 > cap:
            break
        n = _split(mid, p, projection, view, i, n, child, x0, y0, level, st)
        evals += SPLIT_EVALUATIONS
    return n, evals


@njit(nogil=True, cache=True)
def grow(mid, p, projection, view, warp_tol, base_level, max_level, child, x0, y0, level, st):
    """Step 1: the tree's shape for the rejection-free density at the node: leaves split, the largest errors
    first, until the warp's relative variance ``sum_L int_L (g - q)^2 / q / I`` is at most ``warp_tol``;
    returns ``(nodes, integral, evaluations)``."""
    cap = child.shape[0]
    x0[0] = 0.0
    y0[0] = 0.0
    level[0] = 0
    child[0] = -1
    _stencil(mid, p, projection, view, 0.0, 0.0, 1.0, st[0])
    n = 1
    evals = 9
    i = 0
    while i < n:  # the uniform levels, breadth first
        if level[i] < base_level and n + 4 <= cap:
            n = _split(mid, p, projection, view, i, n, child, x0, y0, level, st)
            evals += SPLIT_EVALUATIONS
        i += 1
    integral = 0.0
    for i in range(n):
        if child[i] == -1:
            integral += _rule(st[i], x0[i], y0[i], 0.5 ** level[i])
    if integral <= 0.0:  # f is 0 everywhere seen (zero albedo): nothing to refine
        return n, 0.0, evals
    n, e = _chase_peak(mid, p, projection, view, max_level, n, child, x0, y0, level, st)
    evals += e
    floor = FLOOR * integral
    errs = np.zeros(cap)
    for _ in range(64):  # greedy: the leaves with the largest errors first, until the budget is met
        total = 0.0
        for i in range(n):
            errs[i] = _warp_error(st[i], 0.25 ** level[i], floor) if child[i] == -1 else 0.0
            total += errs[i]
        if total <= warp_tol * integral:
            break
        n, split, e = _split_worst(mid, p, projection, view, errs, total - 0.5 * warp_tol * integral, max_level, n,
                                   child, x0, y0, level, st)  # fmt: skip
        evals += e
        if split == 0:
            break
    integral = 0.0
    for i in range(n):
        if child[i] == -1:
            integral += _rule(st[i], x0[i], y0[i], 0.5 ** level[i])
    return n, integral, evals


@kernel
def _max_curvature(st):
    """The largest second difference along the stencil's rows, columns and diagonals: a function resolved
    by the stencil rises between two of its points by at most an eighth of it (a parabola's)."""
    d = 0.0
    for j in range(3):
        d = max(d, abs(st[j * 3] - 2.0 * st[j * 3 + 1] + st[j * 3 + 2]))
    for i in range(3):
        d = max(d, abs(st[i] - 2.0 * st[3 + i] + st[6 + i]))
    d = max(d, abs(st[0] - 2.0 * st[4] + st[8]))
    d = max(d, abs(st[2] - 2.0 * st[4] + st[6]))
    return d


@kernel
def _leaf_mass(stv_i, scales, weights, x0, y0, h, mix):
    """The leaf's mass under the rejection-free density (its mixture corners, floor included); ``mix (9,)``
    is scratch."""
    _mixture(stv_i, scales, weights, x0, y0, h, mix)
    return h * h * (0.25 * (mix[0] + mix[2] + mix[6] + mix[8]) + FLOOR)


@kernel
def inv_norm(norm, norm_meta, theta, phi):
    """``1 / c`` at the view ``(theta, phi)``, ``c`` the exact mode's normalizer exactly as the draws read it
    (:func:`~core.sampling.adaptive.layout.normalizer_at` on the table ``norm``; ``norm_meta = (symmetry,
    log)``), 0 where ``c`` is not positive. The bounds are on ``g / c``, the ratio the draws test: they
    hold for the normalizer as it is, whatever its interpolation error. The trees' own integrals of their
    views (Simpson's rule on stencils fitted to the node's density) served before and were off by orders
    of magnitude for a view whose lobe the tree does not resolve (Cook-Torrance m = 0.005): the largest of
    their inverses over the cell, which the ridge and the probes used, covered that, and erred high by
    ``I``'s range across the cell (16x in a grazing cell of Schlick's, whose envelopes then filled their
    trees' capacity and still missed ``n_max``)."""
    c = normalizer_at(
        int(norm_meta[0]), norm, int(norm_meta[1]), math.cos(theta), math.cos(phi), math.sin(phi)
    )
    return 1.0 / c if c > 0.0 else 0.0


@kernel
def _leaf_bound(mid, p, projection, views, scales, bscales, weights, ridge, ridge_views, i, x0, y0, level, stv,
                safety, work):  # fmt: skip
    """``K_L``, a bound of ``(g_v / c_v) / q`` on leaf ``i`` for every view of the cell (``bscales[v] =
    1 / c_v``, :func:`inv_norm`), ``q`` the leaf's bilinear density (its stencils at every view must be in
    ``stv[i]``); returns ``(K, evaluations)`` (``(1, 0)`` when ``safety`` is 0: a table without bounds).
    ``work (3, 9)`` is scratch."""
    if safety <= 0.0:
        return 1.0, 0
    h = 0.5 ** level[i]
    mix = work[0]
    _mixture(stv[i], scales, weights, x0[i], y0[i], h, mix)
    q = work[1]
    for k in range(9):
        q[k] = _bilinear_at_stencil(mix, k, FLOOR)
    ratio = work[2]
    m = 0.0
    for v in range(views.shape[0]):
        top = 0.0
        for k in range(9):
            ratio[k] = stv[i, v, k] * bscales[v] / q[k]
            top = max(top, ratio[k])
        m = max(m, top + CURVATURE * _max_curvature(ratio))
    evals = 0
    pad = (
        max(h, ridge[0, 4]) if ridge.shape[0] > 0 else h
    )  # a leaf smaller than the ridge's step still meets it
    lo_x = x0[i] - pad
    hi_x = x0[i] + h + pad
    lo_y = y0[i] - pad
    hi_y = y0[i] + h + pad
    c0 = mix[0] + FLOOR
    c1 = mix[2] + FLOOR
    c2 = mix[6] + FLOOR
    c3 = mix[8] + FLOOR
    for r in range(ridge.shape[0]):
        v = int(ridge[r, 2])
        a = ridge[r, 0]
        b = ridge[r, 1]
        if a < lo_x or a > hi_x or b < lo_y or b > hi_y:
            continue
        a = min(max(a, x0[i]), x0[i] + h)
        b = min(max(b, y0[i]), y0[i] + h)
        tx = (a - x0[i]) / h
        ty = (b - y0[i]) / h
        qq = (1.0 - tx) * (1.0 - ty) * c0 + tx * (1.0 - ty) * c1 + (1.0 - tx) * ty * c2 + tx * ty * c3
        m = max(m, g_at(mid, p, a, b, projection, ridge_views[v]) * ridge[r, 3] / qq)
        evals += 1
    if x0[i] == 0.0 or y0[i] == 0.0 or x0[i] + h == 1.0 or y0[i] + h == 1.0:
        safety *= RIM_BOUND_SAFETY
    # at least the density itself: where g was 0 at every point seen (beyond a front, such as the horizon's
    # through a half-vector disk), it may not be between them at another view of the cell
    return max(m * safety, 1.0), evals


@njit(inline="always", nogil=True, cache=True)
def _mirror_point(view, projection):
    """The square point of the view's mirror direction (the normal, for half-vector trees)."""
    if projection == HALF_VECTOR:
        return 0.5, 0.5
    a, b, _ = direction_to_square(-view[0], -view[1], view[2], projection)
    return a, b


@kernel
def _peak(n, child, x0, y0, level, st):
    """The square point of the largest ``g`` at the node view among the leaves' stencil points."""
    best = -1.0
    pa = 0.5
    pb = 0.5
    for i in range(n):
        if child[i] != -1:
            continue
        h = 0.5 ** level[i]
        for k in range(9):
            if st[i, k] > best:
                best = st[i, k]
                pa, pb = _point(x0[i], y0[i], h, k)
    return pa, pb


@njit(nogil=True, cache=True)
def _ridge(projection, views, ridge_views, pa, pb, rscales, step):
    """Ridge points ``(r, 5)``: ``(a, b, view, scale, step)`` of the mirror direction of each of the
    ``ridge_views`` (a finer set than the stencils' views: a lobe narrower than their spacing is still met),
    and of the node view's peak ``(pa, pb)`` (:func:`_peak`) moved with it; ``scale`` is ``1 / c`` at the
    ridge view (:func:`inv_norm`), ``step`` the distance between neighbouring ridge points on the square."""
    ma0, mb0 = _mirror_point(views[0], projection)
    da = pa - ma0
    db = pb - mb0
    out = np.empty((2 * ridge_views.shape[0], 5))
    for v in range(ridge_views.shape[0]):
        ma, mb = _mirror_point(ridge_views[v], projection)
        out[2 * v, 3] = rscales[v]
        out[2 * v + 1, 3] = rscales[v]
        out[2 * v, 4] = step
        out[2 * v + 1, 4] = step
        out[2 * v, 0] = ma
        out[2 * v, 1] = mb
        out[2 * v, 2] = v
        out[2 * v + 1, 0] = min(max(ma + da, 0.0), 1.0)
        out[2 * v + 1, 1] = min(max(mb + db, 0.0), 1.0)
        out[2 * v + 1, 2] = v
    return out


RIDGE_STEPS = 17
"""Polar angles across a cell at which the lobe's ridge is followed at least (and 5 azimuths when
anisotropic); more where the lobe is narrow against the mirror direction's motion across the cell
(:func:`make_ridge`), up to :data:`RIDGE_MAX_STEPS`."""

RIDGE_MAX_STEPS = 65
"""Every leaf near the ridge looks at every ridge point: at 513 steps an anisotropic tree (5 azimuths) spent
more there than on ``f`` (Ashikhmin-Shirley nu=10 nv=200's exact table: 7.8 s of CPU)."""


@kernel
def _view_row(theta, phi, follow, out):
    """A view row (:func:`core.sampling.adaptive.target.make_view`)."""
    st = math.sin(theta)
    if follow:
        out[0] = st
        out[1] = 0.0
        out[3] = math.cos(phi)
        out[4] = math.sin(phi)
    else:
        out[0] = st * math.cos(phi)
        out[1] = st * math.sin(phi)
        out[3] = 1.0
        out[4] = 0.0
    out[2] = math.cos(theta)
    out[5] = 1.0


@njit(nogil=True, cache=True)
def make_ridge(cell, projection, view0, width, norm, norm_meta, safety):
    """The views along which the lobe's ridge is followed (polar angles across the cell, times 5 azimuths
    when anisotropic), ``1 / c`` at each and the step between their mirror points on the square. The polar
    steps are at least :data:`RIDGE_STEPS` and halved while the mirror point moves more than a quarter of
    the lobe's ``width`` between them (the side of the leaf holding the node's mirror point once the tree is
    grown, :func:`_lobe_width`): a peak between two ridge points is then no higher than theirs, give or take the bound's safety
    factor. (Cook-Torrance m = 0.005's rare violations between the nodes were the same with 17 steps and
    with more: they are off the ridge, see ``docs/adaptive.md`` section 4.)"""
    follow = cell[4] > 0.5
    n_phi = 5 if cell[3] > cell[2] else 1
    row = np.empty(6)
    _view_row(cell[0], cell[2], follow, row)
    a0, b0 = _mirror_point(row, projection)
    _view_row(cell[1], cell[2], follow, row)
    a1, b1 = _mirror_point(row, projection)
    motion = math.sqrt((a1 - a0) ** 2 + (b1 - b0) ** 2)
    steps = RIDGE_STEPS
    while steps < RIDGE_MAX_STEPS and motion / (steps - 1) > 0.25 * width:
        steps = 2 * steps - 1
    out = np.empty((steps * n_phi, 6))
    scales = np.zeros(steps * n_phi)
    for t in range(steps):
        theta = cell[0] + (cell[1] - cell[0]) * t / (steps - 1)
        for j in range(n_phi):
            phi = cell[2] + (cell[3] - cell[2]) * j / max(n_phi - 1, 1)
            _view_row(theta, phi, follow, out[t * n_phi + j])
            if safety > 0.0:
                scales[t * n_phi + j] = inv_norm(norm, norm_meta, theta, phi)
    return out, scales, motion / (steps - 1)


@kernel
def _view_stencils(mid, p, projection, views, i, x0, y0, level, st, stv):
    """Node ``i``'s stencils at every view (view 0's is ``st[i]``): each point's direction is made once
    for all the views. Returns the evaluations made."""
    h = 0.5 ** level[i]
    for k in range(9):
        stv[i, 0, k] = st[i, k]
        _point_at_views(mid, p, projection, views, x0[i], y0[i], h, k, stv, i)
    return 9 * (views.shape[0] - 1)


@njit(inline="always", nogil=True, cache=True)
def _point_at_views(mid, p, projection, views, x0, y0, h, k, stv, i):
    """Stencil point ``k`` of the node at ``(x0, y0)`` (side ``h``) evaluated at views 1.. into ``stv[i]``."""
    a, b = _point(x0, y0, h, k)
    x, y, z, w = square_point(a, b, projection)
    for v in range(1, views.shape[0]):
        stv[i, v, k] = g_dir(mid, p, x, y, z, w, views[v], projection)


@kernel
def _child_view_stencils(mid, p, projection, views, parent, q, c, x0, y0, level, st, stv):
    """Child ``c`` (quarter ``q`` of ``parent``)'s stencils at every view: its corners are stencil points of
    its parent's and the middles of the edges inside the parent its earlier siblings' (as in
    :func:`_child_stencil`; the siblings are made in order), so 3 to 5 points are evaluated, not nine.
    Returns the evaluations made."""
    qi = q % 2
    qj = q // 2
    h = 0.5 ** level[c]
    for k in range(9):
        stv[c, 0, k] = st[c, k]
        i = k % 3
        j = k // 3
        if i % 2 == 0 and j % 2 == 0:
            src = (qj + j // 2) * 3 + qi + i // 2
            for v in range(1, views.shape[0]):
                stv[c, v, k] = stv[parent, v, src]
            continue
        sib, ks = _shared_point(q, k)
        if sib >= 0:
            for v in range(1, views.shape[0]):
                stv[c, v, k] = stv[c - q + sib, v, ks]
        else:
            _point_at_views(mid, p, projection, views, x0[c], y0[c], h, k, stv, c)
    return NEW_POINTS[q] * (views.shape[0] - 1)


@njit(nogil=True, cache=True)
def view_stencils(mid, p, projection, views, n, child, x0, y0, level, st, stv):
    """Step 2: every node's stencils at every view and the views' integrals. Returns ``(scales,
    evaluations)``, ``scales[v] = 1 / I_v`` (the mixture's normalization).

    Made from the root down as the tree was split (nodes are created after their parents): a child has its
    parent's and its siblings' shared points (:func:`_child_view_stencils`), 16 new points a split where
    every leaf on its own takes 9 (41 % fewer evaluations; the same values, at the same points)."""
    nv = views.shape[0]
    evals = _view_stencils(mid, p, projection, views, 0, x0, y0, level, st, stv)
    for i in range(n):
        if child[i] >= 0:
            for q in range(4):
                evals += _child_view_stencils(
                    mid, p, projection, views, i, q, child[i] + q, x0, y0, level, st, stv
                )
    integral = np.zeros(nv)
    for i in range(n):
        if child[i] == -1:
            for v in range(nv):
                integral[v] += _rule(stv[i, v], x0[i], y0[i], 0.5 ** level[i])
    scales = np.zeros(nv)
    for v in range(nv):
        scales[v] = 1.0 / integral[v] if integral[v] > 0.0 else 0.0
    return scales, evals


@njit(nogil=True, cache=True)
def bound(mid, p, projection, views, ridge_views, weights, n, child, x0, y0, level, stv, m, safety, scales, bscales,
          rscales, step, pa, pb):  # fmt: skip
    """Step 3: every leaf's bound ``m`` (its stencils at every view already made, :func:`view_stencils`).

    Returns ``(ridge, rho, evaluations)``: the bounds are on ``g_v / c_v``, ``bscales`` raised in place where
    ``1 / I_v`` is larger; ``rho`` the factor on ``1 / c`` between the views (``rscales`` multiplied by it in
    place)."""
    nv = views.shape[0]
    rho = 1.0
    for v in range(nv):
        # at the stencils, the larger of 1 / c and the stencils' own 1 / I_v: where a view's lobe falls between
        # the stencils' points, its own integral is too small and its ratios there err high, as they should
        # (with 1 / c alone, Cook-Torrance m = 0.005's bounds failed at 2e-4 of its trials)
        if safety > 0.0 and bscales[v] > 0.0:
            rho = max(rho, scales[v] / bscales[v])
        bscales[v] = max(bscales[v], scales[v]) if safety > 0.0 else 0.0
    # between the views (ridge, probes): 1 / c there times how far the stencils' integrals fell short of c at
    # the views (rho = 1 where they resolve every view's lobe; a lobe narrower than the stencils' spacing
    # makes it large, and the bounds between the views then err high by as much, as before 1 / c was used)
    for r in range(rscales.shape[0]):
        rscales[r] *= rho
    ridge = _ridge(projection, views, ridge_views, pa, pb, rscales, step)
    evals = 0
    work = np.empty((3, 9))
    for i in range(n):
        if child[i] == -1:
            m[i], e = _leaf_bound(mid, p, projection, views, scales, bscales, weights, ridge, ridge_views, i, x0, y0,
                                  level, stv, safety, work)  # fmt: skip
            evals += e
    return ridge, rho, evals


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


@njit(nogil=True, cache=True)
def refine_warp(mid, p, projection, views, scales, bscales, weights, ridge, ridge_views, warp_tol, max_level, n, child,
                x0, y0, level, st, stv, m, safety):  # fmt: skip
    """Step 2b: the rejection-free density is the cell's *mixture* ``sum_v w_v g_v / I_v`` (the draws use one
    tree for the whole cell, so it should fit every view of it, not only the node's; where the lobe moves or a
    region becomes reachable across the cell, the mixture covers it). Leaves split, the largest errors first,
    until the mixture's warp error is at most ``warp_tol``. Returns ``(nodes, evaluations)``."""
    cap = child.shape[0]
    evals = 0
    mix = np.empty(9)
    work = np.empty((3, 9))
    errs = np.zeros(cap)
    for _ in range(64):
        total = 0.0
        for i in range(n):
            errs[i] = 0.0
            if child[i] == -1:
                _mixture(stv[i], scales, weights, x0[i], y0[i], 0.5 ** level[i], mix)
                errs[i] = _warp_error(mix, 0.25 ** level[i], FLOOR)
                total += errs[i]
        if total <= warp_tol:
            break
        start = n
        n, split, e = _split_worst(mid, p, projection, views[0], errs, total - 0.5 * warp_tol, max_level, n, child,
                                   x0, y0, level, st)  # fmt: skip
        evals += e
        for i in range(start):
            if child[i] < start:  # a leaf, or split before this round
                continue
            for q in range(4):
                c = child[i] + q
                evals += _child_view_stencils(mid, p, projection, views, i, q, c, x0, y0, level, st, stv)
                m[c], e = _leaf_bound(mid, p, projection, views, scales, bscales, weights, ridge, ridge_views, c, x0,
                                      y0, level, stv, safety, work)  # fmt: skip
                evals += e
        if split == 0:
            break
    return n, evals


@njit(nogil=True, cache=True)
def refine(mid, p, projection, views, scales, bscales, weights, ridge, ridge_views, n_max, max_level, n, child, x0, y0,
           level, st, stv, m, safety):  # fmt: skip
    """Step 3: split the leaves with the largest excess ``(K_L - 1) q_L`` until the envelope's mass
    ``V = sum K_L q_L <= n_max / (1 + ACCEPT_MARGIN)`` (``q_L`` the leaf's mass under the density).

    Returns ``(nodes, V, evaluations)``."""
    cap = child.shape[0]
    target = n_max / (1.0 + ACCEPT_MARGIN)
    evals = 0
    excess = np.zeros(cap)
    work = np.empty((3, 9))
    for _ in range(64):
        total = 0.0
        worst = 0.0
        for i in range(n):
            excess[i] = 0.0
            if child[i] == -1:
                q = _leaf_mass(stv[i], scales, weights, x0[i], y0[i], 0.5 ** level[i], work[0])
                vol = m[i] * q
                total += vol
                if level[i] < max_level:
                    excess[i] = vol - q
                    worst = max(worst, excess[i])
        if total <= target or worst <= 0.0:
            return n, total, evals
        # split the leaves within a factor 4 of the worst excess (at least the worst), as room allows
        limit = 0.25 * worst
        end = n
        for i in range(end):
            if child[i] == -1 and excess[i] >= limit and n + 4 <= cap:
                n = _split(mid, p, projection, views[0], i, n, child, x0, y0, level, st)
                evals += SPLIT_EVALUATIONS
                for c in range(n - 4, n):
                    evals += _child_view_stencils(mid, p, projection, views, i, c - (n - 4), c, x0, y0, level, st,
                                                  stv)  # fmt: skip
                    m[c], e = _leaf_bound(mid, p, projection, views, scales, bscales, weights, ridge, ridge_views, c,
                                          x0, y0, level, stv, safety, work)  # fmt: skip
                    evals += e
        if n == end:
            break
    total = 0.0
    for i in range(n):
        if child[i] == -1:
            total += m[i] * _leaf_mass(stv[i], scales, weights, x0[i], y0[i], 0.5 ** level[i], work[0])
    return n, total, evals


PROBES = 24
"""Random points per leaf at which :func:`probe` checks the bounds, each at a random view of the cell; a leaf
above level 5 gets four times as many per level (a large leaf can hide a front that moves across the cell,
as the horizon's boundary does through a half-vector disk at grazing angles)."""

PROBE_MARGIN = 1.25
"""A bound that a probe finds short is raised to this times what the probe saw."""

PROBE_ROUNDS = 6
"""Rounds of the acceptance's refinement, each followed by the probes of the leaves it made."""

PROBE_TIE = 1e-9
"""A bound is short only where a probe's ratio times the safety exceeds it by more than this, relatively: a
flat lobe (Lambert) meets its bounds at every probe to rounding, and ties broken by rounding raised some
leaves' bounds and not others, so that the tables of ``kd = 0.5`` and ``0.25`` differed (their bounds keep
the safety factor: a shortfall of 1e-9 of it is no violation)."""


@kernel
def _has_front(stv_i):
    """Whether ``g`` is 0 at some of the leaf's stencil points (at some view): a front where ``g`` starts
    (the horizon's boundary through a half-vector disk, which turns with ``wo``'s azimuth) may cross the
    leaf at a view between the sampled ones, where the density, fitted to 0 there, holds only its floor."""
    for v in range(stv_i.shape[0]):
        for k in range(9):
            if not stv_i[v, k] > 0.0:
                return True
    return False


INV_NORM_GRID = 257
"""Polar angles (and, across an azimuth range, 17 azimuths) at which :func:`_inv_norm_top` reads ``1 / c``
over a cell: finer than the normalizer's table near the horizon, where its rows are densest in theta."""

INV_NORM_MARGIN = 1.25
"""Factor on the largest ``1 / c`` read on that grid: the cubic between its points rises far less."""


@kernel
def _inv_norm_top(norm, norm_meta, cell):
    """An upper bound of ``1 / c`` (:func:`inv_norm`) over the cell ``theta_lo, theta_hi, phi_lo, phi_hi``:
    the largest value on a grid finer than the normalizer's table, times :data:`INV_NORM_MARGIN`."""
    n_phi = 17 if cell[3] > cell[2] else 1
    top = 0.0
    for t in range(INV_NORM_GRID):
        theta = cell[0] + (cell[1] - cell[0]) * t / (INV_NORM_GRID - 1)
        for j in range(n_phi):
            phi = cell[2] + (cell[3] - cell[2]) * j / max(n_phi - 1, 1)
            top = max(top, inv_norm(norm, norm_meta, theta, phi))
    return top * INV_NORM_MARGIN


CLIMB_STEP = 0.125
"""The climb's first step (:func:`_climb`), in units of the leaf's side and of the cell's extent in theta
(and phi): an eighth, the spacing of a stencil's points halved twice."""

CLIMB_MIN_STEP = 1.0 / 256.0
"""The climb stops once its step is below this (five halvings of :data:`CLIMB_STEP`)."""

CLIMB_EVALUATIONS = 64
"""Evaluations of ``g`` a climb may make at most."""


@kernel
def _ratio_at(mid, p, projection, cell, azimuths, follow, view, x0, y0, h, c0, c1, c2, c3, rho, norm, norm_meta,
              u1, u2, t, w):  # fmt: skip
    """``rho g / (c q)`` at point ``(u1, u2)`` of the leaf (its corner densities ``c0 .. c3``; all four 1:
    ``rho g / c`` itself) and the view ``t, w`` of the way across the cell in theta and phi (``view (6,)`` is
    scratch, its constant entries set by the caller)."""
    theta = cell[0] + t * (cell[1] - cell[0])
    phi = cell[2] + w * (cell[3] - cell[2])
    if azimuths:
        _view_row(theta, phi, follow, view)
    else:
        view[0] = math.sin(theta)
        view[2] = math.cos(theta)
    qq = (1.0 - u1) * (1.0 - u2) * c0 + u1 * (1.0 - u2) * c1 + (1.0 - u1) * u2 * c2 + u1 * u2 * c3
    g = g_at(mid, p, x0 + u1 * h, y0 + u2 * h, projection, view)
    if not g > 0.0:
        return 0.0
    return g * rho * inv_norm(norm, norm_meta, theta, phi) / qq


@kernel
def _climb(mid, p, projection, cell, azimuths, follow, view, x0, y0, h, c0, c1, c2, c3, rho, norm, norm_meta, x,
           fx, trial):  # fmt: skip
    """The largest ``rho g / (c q)`` a compass search finds from the point ``x (4,)`` (``u1, u2, t, w``: the
    leaf's coordinates and the way across the cell, :func:`_ratio_at`; ``fx`` its ratio), each coordinate
    within ``[0, 1]``: a step along one coordinate is taken where it raises the ratio, the step halved where
    none does, from :data:`CLIMB_STEP` down to :data:`CLIMB_MIN_STEP`, at most :data:`CLIMB_EVALUATIONS`
    evaluations. Returns ``(ratio, evaluations)``; ``x`` holds the point reached, ``trial (4,)`` is
    scratch.

    A local maximum of the ratio whose basin holds the start is reached to within the last step: a peak
    between the points the bounds were made from (a lobe squeezed against the horizon in a coarse rim leaf,
    Lafortune's at 89 degrees, 1.16x its bound; the front of the region whose ``wi`` is above the horizon on
    a half-vector disk moving across a leaf with ``wo``, where ``g`` is cut from a positive value to 0 and the
    ratio is largest just on its near side, BRDF Explorer's Blinn-Phong at 60 degrees, 1.8x)."""
    dims = 4 if azimuths else 3
    step = CLIMB_STEP
    evals = 0
    while step >= CLIMB_MIN_STEP and evals < CLIMB_EVALUATIONS:
        moved = False
        # along each coordinate, then along the leaf's two diagonals (a front crossing the leaf obliquely:
        # along the coordinates alone the search stalls where each step crosses it)
        for d in range(dims + 2):
            for sign in (1.0, -1.0):
                for k in range(4):
                    trial[k] = x[k]
                if d < dims:
                    trial[d] = min(max(x[d] + sign * step, 0.0), 1.0)
                else:
                    trial[0] = min(max(x[0] + sign * step, 0.0), 1.0)
                    trial[1] = min(max(x[1] + (sign if d == dims else -sign) * step, 0.0), 1.0)
                if trial[0] == x[0] and trial[1] == x[1] and trial[2] == x[2] and trial[3] == x[3]:
                    continue
                fy = _ratio_at(mid, p, projection, cell, azimuths, follow, view, x0, y0, h, c0, c1, c2, c3, rho,
                               norm, norm_meta, trial[0], trial[1], trial[2], trial[3])  # fmt: skip
                evals += 1
                if fy > fx:
                    fx = fy
                    for k in range(4):
                        x[k] = trial[k]
                    moved = True
                    break
            if moved:
                break
        if not moved:
            step *= 0.5
    return fx, evals


@kernel
def probe(mid, p, projection, views, angles, cell, scales, weights, n, child, x0, y0, level, stv, m, seed, probed,
          safety, norm, norm_meta, rho, mix, view, pts):  # fmt: skip
    """Step 3b: every leaf's bound checked at ``PROBES`` random points, each at a random view of the cell
    (``cell = theta_lo, theta_hi, phi_lo, phi_hi, follow``), then by three climbs (:func:`_climb`), from the
    two best probes and from the stencils' largest ratio (``angles``: each view's ``(theta, phi)``): between the
    stencils' points and between the views, where no rule covers it. A bound found short is raised to
    ``PROBE_MARGIN`` times the ratio seen (against ``rho g / c`` at the probe's view, :func:`inv_norm`,
    ``rho`` from :func:`bound`; ``1 / c`` is read only where the cell's largest could beat the best ratio
    seen). Returns the number of bounds raised and the evaluations made. ``mix (9,)``, ``view (6,)`` and
    ``pts (16,)`` are scratch."""
    raised = 0
    evals = 0
    view[5] = 1.0
    azimuths = cell[3] > cell[2]
    follow = cell[4] > 0.5
    if not azimuths:  # one azimuth, 0: the view's turn is none (as _view_row makes it at phi = 0)
        view[1] = 0.0
        view[3] = 1.0
        view[4] = 0.0
    # a probe whose ratio cannot beat the best one seen even at the cell's largest 1 / c needs no 1 / c
    top = rho * _inv_norm_top(norm, norm_meta, cell)
    span_t = cell[1] - cell[0]
    span_w = cell[3] - cell[2]
    x = pts[0:4]
    trial = pts[4:8]
    for i in range(n):
        if child[i] != -1 or probed[i]:
            continue
        probed[i] = True
        h = 0.5 ** level[i]
        _mixture(stv[i], scales, weights, x0[i], y0[i], h, mix)
        c0 = mix[0] + FLOOR
        c1 = mix[2] + FLOOR
        c2 = mix[6] + FLOOR
        c3 = mix[8] + FLOOR
        state = stream(seed, i)
        worst = 0.0
        second = 0.0
        count = min(PROBES * 4 ** max(0, 5 - level[i]), 8 * PROBES)
        if _has_front(stv[i]):
            count = 8 * PROBES
        for _ in range(count):
            state, u1 = next_u01(state)
            state, u2 = next_u01(state)
            state, u3 = next_u01(state)
            state, u4 = next_u01(state)
            theta = cell[0] + u3 * span_t
            phi = cell[2] + u4 * span_w
            if azimuths:
                _view_row(theta, phi, follow, view)
            else:
                view[0] = math.sin(theta)
                view[2] = math.cos(theta)
            qq = (1.0 - u1) * (1.0 - u2) * c0 + u1 * (1.0 - u2) * c1 + (1.0 - u1) * u2 * c2 + u1 * u2 * c3
            g = g_at(mid, p, x0[i] + u1 * h, y0[i] + u2 * h, projection, view)
            if g * top / qq > second:
                r = g * rho * inv_norm(norm, norm_meta, theta, phi) / qq
                if r > worst:
                    second = worst
                    for k in range(4):
                        pts[12 + k] = pts[8 + k]
                    worst = r
                    pts[8] = u1
                    pts[9] = u2
                    pts[10] = u3
                    pts[11] = u4
                elif r > second:
                    second = r
                    pts[12] = u1
                    pts[13] = u2
                    pts[14] = u3
                    pts[15] = u4
            evals += 1
        # climb from the two best probes
        start = worst
        for j in range(2):
            f0 = start if j == 0 else second
            if f0 > 0.0:
                for k in range(4):
                    x[k] = pts[8 + 4 * j + k]
                r, e = _climb(mid, p, projection, cell, azimuths, follow, view, x0[i], y0[i], h, c0, c1, c2, c3,
                              rho, norm, norm_meta, x, f0, trial)  # fmt: skip
                evals += e
                worst = max(worst, r)
        # and from the stencils' largest ratio (at its view's place in the cell)
        best = 0.0
        kb = 0
        vb = 0
        for v in range(stv.shape[1]):
            s_v = inv_norm(norm, norm_meta, angles[v, 0], angles[v, 1])
            for k in range(9):
                qk = _bilinear_at_stencil(mix, k, FLOOR)
                r = stv[i, v, k] * s_v / qk
                if r > best:
                    best = r
                    kb = k
                    vb = v
        if best > 0.0:
            x[0] = 0.5 * (kb % 3)
            x[1] = 0.5 * (kb // 3)
            x[2] = min(max((angles[vb, 0] - cell[0]) / span_t, 0.0), 1.0) if span_t > 0.0 else 0.0
            x[3] = min(max((angles[vb, 1] - cell[2]) / span_w, 0.0), 1.0) if span_w > 0.0 else 0.0
            f0 = _ratio_at(mid, p, projection, cell, azimuths, follow, view, x0[i], y0[i], h, c0, c1, c2, c3, rho,
                           norm, norm_meta, x[0], x[1], x[2], x[3])  # fmt: skip
            r, e = _climb(mid, p, projection, cell, azimuths, follow, view, x0[i], y0[i], h, c0, c1, c2, c3, rho,
                          norm, norm_meta, x, f0, trial)  # fmt: skip
            evals += e + 1
            worst = max(worst, r)
        if worst * safety > m[i] * (1.0 + PROBE_TIE):
            m[i] = worst * PROBE_MARGIN
            raised += 1
    return raised, evals


@njit(inline="always", nogil=True, cache=True)
def _richardson_divisor(x0, y0, h):
    """``2^k - 1`` for a rule of order ``k`` on this node: 4 inside, 3 on the diagonals' kink, and 1 (no
    extrapolation: the difference itself is the error) on the square's edge, the horizon, where ``g`` may
    behave like ``(pi/2 - theta)^a`` with ``a < 1`` (Minnaert's ``cos^k``) or hold a lobe cut by the horizon
    narrower than the cells (Phong with n = 1e4 at grazing: a Richardson step there made the node's
    integral 13 % too large)."""
    if x0 == 0.0 or y0 == 0.0 or x0 + h == 1.0 or y0 + h == 1.0:
        return 1.0
    if _on_diagonal(x0, y0, h):
        return 7.0
    return 15.0


@kernel
def _trial_split(mid, p, projection, view, i, n, child, x0, y0, level, st, max_level, trial):
    """The rule on leaf ``i``'s four children (made in slots ``n .. n + 3`` and dropped again, their stencils
    kept in ``trial[i]`` for a split for good, :func:`_split_tried`): returns the extrapolated integral, its
    estimated error and the evaluations made."""
    h = 0.5 ** level[i]
    coarse = _rule(st[i], x0[i], y0[i], h)
    if level[i] >= max_level or n + 4 > child.shape[0]:
        # no room or depth to try it: the rule's own difference from the trapezoids is its error (0 here
        # would read the whole integral as converged: g_duer's ring along the horizon at 89 degrees)
        return coarse, abs(coarse - _trapezoids(st[i], h * h)), 0
    end = _split(mid, p, projection, view, i, n, child, x0, y0, level, st)
    s = 0.0
    for c in range(n, end):
        s += _rule(st[c], x0[c], y0[c], 0.5 * h)
        for k in range(9):
            trial[i, c - n, k] = st[c, k]
    child[i] = -1
    divisor = _richardson_divisor(x0[i], y0[i], h)
    return s + (s - coarse) / divisor, abs(s - coarse) / divisor, SPLIT_EVALUATIONS


@kernel
def _split_tried(i, n, child, x0, y0, level, st, trial):
    """:func:`_split` of a leaf split on trial before: its children's stencils are those the trial made."""
    _children(i, n, child, x0, y0, level)
    for q in range(4):
        for k in range(9):
            st[n + q, k] = trial[i, q, k]
    return n + 4


@njit(nogil=True, cache=True)
def quadrature(mid, p, projection, view, quad_tol, max_level, n, child, x0, y0, level, st, fine, fine_err):
    """Step 4: the node view's integral to ``quad_tol`` (relative, the whole square), in cells below the
    sampling tree's leaves (the caller folds them back into their leaf: they are not stored).

    Every leaf is split on trial: the rule on its four children against its own estimates the error (a
    Richardson step) and gives a better integral (``fine``, error ``fine_err``). While the errors add up to
    more than ``quad_tol * I``, the cells with the largest errors are split for good (into the children their
    trial made: no evaluation) and tried in turn: the fewest cells that reach the tolerance. Returns
    ``(nodes, evaluations)``."""
    cap = child.shape[0]
    evals = 0
    known = np.zeros(cap, dtype=np.bool_)
    errs = np.zeros(cap)
    trial = np.empty((cap, 4, 9))
    for _ in range(48):
        total = 0.0
        err = 0.0
        for i in range(n):
            if child[i] != -1:
                continue
            if not known[i]:
                fine[i], fine_err[i], e = _trial_split(mid, p, projection, view, i, n, child, x0, y0, level,
                                                       st, max_level, trial)  # fmt: skip
                evals += e
                known[i] = True
            total += fine[i]
            err += fine_err[i]
        excess = err - 0.5 * quad_tol * total
        if err <= quad_tol * total or excess <= 0.0:
            break
        k = 0
        for i in range(n):
            errs[i] = fine_err[i] if child[i] == -1 else 0.0
        order = np.argsort(-errs[:n])
        removed = 0.0
        end = n
        for r in range(end):
            i = order[r]
            if removed >= excess or errs[i] <= 0.0 or n + 4 > cap or level[i] >= max_level:
                break
            n = _split_tried(i, n, child, x0, y0, level, st, trial)  # every leaf here was split on trial
            removed += errs[i]
            k += 1
        if k == 0:
            break
    for i in range(n):  # leaves split in the last round
        if child[i] == -1 and not known[i]:
            fine[i], fine_err[i], e = _trial_split(mid, p, projection, view, i, n, child, x0, y0, level, st,
                                                   max_level, trial)  # fmt: skip
            evals += e
    return n, evals


@kernel
def _fold_quadrature(n_keep, n, child, fine, fine_err):
    """Fold the quadrature's cells (nodes ``n_keep ..``) into the sampling tree's leaves: a leaf's ``fine``
    becomes the sum over its cells; the leaves are made leaves again."""
    for i in range(n - 1, -1, -1):
        c = child[i]
        if c >= 0 and c >= n_keep:
            fine[i] = fine[c] + fine[c + 1] + fine[c + 2] + fine[c + 3]
            fine_err[i] = fine_err[c] + fine_err[c + 1] + fine_err[c + 2] + fine_err[c + 3]
    for i in range(n_keep):
        if child[i] >= n_keep:
            child[i] = -1


_HILBERT_QUADRANT = np.array([[0, 2, 3, 1], [0, 1, 3, 2], [3, 1, 0, 2], [3, 2, 0, 1]], dtype=np.int64)
"""The order in which a node of each of the Hilbert curve's four orientations visits its children (quadrant
``qx + 2 qy``): orientation 0 goes (0, 0), (0, 1), (1, 1), (1, 0); 1 is its transpose, 2 its half turn, 3 the
half turn's transpose."""
_HILBERT_STATE = np.array([[1, 0, 0, 2], [0, 1, 1, 3], [3, 2, 2, 0], [2, 3, 3, 1]], dtype=np.int64)
"""The orientation of each child, in that order: each child's curve starts next to where the last one ended."""


_UNNUMBERED = -(2**31)
"""A leaf's ``child`` while :func:`_number_leaves` walks the tree (no leaf number is that large)."""


@njit(nogil=True, cache=True)
def _number_leaves(n, child):
    """Number the leaves (``child < 0``) of the tree rooted at node 0 along a Hilbert curve over the square,
    as ``child = -1 - leaf``; returns their count. The leaves' order is the one a uniform number walks to
    pick a leaf by the cumulative probabilities (``draw._pick_leaf``): along this curve consecutive leaves
    touch, so a caller's stratified numbers stay spread over the square (the nodes' index order, the
    numbering before, is breadth-first-like and jumps across it). A node the root does not reach (none is
    expected) is numbered after the others, in index order."""
    for i in range(n):
        if child[i] < 0:
            child[i] = _UNNUMBERED
    stack_node = np.empty(256, np.int64)  # at most three pending siblings per level, 14 levels
    stack_state = np.empty(256, np.int64)
    stack_node[0] = 0
    stack_state[0] = 0
    top = 1
    k = 0
    while top > 0:
        top -= 1
        i = stack_node[top]
        state = stack_state[top]
        c = child[i]
        if c < 0:
            child[i] = -1 - k
            k += 1
            continue
        for j in range(3, -1, -1):
            stack_node[top] = c + _HILBERT_QUADRANT[state, j]
            stack_state[top] = _HILBERT_STATE[state, j]
            top += 1
    for i in range(n):
        if child[i] == _UNNUMBERED:
            child[i] = -1 - k
            k += 1
    return k


@njit(nogil=True, cache=True)
def summarize(n, child, x0, y0, level, st, stv, m, fine, fine_err, scales, weights):
    """Leaf numbering (:func:`_number_leaves`), corner values (the cell's mixture, floor included), the views'
    integrals, errors and chi^2, and the envelope."""
    nv = stv.shape[1]
    floor = FLOOR
    mix = np.empty(9)
    k = _number_leaves(n, child)
    corners = np.empty((k, 4))
    bounds = np.empty(k)
    integrals = np.zeros(nv)
    errors = np.zeros(nv)
    mass = 0.0
    envelope = 0.0
    for i in range(n):
        if child[i] >= 0:
            continue
        leaf = -1 - child[i]
        area = 0.25 ** level[i]
        _mixture(stv[i], scales, weights, x0[i], y0[i], 0.5 ** level[i], mix)
        for c in range(4):
            corners[leaf, c] = mix[CORNERS[c]] + floor
        bounds[leaf] = m[i]
        leaf_mass = area * 0.25 * (corners[leaf, 0] + corners[leaf, 1] + corners[leaf, 2] + corners[leaf, 3])
        mass += leaf_mass
        envelope += m[i] * leaf_mass
        integrals[0] += fine[i]
        errors[0] += fine_err[i]
        for v in range(1, nv):
            s = _rule(stv[i, v], x0[i], y0[i], 0.5 ** level[i])
            t = _trapezoids(stv[i, v], area)
            integrals[v] += s
            errors[v] += abs(s - t)
    # chi^2 of g_v / I_v against the bilinear density q = bilinear / mass, by Simpson on the stencils
    chi2 = np.zeros(nv)
    for i in range(n):
        if child[i] >= 0:
            continue
        area = 0.25 ** level[i]
        _mixture(stv[i], scales, weights, x0[i], y0[i], 0.5 ** level[i], mix)
        for v in range(nv):
            if integrals[v] <= 0.0:
                continue
            acc = 0.0
            for kk in range(9):
                q = _bilinear_at_stencil(mix, kk, floor) / mass
                g = stv[i, v, kk] / integrals[v]
                acc += SIMPSON[kk] * g * g / q
            chi2[v] += acc * area
    for v in range(nv):
        chi2[v] = max(chi2[v] - 1.0, 0.0)
    return corners, bounds, integrals, errors, chi2, envelope


@kernel
def _lobe_width(projection, view0, child, x0, y0, level):
    """The side of the leaf holding the node view's mirror point (:func:`make_ridge`)."""
    ma, mb = _mirror_point(view0, projection)
    return 0.5 ** level[_leaf_holding(child, x0, y0, level, ma, mb)]


@njit(nogil=True, cache=True)
def _finish(n, child, x0, y0, level, st, stv, m, scales, weights):
    """The node view's Simpson integral on the leaves (the normalizer has its own) and :func:`summarize`
    (which numbers the leaves in ``child``)."""
    fine = np.zeros(n)
    fine_err = np.zeros(n)
    for i in range(n):
        if child[i] == -1:
            h = 0.5 ** level[i]
            fine[i] = _rule(st[i], x0[i], y0[i], h)
            fine_err[i] = abs(fine[i] - _trapezoids(st[i], h * h))
    return summarize(n, child, x0, y0, level, st, stv, m, fine, fine_err, scales, weights)


@njit(nogil=True, cache=True)
def shape(mid, p, projection, views, weights, warp_tol, base_level, max_level, capacity):
    """Steps 1, 2 and 2b for one node: the rejection-free density's tree. Returns the arrays of
    :class:`TreeArrays` (no bounds: every ``K_L`` is 1), then what step 3 continues from (:class:`TreeShape`)."""
    nv = views.shape[0]
    child = np.empty(capacity, dtype=np.int32)
    x0 = np.empty(capacity)
    y0 = np.empty(capacity)
    level = np.empty(capacity, dtype=np.int32)
    # not zeroed (numba writes every byte of np.zeros, 7 MB a tree): a node's stencils are made with it
    st = np.empty((capacity, 9))
    stv = np.empty((capacity, nv, 9))
    n, _, evals = grow(
        mid, p, projection, views[0], warp_tol, base_level, max_level, child, x0, y0, level, st
    )
    # what the ridge is made from, taken from the grown tree (before step 2b splits it for the mixture)
    pa, pb = _peak(n, child, x0, y0, level, st)
    width = _lobe_width(projection, views[0], child, x0, y0, level)
    scales, e = view_stencils(mid, p, projection, views, n, child, x0, y0, level, st, stv)
    evals += e
    m = np.ones(capacity)
    no_ridge = np.zeros((0, 5))
    n, e = refine_warp(mid, p, projection, views, scales, np.zeros(nv), weights, no_ridge, np.zeros((0, 6)), warp_tol,
                       max_level, n, child, x0, y0, level, st, stv, m, 0.0)  # fmt: skip
    evals += e
    kept = child[:n].copy()
    corners, bounds, integrals, errors, chi2, envelope = _finish(n, child, x0, y0, level, st, stv, m, scales,
                                                                 weights)  # fmt: skip
    return (child[:n].copy(), x0[:n].copy(), y0[:n].copy(), level[:n].copy(), corners, bounds, integrals, errors,
            chi2, envelope, evals, kept, st[:n].copy(), stv[:n].copy(), scales, pa, pb, width)  # fmt: skip


@njit(nogil=True, cache=True)
def add_bounds(mid, p, projection, views, weights, cell, n_max, max_level, capacity, safety, angles, norm, norm_meta,
               child_s, x0_s, y0_s, level_s, st_s, stv_s, scales, pa, pb, width):  # fmt: skip
    """Step 3 for one node, continuing from its :func:`shape` (``child_s .. width``): the bounds, the
    acceptance's refinement and the probes. ``angles``: the ``(theta, phi)`` of the views; ``norm,
    norm_meta``: the exact mode's normalizer (:func:`inv_norm`). Returns the arrays of :class:`TreeArrays`."""
    n = child_s.shape[0]
    nv = views.shape[0]
    child = np.empty(capacity, dtype=np.int32)
    x0 = np.empty(capacity)
    y0 = np.empty(capacity)
    level = np.empty(capacity, dtype=np.int32)
    st = np.empty((capacity, 9))  # (as in shape: a node's stencils are made with it)
    stv = np.empty((capacity, nv, 9))
    child[:n] = child_s
    x0[:n] = x0_s
    y0[:n] = y0_s
    level[:n] = level_s
    st[:n] = st_s
    stv[:n] = stv_s
    m = np.zeros(capacity)
    bscales = np.zeros(nv)
    for v in range(nv):
        bscales[v] = inv_norm(norm, norm_meta, angles[v, 0], angles[v, 1])
    ridge_v, rscales, step = make_ridge(cell, projection, views[0], width, norm, norm_meta, safety)
    ridge, rho, evals = bound(mid, p, projection, views, ridge_v, weights, n, child, x0, y0, level, stv, m, safety,
                              scales, bscales, rscales, step, pa, pb)  # fmt: skip
    probed = np.zeros(capacity, dtype=np.bool_)
    mix, view, pts = np.empty(9), np.empty(6), np.empty(16)
    for _ in range(PROBE_ROUNDS):  # the acceptance, then the probes; a raised bound may call for more leaves
        n, envelope, e = refine(mid, p, projection, views, scales, bscales, weights, ridge, ridge_v, n_max, max_level, n,
                                child, x0, y0, level, st, stv, m, safety)  # fmt: skip
        evals += e
        # every leaf is probed, those of the last refinement too: a bound is never left unprobed (should the
        # rounds run out, a bound the last probes raise costs acceptance, not a violation)
        raised, e = probe(mid, p, projection, views, angles, cell, scales, weights, n, child, x0, y0, level, stv, m,
                          mid, probed, safety, norm, norm_meta, rho, mix, view, pts)  # fmt: skip
        evals += e
        if raised == 0:
            break
    corners, bounds, integrals, errors, chi2, envelope = _finish(n, child, x0, y0, level, st, stv, m, scales,
                                                                 weights)  # fmt: skip
    return (child[:n].copy(), x0[:n].copy(), y0[:n].copy(), level[:n].copy(), corners, bounds, integrals,
            errors, chi2, envelope, evals)  # fmt: skip


class TreeShape(NamedTuple):
    """What step 3 continues from: a node's tree after steps 1, 2 and 2b (``n`` nodes, ``v`` views)."""

    child: np.ndarray
    """``(n,)`` int32: a node's first child, or -1 for a leaf (not yet numbered)."""
    x0: np.ndarray
    y0: np.ndarray
    level: np.ndarray
    st: np.ndarray
    """``(n, 9)``: the node view's stencils."""
    stv: np.ndarray
    """``(n, v, 9)``: every view's stencils (those of inner nodes as they were when split)."""
    scales: np.ndarray
    """``(v,)``: ``1 / I_v`` of the mixture."""
    peak: tuple[float, float]
    """The node view's largest ``g`` among the grown tree's stencil points (:func:`_ridge`)."""
    width: float
    """The lobe's width for the ridge's steps (:func:`make_ridge`)."""


def shape_tree(mid: int, p: np.ndarray, projection: int, views: np.ndarray, weights: np.ndarray,
               settings: BuildSettings) -> tuple[TreeArrays, TreeShape]:  # fmt: skip
    """One node's tree without bounds (``views[0]`` is the node; the others span its cell, with the mixture's
    ``weights``): the rejection-free mode's tree, and what :func:`bound_tree` continues from."""
    out = shape(
        int(mid), np.ascontiguousarray(p, dtype=np.float64), int(projection),
        np.ascontiguousarray(views, dtype=np.float64), np.ascontiguousarray(weights, dtype=np.float64),
        float(settings.warp_tol), int(settings.base_level), int(settings.max_level), int(settings.capacity),
    )  # fmt: skip
    tree = TreeArrays(*out[:9], envelope=float(out[9]), evaluations=int(out[10]))
    kept, st, stv, scales, pa, pb, width = out[11:]
    return tree, TreeShape(
        kept, tree.x0, tree.y0, tree.level, st, stv, scales, (float(pa), float(pb)), float(width)
    )


def bound_tree(shaped: TreeShape, mid: int, p: np.ndarray, projection: int, views: np.ndarray,
               weights: np.ndarray, cell: np.ndarray, settings: BuildSettings, angles: np.ndarray, norm: np.ndarray,
               norm_meta: np.ndarray) -> TreeArrays:  # fmt: skip
    """The exact mode's tree from a node's :func:`shape_tree` (the same ``views`` and ``weights``; ``cell =
    theta_lo, theta_hi, phi_lo, phi_hi, follow``; ``angles``: each view's ``(theta, phi)``; ``norm,
    norm_meta``: the exact mode's normalizer, whose ``g / c`` the bounds bound, :func:`inv_norm`). Its
    evaluations are step 3's only."""
    out = add_bounds(
        int(mid), np.ascontiguousarray(p, dtype=np.float64), int(projection),
        np.ascontiguousarray(views, dtype=np.float64), np.ascontiguousarray(weights, dtype=np.float64),
        np.ascontiguousarray(cell, dtype=np.float64), float(settings.n_max), int(settings.max_level),
        int(settings.capacity), float(settings.bound_safety), np.ascontiguousarray(angles, dtype=np.float64),
        np.ascontiguousarray(norm, dtype=np.float64), np.ascontiguousarray(norm_meta, dtype=np.float64),
        shaped.child, shaped.x0, shaped.y0, shaped.level, shaped.st, shaped.stv, shaped.scales,
        shaped.peak[0], shaped.peak[1], shaped.width,
    )  # fmt: skip
    return TreeArrays(*out[:9], envelope=float(out[9]), evaluations=int(out[10]))


QUAD_CAPACITY = 32
"""The normalizer's quadrature may use this many times a tree's capacity in cells (they are folded into the
view's tree and dropped, and only the pages they touch are used): a lobe along the whole horizon, thinner than
a level-12 cell (BRDF Explorer's ``g_duer.brdf``, ``|L + V|^2 / (N.(L + V))^4``, at 89-89.9 degrees: a ring
``cos(theta_o) / 3`` above it), fills a tree's 16 384 nodes before the quadrature starts."""

QUAD_MAX_LEVEL = 20
"""The quadrature's deepest cells (the trees' leaves stop at ``max_level``, 12; the cells are not stored)."""


@njit(nogil=True, cache=True)
def view_integral(mid, p, projection, view, warp_tol, quad_tol, base_level, max_level, capacity):
    """``I`` of one view to ``quad_tol`` (relative, by its own estimate): step 1's tree, then step 4.
    Returns ``(I, estimated error, evaluations)``. The exact mode's normalizer is interpolated from these, at
    polar angles of its own (:func:`core.sampling.adaptive.table.build_table`): a node's tree is not needed
    where only the normalizer asks for another node."""
    cells = capacity * QUAD_CAPACITY
    child = np.empty(cells, dtype=np.int32)
    x0 = np.empty(cells)
    y0 = np.empty(cells)
    level = np.empty(cells, dtype=np.int32)
    st = np.empty((cells, 9))  # (as in shape: a node's stencils are made with it; pages untouched stay free)
    n, _, evals = grow(mid, p, projection, view, warp_tol, base_level, max_level, child[:capacity], x0, y0, level,
                       st)  # fmt: skip
    fine = np.zeros(cells)
    fine_err = np.zeros(cells)
    n_keep = n
    n, e = quadrature(mid, p, projection, view, quad_tol, QUAD_MAX_LEVEL, n, child, x0, y0, level, st, fine,
                      fine_err)  # fmt: skip
    _fold_quadrature(n_keep, n, child, fine, fine_err)
    total = 0.0
    err = 0.0
    for i in range(n_keep):
        if child[i] == -1:
            total += fine[i]
            err += fine_err[i]
    return total, err, evals + e


def acceptance(tree: TreeArrays) -> float:
    return 1.0 / tree.envelope if tree.envelope > 0.0 else 0.0
