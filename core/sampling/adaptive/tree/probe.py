"""Step 3b of a tree (see :mod:`core.sampling.adaptive.tree`): the bounds checked between the stencils'
points and between the views, by random probes and compass climbs of the ratio ``g / (c q)``."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from core.jit import kernel
from core.rng import next_u01, stream
from core.sampling.adaptive.target import g_at
from core.sampling.adaptive.tree.bounds import _view_row, inv_norm
from core.sampling.adaptive.tree.nodes import FLOOR, _bilinear_at_stencil, _mixture

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

INV_NORM_GRID = 257
"""Polar angles (and, across an azimuth range, 17 azimuths) at which :func:`_inv_norm_top` reads ``1 / c``
over a cell: finer than the normalizer's table near the horizon, where its rows are densest in theta."""

INV_NORM_MARGIN = 1.25
"""Factor on the largest ``1 / c`` read on that grid: the cubic between its points rises far less."""

CLIMB_STEP = 0.125
"""The climb's first step (:func:`_climb`), in units of the leaf's side and of the cell's extent in theta
(and phi): an eighth, the spacing of a stencil's points halved twice."""

CLIMB_MIN_STEP = 1.0 / 256.0
"""The climb stops once its step is below this (five halvings of :data:`CLIMB_STEP`)."""

CLIMB_EVALUATIONS = 64
"""Evaluations of ``g`` a climb may make at most."""


class ProbeState(NamedTuple):
    """What the probes keep between rounds, and their scratch rows."""

    probed: np.ndarray
    """``(room,)`` bool: the leaves already probed."""
    mix: np.ndarray
    """``(9,)`` scratch: a leaf's mixture on its stencil."""
    view: np.ndarray
    """``(6,)`` scratch: the view row of a probe."""
    pts: np.ndarray
    """``(16,)`` scratch: the climb's point and trial (0-7), the two best probes (8-15)."""


class Cell(NamedTuple):
    """The cell a tree serves, as the probes walk it."""

    bounds: np.ndarray
    """``theta_lo, theta_hi, phi_lo, phi_hi, follow``."""
    azimuths: bool
    """Whether the cell spans azimuths (``phi_hi > phi_lo``)."""
    follow: bool
    """Whether the square turns with the view's azimuth."""


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


@kernel
def _inv_norm_top(norm, norm_meta, cell):
    """An upper bound of ``1 / c`` (:func:`~.bounds.inv_norm`) over the cell ``theta_lo, theta_hi, phi_lo,
    phi_hi``: the largest value on a grid finer than the normalizer's table, times :data:`INV_NORM_MARGIN`."""
    n_phi = 17 if cell[3] > cell[2] else 1
    top = 0.0
    for t in range(INV_NORM_GRID):
        theta = cell[0] + (cell[1] - cell[0]) * t / (INV_NORM_GRID - 1)
        for j in range(n_phi):
            phi = cell[2] + (cell[3] - cell[2]) * j / max(n_phi - 1, 1)
            top = max(top, inv_norm(norm, norm_meta, theta, phi))
    return top * INV_NORM_MARGIN


@njit(inline="always", nogil=True, cache=True)
def _g_in_leaf(tg, cell, view, leaf, u1, u2, t, w):
    """``(g, q, theta, phi)``: ``g`` at point ``(u1, u2)`` of the leaf (``leaf = x0, y0, h, c0, c1, c2, c3``: its
    square and its corner densities), ``q`` the corners' bilinear interpolant there, at the view ``t, w`` of the
    way across the cell in theta and phi (``view (6,)`` is scratch, its constant entries set by the caller)."""
    x0, y0, h, c0, c1, c2, c3 = leaf
    box = cell.bounds
    theta = box[0] + t * (box[1] - box[0])
    phi = box[2] + w * (box[3] - box[2])
    if cell.azimuths:
        _view_row(theta, phi, cell.follow, view)
    else:
        view[0] = math.sin(theta)
        view[2] = math.cos(theta)
    qq = (1.0 - u1) * (1.0 - u2) * c0 + u1 * (1.0 - u2) * c1 + (1.0 - u1) * u2 * c2 + u1 * u2 * c3
    return g_at(tg.mid, tg.p, x0 + u1 * h, y0 + u2 * h, tg.projection, view), qq, theta, phi


@kernel
def _ratio_at(tg, cell, view, leaf, rho, nm, u1, u2, t, w):
    """``rho g / (c q)`` at point ``(u1, u2)`` of the leaf and the view ``t, w`` of the way across the cell
    (:func:`_g_in_leaf`; all four corner densities 1: ``rho g / c`` itself)."""
    g, qq, theta, phi = _g_in_leaf(tg, cell, view, leaf, u1, u2, t, w)
    if not g > 0.0:
        return 0.0
    return g * rho * inv_norm(nm.table, nm.meta, theta, phi) / qq


@kernel
def _climb(tg, cell, view, leaf, rho, nm, x, fx, trial):
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
    dims = 4 if cell.azimuths else 3
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
                fy = _ratio_at(tg, cell, view, leaf, rho, nm, trial[0], trial[1], trial[2], trial[3])
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
def probe(tg, cv, cell, nodes, n, stv, m, seed, safety, nm, rho, state):
    """Step 3b: every leaf's bound checked at ``PROBES`` random points, each at a random view of the cell,
    then by three climbs (:func:`_climb`), from the two best probes and from the stencils' largest ratio
    (at its view's ``cv.angles``): between the stencils' points and between the views, where no rule covers
    it. A bound found short is raised to ``PROBE_MARGIN`` times the ratio seen (against ``rho g / c`` at the
    probe's view, :func:`~.bounds.inv_norm`, ``rho`` from :func:`~.bounds.bound`; ``1 / c`` is read only where
    the cell's largest could beat the best ratio seen). Returns the number of bounds raised and the
    evaluations made; the leaves probed are marked in ``state.probed``."""
    child, x0, y0, level = nodes.child, nodes.x0, nodes.y0, nodes.level
    probed, mix, view, pts = state
    angles = cv.angles
    box = cell.bounds
    raised = 0
    evals = 0
    view[5] = 1.0
    if not cell.azimuths:  # one azimuth, 0: the view's turn is none (as _view_row makes it at phi = 0)
        view[1] = 0.0
        view[3] = 1.0
        view[4] = 0.0
    # a probe whose ratio cannot beat the best one seen even at the cell's largest 1 / c needs no 1 / c
    top = rho * _inv_norm_top(nm.table, nm.meta, box)
    span_t = box[1] - box[0]
    span_w = box[3] - box[2]
    x = pts[0:4]
    trial = pts[4:8]
    for i in range(n):
        if child[i] != -1 or probed[i]:
            continue
        probed[i] = True
        h = 0.5 ** level[i]
        _mixture(stv[i], cv.scales, cv.weights, x0[i], y0[i], h, mix)
        c0 = mix[0] + FLOOR
        c1 = mix[2] + FLOOR
        c2 = mix[6] + FLOOR
        c3 = mix[8] + FLOOR
        leaf = (x0[i], y0[i], h, c0, c1, c2, c3)
        rng = stream(seed, i)
        worst = 0.0
        second = 0.0
        count = min(PROBES * 4 ** max(0, 5 - level[i]), 8 * PROBES)
        if _has_front(stv[i]):
            count = 8 * PROBES
        for _ in range(count):
            rng, u1 = next_u01(rng)
            rng, u2 = next_u01(rng)
            rng, u3 = next_u01(rng)
            rng, u4 = next_u01(rng)
            g, qq, theta, phi = _g_in_leaf(tg, cell, view, leaf, u1, u2, u3, u4)
            if g * top / qq > second:
                r = g * rho * inv_norm(nm.table, nm.meta, theta, phi) / qq
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
                r, e = _climb(tg, cell, view, leaf, rho, nm, x, f0, trial)
                evals += e
                worst = max(worst, r)
        # and from the stencils' largest ratio (at its view's place in the cell)
        best = 0.0
        kb = 0
        vb = 0
        for v in range(stv.shape[1]):
            s_v = inv_norm(nm.table, nm.meta, angles[v, 0], angles[v, 1])
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
            x[2] = min(max((angles[vb, 0] - box[0]) / span_t, 0.0), 1.0) if span_t > 0.0 else 0.0
            x[3] = min(max((angles[vb, 1] - box[2]) / span_w, 0.0), 1.0) if span_w > 0.0 else 0.0
            f0 = _ratio_at(tg, cell, view, leaf, rho, nm, x[0], x[1], x[2], x[3])
            r, e = _climb(tg, cell, view, leaf, rho, nm, x, f0, trial)
            evals += e + 1
            worst = max(worst, r)
        if worst * safety > m[i] * (1.0 + PROBE_TIE):
            m[i] = worst * PROBE_MARGIN
            raised += 1
    return raised, evals
