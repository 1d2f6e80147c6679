"""Compiled inner loops of the tree construction (:mod:`core.quadtree`).

The construction's algorithm is described in :mod:`core.quadtree`; this module holds its per-node work as
numba loops, one pass per call over the listed nodes: the integrals of ``g`` over each node's part of the disk
(the exact-region rule), the leaf bounds (candidate points, then a compass search in ``(X, Y, theta_o,
phi_o)``) and the peak search of the ridge setup. Before, the same work ran as 60-100 vectorized numpy passes
per tree over arrays of candidate points; per point the arithmetic is the same, in the same order (ties are
broken towards the first candidate, as ``np.argmax`` does), so a tree is unchanged up to rounding.

The model's ``eval`` is bound as a global of a generated module per model (:func:`build_kernels`), so numba
caches these loops on disk like the sampler's (:mod:`core.quadtree_kernels`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

R_MAX = 1.0 - 1e-12
"""Probes and the search stay inside this radius (g is 0 on and outside the unit circle)."""


@njit(nogil=True, cache=True)
def box_rule(x0, y0, x1, y1, gx, gw, X, Y, W):
    """Quadrature points and weights (written to ``X, Y, W`` from 0; returns their count) for the integral over
    the box ``[x0, x1] x [y0, y1]`` intersected with the unit disk.

    Iterated Gauss-Legendre: the outer variable is the one along which the circle is far from vertical
    (``x`` when the box centre has ``|x| < |y|``, else ``y``); the outer interval is split where the circle
    crosses the box's inner edges, so that on each piece the inner limits are smooth. When an inner limit lies
    on the circle the inner variable is ``v = s sin(psi)``, ``s = sqrt(1 - u^2)``: the distance to the rim is
    then smooth in ``psi`` and square-root behaviour of the integrand at the rim does not spoil the rule.
    """
    n = 0
    if not (x1 > x0 and y1 > y0):
        return n
    k = gx.shape[0]
    swap = abs(0.5 * (x0 + x1)) >= abs(0.5 * (y0 + y1))
    if swap:
        u0, u1, v0, v1 = y0, y1, x0, x1
    else:
        u0, u1, v0, v1 = x0, x1, y0, y1
    u0 = max(u0, -1.0)
    u1 = min(u1, 1.0)
    if u1 <= u0:
        return n
    cuts = np.empty(6)
    nc = 0
    cuts[nc] = u0
    nc += 1
    for vb in (v0, v1):
        if abs(vb) < 1.0:
            ub = math.sqrt(1.0 - vb * vb)
            if u0 < -ub < u1:
                cuts[nc] = -ub
                nc += 1
            if u0 < ub < u1:
                cuts[nc] = ub
                nc += 1
    cuts[nc] = u1
    nc += 1
    cs = np.sort(cuts[:nc])
    for seg in range(nc - 1):
        a = cs[seg]
        b = cs[seg + 1]
        if b <= a:
            continue
        for i in range(k):
            u = a + (b - a) * gx[i]
            wu = (b - a) * gw[i]
            s = math.sqrt(max(0.0, 1.0 - u * u))
            lo = max(v0, -s)
            hi = min(v1, s)
            if hi <= lo or s <= 0.0:
                continue
            if lo == -s or hi == s:
                plo = math.asin(max(-1.0, min(1.0, lo / s)))
                phi_ = math.asin(max(-1.0, min(1.0, hi / s)))
                for j in range(k):
                    psi = plo + (phi_ - plo) * gx[j]
                    v = s * math.sin(psi)
                    X[n] = v if swap else u
                    Y[n] = u if swap else v
                    W[n] = wu * gw[j] * (phi_ - plo) * s * math.cos(psi)
                    n += 1
            else:
                for j in range(k):
                    v = lo + (hi - lo) * gx[j]
                    X[n] = v if swap else u
                    Y[n] = u if swap else v
                    W[n] = wu * gw[j] * (hi - lo)
                    n += 1
    return n


@njit(nogil=True, cache=True)
def _bary(vals, off, m, x, nodes, weights):
    """Barycentric interpolation through ``vals[off:off+m]`` at Chebyshev points ``nodes`` (first kind)."""
    num = 0.0
    den = 0.0
    for j in range(m):
        d = x - nodes[j]
        if d == 0.0:
            return vals[off + j]
        t = weights[j] / d
        num += t * vals[off + j]
        den += t
    return num / den


def scale_tables(vals: np.ndarray, mt: int, mp: int, rng: tuple, floor: float) -> tuple:
    """The arguments of :func:`scale_at` for the scale ``c(wo)`` of one bin: ``(meta, vals, nodes, tmp)``."""

    def cheb(m: int) -> tuple[np.ndarray, np.ndarray]:
        a = (2 * np.arange(m) + 1) * np.pi / (2 * m)
        return np.cos(a), np.sin(a) * np.where(np.arange(m) & 1, -1.0, 1.0)

    width = max(mt, mp, 1)
    nodes = np.zeros((4, width))
    nodes[0, :mt], nodes[1, :mt] = cheb(mt)
    if mp > 1:
        nodes[2, :mp], nodes[3, :mp] = cheb(mp)
    meta = np.array([mt, mp, *rng, floor], dtype=np.float64)
    return meta, np.ascontiguousarray(vals, dtype=np.float64), nodes, np.empty(width)


@njit(nogil=True, cache=True)
def scale_at(theta, phi, meta, vals, nodes, tmp):
    """``max(c(theta, phi), floor)``: the bin's Chebyshev interpolant of the normalizer estimates
    (``meta = (m_theta, m_phi, theta_lo, theta_hi, phi_lo, phi_hi, floor)``; values at ``i_theta m_phi +
    i_phi``)."""
    mt = int(meta[0])
    mp = int(meta[1])
    if mp > 1:
        xp = (2.0 * phi - meta[4] - meta[5]) / (meta[5] - meta[4])
        for a in range(mt):
            tmp[a] = _bary(vals, a * mp, mp, xp, nodes[2], nodes[3])
    else:
        for a in range(mt):
            tmp[a] = vals[a]
    xt = (2.0 * theta - meta[2] - meta[3]) / (meta[3] - meta[2])
    return max(_bary(tmp, 0, mt, xt, nodes[0], nodes[1]), meta[6])


@njit(nogil=True, cache=True)
def scale_rows(theta, phi, meta, vals, nodes, tmp):
    """:func:`scale_at` per row."""
    out = np.empty(theta.shape[0])
    for i in range(theta.shape[0]):
        out[i] = scale_at(theta[i], phi[i], meta, vals, nodes, tmp)
    return out


@njit(nogil=True, cache=True)
def clamp_disk(x, y):
    r = math.sqrt(x * x + y * y)
    if r > R_MAX:
        s = R_MAX / r
        return x * s, y * s
    return x, y


@njit(nogil=True, cache=True)
def clamp_to_box(x, y, x0, y0, x1, y1):
    """The point clipped to the box, then pulled inside the radius ``R_MAX``."""
    return clamp_disk(min(max(x, x0), x1), min(max(y, y0), y1))


@njit(nogil=True, cache=True)
def sign(v):
    return 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)


BUILD_TEMPLATE = '''
import math

import numpy as np
from numba import njit

from core.quadtree_build_kernels import box_rule, clamp_disk, clamp_to_box, scale_at, sign
from core.quadtree_kernels import LUM_B, LUM_G, LUM_R, project


@njit(nogil=True, cache=True)
def f_at(wx, wy, wz, ix, iy, iz, p):
    """The luminance of ``f_r(wo, wi)``."""
    r, g, b = _eval((ix, iy, iz), (wx, wy, wz), p)
    return LUM_R * r + LUM_G * g + LUM_B * b


@njit(nogil=True, cache=True)
def g_at(wx, wy, wz, X, Y, proj, p):
    """``g = f cos(theta_i) J`` at disk point ``(X, Y)`` for ``wo = (wx, wy, wz)`` (0 outside the disk)."""
    ix, iy, iz, factor = project(X, Y, proj)
    if factor > 0.0:
        return f_at(wx, wy, wz, ix, iy, iz, p) * factor
    return 0.0


@njit(nogil=True, cache=True)
def h_at(theta, phi, X, Y, proj, p, s_meta, s_vals, s_nodes, s_tmp):
    """The scaled target ``g / c(wo)`` at ``wo(theta, phi)``."""
    st = math.sin(theta)
    g = g_at(st * math.cos(phi), st * math.sin(phi), math.cos(theta), X, Y, proj, p)
    return g / scale_at(theta, phi, s_meta, s_vals, s_nodes, s_tmp)


@njit(nogil=True, cache=True)
def g_rows(theta, phi, X, Y, proj, p):
    """``g(wo(theta, phi), X)`` per row."""
    n = theta.shape[0]
    out = np.empty(n)
    for i in range(n):
        st = math.sin(theta[i])
        out[i] = g_at(st * math.cos(phi[i]), st * math.sin(phi[i]), math.cos(theta[i]), X[i], Y[i], proj, p)
    return out


@njit(nogil=True, cache=True)
def peak_search(theta, phi, sx, sy, proj, p):
    """Compass search (8 directions, step halving from 0.05 down to 1e-6, at most 48 rounds) for the largest
    ``g(wo, X)`` over the disk for the fixed ``wo`` of each row, from ``(sx, sy)``."""
    n = theta.shape[0]
    px = np.empty(n)
    py = np.empty(n)
    pv = np.empty(n)
    r2 = 1.0 / math.sqrt(2.0)
    dx = np.array([1.0, -1.0, 0.0, 0.0, r2, r2, -r2, -r2])
    dy = np.array([0.0, 0.0, 1.0, -1.0, r2, -r2, r2, -r2])
    for i in range(n):
        st = math.sin(theta[i])
        wx, wy, wz = st * math.cos(phi[i]), st * math.sin(phi[i]), math.cos(theta[i])
        cx, cy = clamp_disk(sx[i], sy[i])
        best = g_at(wx, wy, wz, cx, cy, proj, p)
        step = 0.05
        for _ in range(48):
            bv = -np.inf
            bx, by = cx, cy
            for j in range(8):
                x, y = clamp_disk(cx + step * dx[j], cy + step * dy[j])
                v = g_at(wx, wy, wz, x, y, proj, p)
                if v > bv:
                    bv, bx, by = v, x, y
            if bv > best:
                cx, cy, best = bx, by, bv
            else:
                step *= 0.5
                if step < 1e-6:
                    break
        px[i], py[i], pv[i] = cx, cy, best
    return px, py, pv


@njit(nogil=True, cache=True)
def node_integrals(boxes, gx, gw, theta, phi, proj, p, scaled, s_meta, s_vals, s_nodes, s_tmp):
    """Per box and per ``wo``: the integral of ``g`` over box-and-disk (the exact-region rule); with
    ``scaled``, also the largest ``g / c`` on the rule per box and where it is (``X, Y, theta, phi``: a start
    for the bound's search; the first point and ``wo`` that reach it)."""
    nb = boxes.shape[0]
    nw = theta.shape[0]
    k = gx.shape[0]
    out = np.zeros((nb, nw))
    vmax = np.zeros(nb)
    qstart = np.zeros((nb, 4))
    wv = np.empty((nw, 3))
    c = np.ones(nw)
    for w in range(nw):
        st = math.sin(theta[w])
        wv[w, 0], wv[w, 1], wv[w, 2] = st * math.cos(phi[w]), st * math.sin(phi[w]), math.cos(theta[w])
        if scaled:
            c[w] = scale_at(theta[w], phi[w], s_meta, s_vals, s_nodes, s_tmp)
    cap = 5 * k * k
    X = np.empty(cap)
    Y = np.empty(cap)
    W = np.empty(cap)
    for b in range(nb):
        qstart[b, 2] = theta[0]
        qstart[b, 3] = phi[0]
        n = box_rule(boxes[b, 0], boxes[b, 1], boxes[b, 2], boxes[b, 3], gx, gw, X, Y, W)
        best = -1.0
        for q in range(n):
            ix, iy, iz, factor = project(X[q], Y[q], proj)
            for w in range(nw):
                v = f_at(wv[w, 0], wv[w, 1], wv[w, 2], ix, iy, iz, p) * factor if factor > 0.0 else 0.0
                out[b, w] += W[q] * v
                if scaled:
                    s = v / c[w]
                    if s > best:
                        best = s
                        qstart[b, 0], qstart[b, 1], qstart[b, 2], qstart[b, 3] = X[q], Y[q], theta[w], phi[w]
        vmax[b] = max(best, 0.0)
    return out, vmax, qstart


@njit(nogil=True, cache=True)
def _search(cx, cy, ct, cp, best, x0, y0, x1, y1, srch, iso, iters, proj, p, s_meta, s_vals, s_nodes, s_tmp):
    """Compass search for a larger ``g / c`` in ``(X, Y, theta_o, phi_o)`` over the box x the bin, from
    ``(cx, cy, ct, cp)`` whose value is ``best``. Besides the coordinate moves, moves in ``wo`` drag ``X``
    along with the mirror point (``srch = (theta_lo, theta_hi, phi_lo, phi_hi, d mirror / d theta (2),
    d mirror / d phi (2), theta step, phi step)``): the ridge of a sharp lobe runs diagonally in these
    coordinates and plain coordinate moves fall off it."""
    t_lo, t_hi, f_lo, f_hi = srch[0], srch[1], srch[2], srch[3]
    m = 4 if iso else 6
    D = np.zeros((6, 4))
    D[0, 0] = 1.0
    D[1, 1] = 1.0
    D[2, 2] = 1.0
    D[3, 0], D[3, 1], D[3, 2] = srch[4], srch[5], 1.0
    D[4, 3] = 1.0
    D[5, 0], D[5, 1], D[5, 3] = srch[6], srch[7], 1.0
    S = np.empty(6)
    S[0] = 0.25 * (x1 - x0)
    S[1] = 0.25 * (y1 - y0)
    S[2] = S[3] = 0.5 * srch[8]
    S[4] = S[5] = 0.5 * srch[9]
    for _ in range(iters):
        bv = -np.inf
        bx, by, bt, bp = cx, cy, ct, cp
        for jj in range(2 * m):
            j = jj % m
            d = S[j] if jj < m else -S[j]
            x = min(max(cx + d * D[j, 0], x0), x1)
            y = min(max(cy + d * D[j, 1], y0), y1)
            t = min(max(ct + d * D[j, 2], t_lo), t_hi)
            f = min(max(cp + d * D[j, 3], f_lo), f_hi)
            x, y = clamp_to_box(x, y, x0, y0, x1, y1)
            v = h_at(t, f, x, y, proj, p, s_meta, s_vals, s_nodes, s_tmp)
            if v > bv:
                bv, bx, by, bt, bp = v, x, y, t, f
        if bv > best:
            cx, cy, ct, cp, best = bx, by, bt, bp, bv
        else:
            for j in range(m):
                S[j] *= 0.5
    return best


@njit(nogil=True, cache=True)
def node_bounds(boxes, theta, phi, ridge, qmax, qstart, srch, iso, iters, grid, arc, rings, probe_from, proj, p,
                s_meta, s_vals, s_nodes, s_tmp):
    """``(max before search, max after search)`` of ``g / c`` per box over the bin.

    Candidates, in this order: at each ``wo`` from index ``probe_from`` on (the bin's edges and middle; the
    others are the normalizer's nodes, whose best quadrature point arrives as ``qmax``, ``qstart``), a
    ``grid x grid`` lattice over the box, ``2 x arc`` points of the unit circle clamped into it (where ``f``
    grows toward the horizon the sup of a rim leaf lies on its arc) and ``arc`` points on each circle of radius
    ``rings`` that crosses the box (a peak in a thin band just inside the horizon: Poulin-Fournier's at
    theta_i ~ 89.6 degrees is 1e-4 wide on the orthographic disk, between the lattice and the rim); then the
    box's nearest points to the ridge points (rows ``X, Y, theta, phi``: mirror, peak and retro-reflection
    points of a dense set of ``wo``, paired with that ``wo``). Then a compass search from the best two and from the best quadrature point ``qstart``
    (value ``qmax``, see ``node_integrals``)."""
    nb = boxes.shape[0]
    nw = theta.shape[0]
    nr = ridge.shape[0]
    wv = np.empty((nw, 3))
    cw = np.empty(nw)
    for w in range(nw):
        st = math.sin(theta[w])
        wv[w, 0], wv[w, 1], wv[w, 2] = st * math.cos(phi[w]), st * math.sin(phi[w]), math.cos(theta[w])
        cw[w] = scale_at(theta[w], phi[w], s_meta, s_vals, s_nodes, s_tmp)
    rv = np.empty((nr, 3))
    cr = np.empty(nr)
    for r in range(nr):
        st = math.sin(ridge[r, 2])
        rv[r, 0], rv[r, 1], rv[r, 2] = st * math.cos(ridge[r, 3]), st * math.sin(ridge[r, 3]), math.cos(ridge[r, 2])
        cr[r] = scale_at(ridge[r, 2], ridge[r, 3], s_meta, s_vals, s_nodes, s_tmp)
    gt = np.empty(grid)
    for i in range(grid):
        gt[i] = i / (grid - 1) if grid > 1 else 0.0
    at = np.empty(arc)
    for i in range(arc):
        at[i] = i / (arc - 1) if arc > 1 else 0.0
    nring = rings.shape[0]
    rarc = max(2, arc // 2)  # a ring's value varies slowly along it: half the rim's points per side
    ar = np.empty(rarc)
    for i in range(rarc):
        ar[i] = i / (rarc - 1)
    cap = grid * grid + 2 * arc + 2 * rarc * nring
    px = np.empty(cap)
    py = np.empty(cap)
    pi = np.empty((cap, 4))
    before = np.empty(nb)
    after = np.empty(nb)
    for b in range(nb):
        x0, y0, x1, y1 = boxes[b, 0], boxes[b, 1], boxes[b, 2], boxes[b, 3]
        n = 0
        for i in range(grid):
            for j in range(grid):
                px[n] = x0 + (x1 - x0) * gt[i]
                py[n] = y0 + (y1 - y0) * gt[j]
                n += 1
        sy = sign(y0 + y1)
        for i in range(arc):
            ax = x0 + (x1 - x0) * at[i]
            px[n] = ax
            py[n] = sy * math.sqrt(max(0.0, 1.0 - ax * ax))
            n += 1
        sx = sign(x0 + x1)
        for i in range(arc):
            by = y0 + (y1 - y0) * at[i]
            px[n] = sx * math.sqrt(max(0.0, 1.0 - by * by))
            py[n] = by
            n += 1
        # circles just inside the rim that cross the box (nearest and farthest points of the box)
        dx = 0.0 if x0 <= 0.0 <= x1 else min(abs(x0), abs(x1))
        dy = 0.0 if y0 <= 0.0 <= y1 else min(abs(y0), abs(y1))
        near = math.sqrt(dx * dx + dy * dy)
        far = math.sqrt(max(x0 * x0, x1 * x1) + max(y0 * y0, y1 * y1))
        for k in range(nring):
            rho = rings[k]
            if rho < near or rho > far:
                continue
            for i in range(rarc):
                ax = x0 + (x1 - x0) * ar[i]
                px[n] = ax
                py[n] = sy * math.sqrt(max(0.0, rho * rho - ax * ax))
                n += 1
            for i in range(rarc):
                by = y0 + (y1 - y0) * ar[i]
                px[n] = sx * math.sqrt(max(0.0, rho * rho - by * by))
                py[n] = by
                n += 1
        npts = n
        # the best two candidates (first occurrence on ties, as np.argmax)
        v1 = -np.inf
        v2 = -np.inf
        s1 = np.zeros(4)
        s2 = np.zeros(4)
        for q in range(npts):
            px[q], py[q] = clamp_to_box(px[q], py[q], x0, y0, x1, y1)
            pi[q, 0], pi[q, 1], pi[q, 2], pi[q, 3] = project(px[q], py[q], proj)
        for w in range(probe_from, nw):
            for q in range(npts):
                x, y = px[q], py[q]
                fac = pi[q, 3]
                v = f_at(wv[w, 0], wv[w, 1], wv[w, 2], pi[q, 0], pi[q, 1], pi[q, 2], p) * fac if fac > 0.0 else 0.0
                v /= cw[w]
                if v > v1:
                    v2 = v1
                    s2[:] = s1
                    v1 = v
                    s1[0], s1[1], s1[2], s1[3] = x, y, theta[w], phi[w]
                elif v > v2:
                    v2 = v
                    s2[0], s2[1], s2[2], s2[3] = x, y, theta[w], phi[w]
        for r in range(nr):
            x, y = clamp_to_box(ridge[r, 0], ridge[r, 1], x0, y0, x1, y1)
            v = g_at(rv[r, 0], rv[r, 1], rv[r, 2], x, y, proj, p) / cr[r]
            if v > v1:
                v2 = v1
                s2[:] = s1
                v1 = v
                s1[0], s1[1], s1[2], s1[3] = x, y, ridge[r, 2], ridge[r, 3]
            elif v > v2:
                v2 = v
                s2[0], s2[1], s2[2], s2[3] = x, y, ridge[r, 2], ridge[r, 3]
        top = max(v1, qmax[b])
        before[b] = top
        best = top
        best = max(best, _search(s1[0], s1[1], s1[2], s1[3], v1, x0, y0, x1, y1, srch, iso, iters, proj, p,
                                 s_meta, s_vals, s_nodes, s_tmp))
        best = max(best, _search(s2[0], s2[1], s2[2], s2[3], v2, x0, y0, x1, y1, srch, iso, iters, proj, p,
                                 s_meta, s_vals, s_nodes, s_tmp))
        best = max(best, _search(qstart[b, 0], qstart[b, 1], qstart[b, 2], qstart[b, 3], qmax[b], x0, y0,
                                 x1, y1, srch, iso, iters, proj, p, s_meta, s_vals, s_nodes, s_tmp))
        after[b] = best
    return before, after
'''
"""The construction's loops: the source of a generated module per model kernel (:mod:`core.specialize`)."""


def build_kernels(kernel: Any) -> Any:
    """The construction's compiled loops for a model's ``eval`` kernel (``g_rows, peak_search,
    node_integrals, node_bounds``)."""
    from core.quadtree_kernels import specialized

    return specialized(BUILD_TEMPLATE, kernel)
