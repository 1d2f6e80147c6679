"""A node's tree from start to end: the two calls that run the steps (:func:`shape_tree`, :func:`bound_tree`)
and the summary of a finished tree (see :mod:`core.sampling.adaptive.tree`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from core.sampling.adaptive.tree.bounds import BOUND_SAFETY, bound, inv_norm, make_ridge, refine
from core.sampling.adaptive.tree.grow import _lobe_width, _peak, grow, refine_warp, view_stencils
from core.sampling.adaptive.tree.nodes import (
    CORNERS,
    FLOOR,
    SIMPSON,
    CellViews,
    Nodes,
    Normalizer,
    Target,
    _bilinear_at_stencil,
    _mixture,
    _rule,
    _trapezoids,
)
from core.sampling.adaptive.tree.probe import PROBE_ROUNDS, Cell, ProbeState, probe


class BuildSettings(NamedTuple):
    """What a tree's construction is asked for (see :mod:`core.sampling.adaptive.tree`)."""

    n_max: float
    warp_tol: float
    quad_tol: float
    base_level: int
    max_level: int
    capacity: int
    """Nodes a tree may have."""
    bound_safety: float = BOUND_SAFETY
    """Factor on each leaf's bound (:data:`~.bounds.ANISOTROPIC_BOUND_SAFETY` for an anisotropic material's
    trees); 0: no bounds at all (steps 3 and 3b skipped: a table for the rejection-free mode only)."""


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
    the order of :data:`~.nodes.CORNERS`."""
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
    """The node view's largest ``g`` among the grown tree's stencil points (:func:`~.bounds._ridge`)."""
    width: float
    """The lobe's width for the ridge's steps (:func:`~.bounds.make_ridge`)."""


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
    touch, so a caller's stratified numbers stay spread over the square (the nodes' index order is
    breadth-first-like and jumps across it). A node the root does not reach (none is expected) is numbered
    after the others, in index order."""
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
def summarize(nodes, n, stv, m, fine, fine_err, scales, weights):
    """Leaf numbering (:func:`_number_leaves`), corner values (the cell's mixture, floor included), the views'
    integrals, errors and chi^2, and the envelope."""
    child, x0, y0, level = nodes.child, nodes.x0, nodes.y0, nodes.level
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


@njit(nogil=True, cache=True)
def _finish(nodes, n, stv, m, scales, weights, evals):
    """The node view's Simpson integral on the leaves (the normalizer has its own) and :func:`summarize`
    (which numbers the leaves in ``nodes.child``): the finished :class:`TreeArrays`."""
    child, x0, y0, level, st = nodes
    fine = np.zeros(n)
    fine_err = np.zeros(n)
    for i in range(n):
        if child[i] == -1:
            h = 0.5 ** level[i]
            fine[i] = _rule(st[i], x0[i], y0[i], h)
            fine_err[i] = abs(fine[i] - _trapezoids(st[i], h * h))
    corners, bounds, integrals, errors, chi2, envelope = summarize(nodes, n, stv, m, fine, fine_err, scales,
                                                                   weights)  # fmt: skip
    return TreeArrays(child[:n].copy(), x0[:n].copy(), y0[:n].copy(), level[:n].copy(), corners, bounds,
                      integrals, errors, chi2, envelope, evals)  # fmt: skip


@njit(nogil=True, cache=True)
def _room(capacity, nv):
    """Empty nodes for ``capacity`` of them and their stencils at ``nv`` views (not zeroed: numba writes
    every byte of ``np.zeros``, 7 MB a tree, and a node's stencils are made with it)."""
    nodes = Nodes(np.empty(capacity, dtype=np.int32), np.empty(capacity), np.empty(capacity),
                  np.empty(capacity, dtype=np.int32), np.empty((capacity, 9)))  # fmt: skip
    return nodes, np.empty((capacity, nv, 9))


@njit(nogil=True, cache=True)
def shape(mid, p, projection, views, weights, warp_tol, base_level, max_level, capacity):
    """Steps 1, 2 and 2b for one node: the rejection-free density's tree (:class:`TreeArrays`, no bounds: every
    ``K_L`` is 1) and what step 3 continues from (:class:`TreeShape`)."""
    tg = Target(mid, p, projection)
    nv = views.shape[0]
    nodes, stv = _room(capacity, nv)
    n, _, evals = grow(tg, views[0], nodes, warp_tol, base_level, max_level)
    # what the ridge is made from, taken from the grown tree (before step 2b splits it for the mixture)
    pa, pb = _peak(nodes, n)
    width = _lobe_width(projection, views[0], nodes)
    scales, e = view_stencils(tg, views, nodes, n, stv)
    evals += e
    cv = CellViews(views, weights, scales, np.zeros(nv), np.zeros((nv, 2)))
    n, e = refine_warp(tg, cv, nodes, stv, warp_tol, max_level, n)
    evals += e
    kept = nodes.child[:n].copy()
    tree = _finish(nodes, n, stv, np.ones(capacity), scales, weights, evals)
    return tree, TreeShape(kept, tree.x0, tree.y0, tree.level, nodes.st[:n].copy(), stv[:n].copy(), scales,
                           (pa, pb), width)  # fmt: skip


@njit(nogil=True, cache=True)
def add_bounds(tg, views, weights, angles, cell, shaped, nm, n_max, max_level, capacity, safety):
    """Step 3 for one node, continuing from its :func:`shape` (``shaped``): the bounds, the acceptance's
    refinement and the probes. ``angles``: the ``(theta, phi)`` of the views; ``nm``: the exact mode's
    normalizer (:func:`~.bounds.inv_norm`). Returns the :class:`TreeArrays`."""
    n = shaped.child.shape[0]
    nv = views.shape[0]
    nodes, stv = _room(capacity, nv)
    nodes.child[:n] = shaped.child
    nodes.x0[:n] = shaped.x0
    nodes.y0[:n] = shaped.y0
    nodes.level[:n] = shaped.level
    nodes.st[:n] = shaped.st
    stv[:n] = shaped.stv
    m = np.zeros(capacity)
    bscales = np.zeros(nv)
    for v in range(nv):
        bscales[v] = inv_norm(nm.table, nm.meta, angles[v, 0], angles[v, 1])
    cv = CellViews(views, weights, shaped.scales, bscales, angles)
    ridge_v, rscales, step = make_ridge(
        cell, tg.projection, views[0], shaped.width, nm.table, nm.meta, safety
    )
    ridge, rho, evals = bound(tg, cv, ridge_v, nodes, n, stv, m, safety, rscales, step, shaped.peak[0],
                              shaped.peak[1])  # fmt: skip
    walk = Cell(cell, cell[3] > cell[2], cell[4] > 0.5)
    state = ProbeState(np.zeros(capacity, dtype=np.bool_), np.empty(9), np.empty(6), np.empty(16))
    for _ in range(PROBE_ROUNDS):  # the acceptance, then the probes; a raised bound may call for more leaves
        n, envelope, e = refine(tg, cv, ridge, ridge_v, nodes, stv, m, n_max, max_level, n, safety)
        evals += e
        # every leaf is probed, those of the last refinement too: a bound is never left unprobed (should the
        # rounds run out, a bound the last probes raise costs acceptance, not a violation)
        raised, e = probe(tg, cv, walk, nodes, n, stv, m, tg.mid, safety, nm, rho, state)
        evals += e
        if raised == 0:
            break
    return _finish(nodes, n, stv, m, shaped.scales, weights, evals)


def shape_tree(mid: int, p: np.ndarray, projection: int, views: np.ndarray, weights: np.ndarray,
               settings: BuildSettings) -> tuple[TreeArrays, TreeShape]:  # fmt: skip
    """One node's tree without bounds (``views[0]`` is the node; the others span its cell, with the mixture's
    ``weights``): the rejection-free mode's tree, and what :func:`bound_tree` continues from."""
    return shape(
        int(mid), np.ascontiguousarray(p, dtype=np.float64), int(projection),
        np.ascontiguousarray(views, dtype=np.float64), np.ascontiguousarray(weights, dtype=np.float64),
        float(settings.warp_tol), int(settings.base_level), int(settings.max_level), int(settings.capacity),
    )  # fmt: skip


def bound_tree(shaped: TreeShape, mid: int, p: np.ndarray, projection: int, views: np.ndarray,
               weights: np.ndarray, cell: np.ndarray, settings: BuildSettings, angles: np.ndarray, norm: np.ndarray,
               norm_meta: np.ndarray) -> TreeArrays:  # fmt: skip
    """The exact mode's tree from a node's :func:`shape_tree` (the same ``views`` and ``weights``; ``cell =
    theta_lo, theta_hi, phi_lo, phi_hi, follow``; ``angles``: each view's ``(theta, phi)``; ``norm,
    norm_meta``: the exact mode's normalizer, whose ``g / c`` the bounds bound, :func:`~.bounds.inv_norm`).
    Its evaluations are step 3's only."""
    f64 = np.float64
    return add_bounds(
        Target(int(mid), np.ascontiguousarray(p, dtype=f64), int(projection)),
        np.ascontiguousarray(views, dtype=f64), np.ascontiguousarray(weights, dtype=f64),
        np.ascontiguousarray(angles, dtype=f64), np.ascontiguousarray(cell, dtype=f64),
        shaped,
        Normalizer(np.ascontiguousarray(norm, dtype=f64), np.ascontiguousarray(norm_meta, dtype=f64)),
        float(settings.n_max), int(settings.max_level), int(settings.capacity), float(settings.bound_safety),
    )  # fmt: skip


def acceptance(tree: TreeArrays) -> float:
    return 1.0 / tree.envelope if tree.envelope > 0.0 else 0.0
