"""Step 4 (see :mod:`core.sampling.adaptive.tree`): one view's integral to a tolerance, for the exact mode's
normalizer, in cells below a tree's leaves."""

from __future__ import annotations

import numpy as np
from numba import njit

from core.jit import kernel
from core.sampling.adaptive.tree.grow import grow
from core.sampling.adaptive.tree.nodes import (
    SPLIT_EVALUATIONS,
    Nodes,
    Target,
    _children,
    _on_diagonal,
    _rule,
    _split,
    _trapezoids,
)

QUAD_CAPACITY = 32
"""The normalizer's quadrature may use this many times a tree's capacity in cells (they are folded into the
view's tree and dropped, and only the pages they touch are used): a lobe along the whole horizon, thinner than
a level-12 cell (BRDF Explorer's ``g_duer.brdf``, ``|L + V|^2 / (N.(L + V))^4``, at 89-89.9 degrees: a ring
``cos(theta_o) / 3`` above it), fills a tree's 16 384 nodes before the quadrature starts."""

QUAD_MAX_LEVEL = 20
"""The quadrature's deepest cells (the trees' leaves stop at ``max_level``, 12; the cells are not stored)."""


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
def _trial_split(tg, view, nodes, i, n, max_level, trial):
    """The rule on leaf ``i``'s four children (made in slots ``n .. n + 3`` and dropped again, their stencils
    kept in ``trial[i]`` for a split for good, :func:`_split_tried`): returns the extrapolated integral, its
    estimated error and the evaluations made."""
    child, x0, y0, level, st = nodes
    h = 0.5 ** level[i]
    coarse = _rule(st[i], x0[i], y0[i], h)
    if level[i] >= max_level or n + 4 > child.shape[0]:
        # no room or depth to try it: the rule's own difference from the trapezoids is its error (0 here
        # would read the whole integral as converged: g_duer's ring along the horizon at 89 degrees)
        return coarse, abs(coarse - _trapezoids(st[i], h * h)), 0
    end = _split(tg, view, nodes, i, n)
    s = 0.0
    for c in range(n, end):
        s += _rule(st[c], x0[c], y0[c], 0.5 * h)
        for k in range(9):
            trial[i, c - n, k] = st[c, k]
    child[i] = -1
    divisor = _richardson_divisor(x0[i], y0[i], h)
    return s + (s - coarse) / divisor, abs(s - coarse) / divisor, SPLIT_EVALUATIONS


@kernel
def _split_tried(nodes, i, n, trial):
    """:func:`~.nodes._split` of a leaf split on trial before: its children's stencils are those the trial
    made."""
    _children(nodes, i, n)
    for q in range(4):
        for k in range(9):
            nodes.st[n + q, k] = trial[i, q, k]
    return n + 4


@njit(nogil=True, cache=True)
def quadrature(tg, view, quad_tol, max_level, nodes, n, fine, fine_err):
    """Step 4: the node view's integral to ``quad_tol`` (relative, the whole square), in cells below the
    sampling tree's leaves (the caller folds them back into their leaf: they are not stored).

    Every leaf is split on trial: the rule on its four children against its own estimates the error (a
    Richardson step) and gives a better integral (``fine``, error ``fine_err``). While the errors add up to
    more than ``quad_tol * I``, the cells with the largest errors are split for good (into the children their
    trial made: no evaluation) and tried in turn: the fewest cells that reach the tolerance. Returns
    ``(nodes, evaluations)``."""
    child, level = nodes.child, nodes.level
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
                fine[i], fine_err[i], e = _trial_split(tg, view, nodes, i, n, max_level, trial)
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
            n = _split_tried(nodes, i, n, trial)  # every leaf here was split on trial
            removed += errs[i]
            k += 1
        if k == 0:
            break
    for i in range(n):  # leaves split in the last round
        if child[i] == -1 and not known[i]:
            fine[i], fine_err[i], e = _trial_split(tg, view, nodes, i, n, max_level, trial)
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


@njit(nogil=True, cache=True)
def view_integral(mid, p, projection, view, warp_tol, quad_tol, base_level, max_level, capacity):
    """``I`` of one view to ``quad_tol`` (relative, by its own estimate): step 1's tree, then step 4.
    Returns ``(I, estimated error, evaluations)``. The exact mode's normalizer is interpolated from these, at
    polar angles of its own (:func:`core.sampling.adaptive.table.build_table`): a node's tree is not needed
    where only the normalizer asks for another node."""
    tg = Target(mid, p, projection)
    cells = capacity * QUAD_CAPACITY
    child = np.empty(cells, dtype=np.int32)
    x0 = np.empty(cells)
    y0 = np.empty(cells)
    level = np.empty(cells, dtype=np.int32)
    st = np.empty((cells, 9))  # (as in shape: a node's stencils are made with it; pages untouched stay free)
    n, _, evals = grow(tg, view, Nodes(child[:capacity], x0, y0, level, st), warp_tol, base_level, max_level)
    fine = np.zeros(cells)
    fine_err = np.zeros(cells)
    n_keep = n
    n, e = quadrature(tg, view, quad_tol, QUAD_MAX_LEVEL, Nodes(child, x0, y0, level, st), n, fine, fine_err)
    _fold_quadrature(n_keep, n, child, fine, fine_err)
    total = 0.0
    err = 0.0
    for i in range(n_keep):
        if child[i] == -1:
            total += fine[i]
            err += fine_err[i]
    return total, err, evals + e
