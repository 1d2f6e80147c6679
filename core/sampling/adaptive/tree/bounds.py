"""Steps 2 and 3 of a tree (see :mod:`core.sampling.adaptive.tree`): the exact mode's leaf bounds and the
refinement for the acceptance."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.jit import kernel
from core.sampling.adaptive.layout import normalizer_at
from core.sampling.adaptive.target import g_at
from core.sampling.adaptive.tree.grow import _child_view_stencils
from core.sampling.adaptive.tree.nodes import (
    FLOOR,
    SPLIT_EVALUATIONS,
    _bilinear_at_stencil,
    _mirror_point,
    _mixture,
    _split,
)

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

RIDGE_STEPS = 17
"""Polar angles across a cell at which the lobe's ridge is followed at least (and 5 azimuths when
anisotropic); more where the lobe is narrow against the mirror direction's motion across the cell
(:func:`make_ridge`), up to :data:`RIDGE_MAX_STEPS`."""

RIDGE_MAX_STEPS = 65
"""Every leaf near the ridge looks at every ridge point: at 513 steps an anisotropic tree (5 azimuths) spent
more there than on ``f`` (Ashikhmin-Shirley nu=10 nv=200's exact table: 7.8 s of CPU)."""


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
def _leaf_bound(tg, cv, ridge, ridge_views, nodes, i, stv, safety, work):
    """``K_L``, a bound of ``(g_v / c_v) / q`` on leaf ``i`` for every view of the cell (``cv.bscales[v] =
    1 / c_v``, :func:`inv_norm`), ``q`` the leaf's bilinear density (its stencils at every view must be in
    ``stv[i]``); returns ``(K, evaluations)`` (``(1, 0)`` when ``safety`` is 0: a table without bounds).
    ``work (3, 9)`` is scratch."""
    if safety <= 0.0:
        return 1.0, 0
    x0, y0, level = nodes.x0, nodes.y0, nodes.level
    h = 0.5 ** level[i]
    mix = work[0]
    _mixture(stv[i], cv.scales, cv.weights, x0[i], y0[i], h, mix)
    q = work[1]
    for k in range(9):
        q[k] = _bilinear_at_stencil(mix, k, FLOOR)
    ratio = work[2]
    m = 0.0
    for v in range(cv.views.shape[0]):
        top = 0.0
        for k in range(9):
            ratio[k] = stv[i, v, k] * cv.bscales[v] / q[k]
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
        m = max(m, g_at(tg.mid, tg.p, a, b, tg.projection, ridge_views[v]) * ridge[r, 3] / qq)
        evals += 1
    if x0[i] == 0.0 or y0[i] == 0.0 or x0[i] + h == 1.0 or y0[i] + h == 1.0:
        safety *= RIM_BOUND_SAFETY
    # at least the density itself: where g was 0 at every point seen (beyond a front, such as the horizon's
    # through a half-vector disk), it may not be between them at another view of the cell
    return max(m * safety, 1.0), evals


@njit(nogil=True, cache=True)
def _ridge(projection, views, ridge_views, pa, pb, rscales, step):
    """Ridge points ``(r, 5)``: ``(a, b, view, scale, step)`` of the mirror direction of each of the
    ``ridge_views`` (a finer set than the stencils' views: a lobe narrower than their spacing is still met),
    and of the node view's peak ``(pa, pb)`` (:func:`~.grow._peak`) moved with it; ``scale`` is ``1 / c`` at
    the ridge view (:func:`inv_norm`), ``step`` the distance between neighbouring ridge points on the
    square."""
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
    grown, :func:`~.grow._lobe_width`): a peak between two ridge points is then no higher than theirs, give
    or take the bound's safety factor. (Cook-Torrance m = 0.005's rare violations between the nodes were the
    same with 17 steps and with more: they are off the ridge, see ``docs/adaptive.md`` section 4.)"""
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


@njit(nogil=True, cache=True)
def bound(tg, cv, ridge_views, nodes, n, stv, m, safety, rscales, step, pa, pb):
    """Step 3: every leaf's bound ``m`` (its stencils at every view already made,
    :func:`~.grow.view_stencils`).

    Returns ``(ridge, rho, evaluations)``: the bounds are on ``g_v / c_v``, ``cv.bscales`` raised in place
    where ``1 / I_v`` is larger; ``rho`` the factor on ``1 / c`` between the views (``rscales`` multiplied by
    it in place)."""
    scales, bscales = cv.scales, cv.bscales
    nv = cv.views.shape[0]
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
    ridge = _ridge(tg.projection, cv.views, ridge_views, pa, pb, rscales, step)
    evals = 0
    work = np.empty((3, 9))
    for i in range(n):
        if nodes.child[i] == -1:
            m[i], e = _leaf_bound(tg, cv, ridge, ridge_views, nodes, i, stv, safety, work)
            evals += e
    return ridge, rho, evals


@njit(nogil=True, cache=True)
def refine(tg, cv, ridge, ridge_views, nodes, stv, m, n_max, max_level, n, safety):
    """Step 3: split the leaves with the largest excess ``(K_L - 1) q_L`` until the envelope's mass
    ``V = sum K_L q_L <= n_max / (1 + ACCEPT_MARGIN)`` (``q_L`` the leaf's mass under the density).

    Returns ``(nodes, V, evaluations)``."""
    child, x0, y0, level = nodes.child, nodes.x0, nodes.y0, nodes.level
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
                q = _leaf_mass(stv[i], cv.scales, cv.weights, x0[i], y0[i], 0.5 ** level[i], work[0])
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
                n = _split(tg, cv.views[0], nodes, i, n)
                evals += SPLIT_EVALUATIONS
                for c in range(n - 4, n):
                    evals += _child_view_stencils(tg, cv.views, nodes, i, c - (n - 4), c, stv)
                    m[c], e = _leaf_bound(tg, cv, ridge, ridge_views, nodes, c, stv, safety, work)
                    evals += e
        if n == end:
            break
    total = 0.0
    for i in range(n):
        if child[i] == -1:
            total += m[i] * _leaf_mass(stv[i], cv.scales, cv.weights, x0[i], y0[i], 0.5 ** level[i], work[0])
    return n, total, evals
