"""The seed's adaptive quadtree over the unit disk: construction, exact rejection sampling and the pdf.

One tree per incident-angle bin (the bins are set by :class:`QuadtreeTable`). For a bin, the unit disk of
disk points ``X = (X, Y)`` is split recursively into square nodes. A *projection* maps disk points to
directions ``wi`` of the upper hemisphere and defines the target ``g(wo, X) = f(wo, wi) cos(theta_i) J(X)``
with ``J = d(omega)/dX dY``, so that ``int_disk g dX dY = int f cos d(omega) = I(wo)``; ``f`` is the luminance
of ``f_r``:

``orthographic`` (the seed's projected-solid-angle disk)
    ``X = (wi.x, wi.y)``; ``J = 1/cos(theta_i)``, so ``g = f``.
``equidistant`` (default)
    ``|X| = theta_i / (pi/2)``; ``J = (pi/2) sin(theta_i) / |X|``, so ``g = f cos(theta_i) J`` is bounded
    wherever ``f cos`` is. Models such as Phong (``1/cos(theta_i)``) or Minnaert (``k < 1``) have an ``f`` that
    grows without bound at the rim of the orthographic disk, where no leaf bound can be tight.

Every leaf ``L`` stores its *clipped box* ``B_L`` (the bounding box of the leaf intersected with the disk:
the seed's "improved area"), a bound ``M_L >= g(wo, X)`` on ``B_L`` for every ``wo`` of the bin, and its
envelope mass ``V_L = area(B_L) M_L``; an internal node's mass is the sum of its children's.

**Sampling (exact).** Pick a leaf with probability ``V_L / V`` (descending from the root by the children's
masses), draw ``X`` uniform in ``B_L``, accept with probability ``g(wo, X) / M_L``; on rejection *restart from
the root*. A trial lands at ``X`` and is accepted with density ``sum_L (V_L/V)(1/area_L)(g/M_L) = g(X)/V``,
so an accepted ``X`` has density ``g / I(wo)`` whatever the leaves are, i.e. ``wi`` has the density
``pdf(wi) = f(wo, wi) cos(theta_i) / I(wo)`` per unit solid angle. The per-trial acceptance is ``I(wo) / V``.
Only the normalizer ``I(wo)`` enters the pdf, and the luminance weight ``f cos / pdf = I(wo)`` is the same for
every sample (zero variance).

**Construction** (vectorized over all nodes of a level; ``f`` is evaluated through the model's batch kernel,
so nothing is compiled per model beyond :func:`core.kernels.eval_batch`). A node at depth >= ``min_depth``
gets the integral of ``g`` over its part of the disk at the normalizer nodes (Gauss-Legendre on the exact
region, :func:`region_rule`), and a bound: the largest ``g`` on the quadrature points, a 4 x 4 grid over
``B_L`` at every ``wo`` sample of the bin, probes at the mirror, retro-reflection and normal directions, then
a compass search in ``(X, Y, theta_o, phi_o)`` from the best points; ``M = (1 + safety) max``. The node is
split while the bound is unsure (the search raised it by more than 2 %) or ``V > n_max I_L`` at the bin's
worst normalizer node with an excess ``V - I_L`` above ``excess_tol I``, until the depth guard.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from numba import njit

from core.kernels import eval_batch
from core.model import LUMINANCE

TABLE_VERSION = 2
"""Bump when the construction changes what a table holds (part of the on-disk cache key)."""

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi
INV_PI = 1.0 / math.pi
R_MAX = 1.0 - 1e-12
"""Probes and the search stay inside this radius (g is 0 on and outside the unit circle)."""
QUAD_ORDER = 6
GRID = 4
PROJECTIONS = ("equidistant", "orthographic")


def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(order)
    return 0.5 * (x + 1.0), 0.5 * w


# ---------------------------------------------------------------------------------------- projections


def disk_to_direction(X: np.ndarray, Y: np.ndarray, projection: str) -> tuple[np.ndarray, np.ndarray]:
    """Directions ``(n, 3)`` of disk points and the factor ``cos(theta_i) J`` (0 on and outside the circle)."""
    r2 = X * X + Y * Y
    inside = r2 < 1.0
    if projection == "orthographic":
        z = np.sqrt(np.maximum(0.0, 1.0 - r2))
        wi = np.stack([X, Y, z], axis=1)
        factor = inside.astype(np.float64)
    else:
        rho = np.sqrt(r2)
        theta = HALF_PI * np.minimum(rho, 1.0)
        s = np.sin(theta)
        safe = np.where(rho > 0.0, rho, 1.0)
        scale = np.where(rho > 0.0, s / safe, HALF_PI)  # sin(theta)/rho -> pi/2 at the centre
        wi = np.stack([X * scale, Y * scale, np.cos(theta)], axis=1)
        factor = np.where(inside, np.cos(theta) * HALF_PI * scale, 0.0)
    wi[~inside] = (0.0, 0.0, 1.0)
    return wi, factor


def direction_to_disk(wi: np.ndarray, projection: str) -> np.ndarray:
    """Disk points ``(n, 2)`` of upper-hemisphere directions (the inverse of :func:`disk_to_direction`)."""
    if projection == "orthographic":
        return wi[:, :2].copy()
    s = np.sqrt(wi[:, 0] ** 2 + wi[:, 1] ** 2)
    theta = np.arctan2(s, wi[:, 2])
    rho = theta / HALF_PI
    safe = np.where(s > 0.0, s, 1.0)
    return np.stack([wi[:, 0] * rho / safe, wi[:, 1] * rho / safe], axis=1)


def angles_to_wo(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    s = np.sin(theta)
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], axis=1)


def f_luminance(model: Any, params: np.ndarray, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Luminance of ``f_r(wo, wi)`` for rows ``(n, 3)``."""
    if len(wo) == 0:
        return np.zeros(0)
    rgb = eval_batch(model, np.ascontiguousarray(wi), np.ascontiguousarray(wo), params)
    return rgb @ LUMINANCE


def target(
    model: Any, params: np.ndarray, wo: np.ndarray, X: np.ndarray, Y: np.ndarray, projection: str
) -> np.ndarray:
    """``g(wo, X)`` for rows: ``f cos(theta_i) J``."""
    wi, factor = disk_to_direction(X, Y, projection)
    return f_luminance(model, params, wo, wi) * factor


# ------------------------------------------------------------------------------- exact-region quadrature


@njit(nogil=True, cache=True)
def clip_boxes(x0, x1, y0, y1):
    """Bounding boxes of ``[x0,x1] x [y0,y1]`` intersected with the unit disk (arrays); ``ok`` False when
    the intersection is empty. Four distance tests per box, as the seed's "improved area"."""
    n = x0.shape[0]
    out = np.empty((n, 4))
    ok = np.empty(n, dtype=np.bool_)
    for i in range(n):
        a0, a1, b0, b1 = x0[i], x1[i], y0[i], y1[i]
        w = 1.0 if b0 <= 0.0 <= b1 else math.sqrt(max(0.0, 1.0 - min(b0 * b0, b1 * b1)))
        h = 1.0 if a0 <= 0.0 <= a1 else math.sqrt(max(0.0, 1.0 - min(a0 * a0, a1 * a1)))
        c0 = max(a0, -w)
        c1 = min(a1, w)
        d0 = max(b0, -h)
        d1 = min(b1, h)
        out[i, 0] = c0
        out[i, 1] = d0
        out[i, 2] = c1
        out[i, 3] = d1
        ok[i] = c0 < c1 and d0 < d1
    return out, ok


@njit(nogil=True, cache=True)
def region_rule(boxes, gx, gw):
    """Quadrature points and weights for the integral over each box ``(x0, y0, x1, y1)`` intersected with the
    unit disk. Returns ``X, Y, weight, owner`` (owner = box row).

    Iterated Gauss-Legendre: the outer variable is the one along which the circle is far from vertical
    (``x`` when the box centre has ``|x| < |y|``, else ``y``); the outer interval is split where the circle
    crosses the box's inner edges, so that on each piece the inner limits are smooth. When an inner limit lies
    on the circle the inner variable is ``v = s sin(psi)``, ``s = sqrt(1 - u^2)``: the distance to the rim is
    then smooth in ``psi`` and square-root behaviour of the integrand at the rim does not spoil the rule.
    """
    k = gx.shape[0]
    nb = boxes.shape[0]
    cap = nb * 5 * k * k
    X = np.empty(cap)
    Y = np.empty(cap)
    W = np.empty(cap)
    O = np.empty(cap, dtype=np.int64)
    n = 0
    cuts = np.empty(6)
    for bi in range(nb):
        x0, y0, x1, y1 = boxes[bi, 0], boxes[bi, 1], boxes[bi, 2], boxes[bi, 3]
        if not (x1 > x0 and y1 > y0):
            continue
        swap = abs(0.5 * (x0 + x1)) >= abs(0.5 * (y0 + y1))
        if swap:
            u0, u1, v0, v1 = y0, y1, x0, x1
        else:
            u0, u1, v0, v1 = x0, x1, y0, y1
        u0 = max(u0, -1.0)
        u1 = min(u1, 1.0)
        if u1 <= u0:
            continue
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
                        wt = wu * gw[j] * (phi_ - plo) * s * math.cos(psi)
                        X[n] = v if swap else u
                        Y[n] = u if swap else v
                        W[n] = wt
                        O[n] = bi
                        n += 1
                else:
                    for j in range(k):
                        v = lo + (hi - lo) * gx[j]
                        X[n] = v if swap else u
                        Y[n] = u if swap else v
                        W[n] = wu * gw[j] * (hi - lo)
                        O[n] = bi
                        n += 1
    return X[:n], Y[:n], W[:n], O[:n]


# --------------------------------------------------------------------------------- normalizer tables


def chebyshev_points(lo: float, hi: float, m: int) -> np.ndarray:
    """The ``m`` Chebyshev points of the first kind on ``[lo, hi]`` (order as in :func:`normalizer_values`)."""
    j = np.arange(m)
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * np.cos((2 * j + 1) * np.pi / (2 * m))


@njit(inline="always", nogil=True, cache=True)
def _cheb_interp(vals, off, m, x):
    """Barycentric interpolation through ``vals[off:off+m]`` at the Chebyshev points of the first kind
    ``x_j = cos((2j+1) pi / (2m))``, evaluated at ``x``."""
    num = 0.0
    den = 0.0
    for j in range(m):
        a = (2 * j + 1) * math.pi / (2 * m)
        d = x - math.cos(a)
        if d == 0.0:
            return vals[off + j]
        t = math.sin(a) / d
        if j & 1:
            t = -t
        num += t * vals[off + j]
        den += t
    return num / den


@njit(nogil=True, cache=True)
def normalizer_values(meta, vals, bins, theta, phi):
    """``I(wo)`` per row from the bins' Chebyshev tables (0 where ``bins < 0``).

    ``meta[b] = (offset, m_theta, m_phi, theta_lo, theta_hi, phi_lo, phi_hi)``; the values of bin ``b`` are
    stored at ``offset + i_theta * m_phi + i_phi``.
    """
    out = np.zeros(bins.shape[0])
    tmp = np.empty(64)
    for i in range(bins.shape[0]):
        b = bins[i]
        if b < 0:
            continue
        off = int(meta[b, 0])
        mt = int(meta[b, 1])
        mp = int(meta[b, 2])
        xt = (2.0 * theta[i] - meta[b, 3] - meta[b, 4]) / (meta[b, 4] - meta[b, 3])
        if mp <= 1:
            out[i] = _cheb_interp(vals, off, mt, xt)
        else:
            xp = (2.0 * phi[i] - meta[b, 5] - meta[b, 6]) / (meta[b, 6] - meta[b, 5])
            for a in range(mt):
                tmp[a] = _cheb_interp(vals, off + a * mp, mp, xp)
            out[i] = _cheb_interp(tmp, 0, mt, xt)
    return out


# ------------------------------------------------------------------------------------------ construction


class BuildOptions:
    """Construction settings (all of them are part of the cache key)."""

    def __init__(
        self,
        n_max: float = 2.0,
        projection: str = "auto",
        theta_step: float = 1.0,
        phi_bins: int = 72,
        min_depth: int = 2,
        max_depth: int = 11,
        max_nodes: int = 200_000,
        safety: float = 0.05,
        excess_tol: float = 1e-4,
        m_theta: int = 6,
        m_phi: int = 5,
        interp_tol: float = 1e-6,
        z_min: float = 1e-6,
        search_iters: int = 12,
    ):
        if projection not in (*PROJECTIONS, "auto"):
            raise ValueError(f"projection must be 'auto' or one of {PROJECTIONS}")
        self.n_max = float(n_max)
        self.projection = projection
        self.theta_step = float(theta_step)
        self.phi_bins = int(phi_bins)
        self.min_depth = int(min_depth)
        self.max_depth = int(max_depth)
        self.max_nodes = int(max_nodes)
        self.safety = float(safety)
        self.excess_tol = float(excess_tol)
        self.m_theta = int(m_theta)
        self.m_phi = int(m_phi)
        self.interp_tol = float(interp_tol)
        self.z_min = float(z_min)
        self.search_iters = int(search_iters)

    def key_parts(self) -> tuple:
        return tuple(sorted(vars(self).items()))


def theta_edges(step_deg: float = 1.0, z_min: float = 1e-6) -> np.ndarray:
    """Bin edges over ``theta_o`` (radians): bins ``step_deg`` wide centred on its multiples (so 0, 30, 60,
    80, 89 degrees lie mid-bin), then, near grazing, bins that halve ``cos(theta_o)`` down to ``z_min``.
    Beyond the last edge (``cos theta_o < z_min``) the sampler uses the cosine density instead."""
    inner = np.arange(0.5 * step_deg, 90.0 - 1e-9, step_deg)
    edges = [0.0, *np.radians(inner)]
    z = math.cos(edges[-1])
    while z * 0.5 > z_min:
        z *= 0.5
        edges.append(math.acos(z))
    edges.append(math.acos(z_min))
    return np.asarray(edges)


def _tensor(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ta, tb = np.meshgrid(a, b, indexing="ij")
    return np.ascontiguousarray(np.stack([ta.ravel(), tb.ravel()], axis=1))


def _clamp_to_box(X, Y, box):
    X = np.clip(X, box[:, 0], box[:, 2])
    Y = np.clip(Y, box[:, 1], box[:, 3])
    r = np.sqrt(X * X + Y * Y)
    s = np.where(r > R_MAX, R_MAX / np.where(r > 0, r, 1.0), 1.0)
    return X * s, Y * s


class _Builder:
    """Vectorized construction of one bin's tree."""

    def __init__(self, model: Any, params: np.ndarray, iso: bool, rng: tuple, opts: BuildOptions):
        self.model, self.params, self.iso, self.opts = model, params, iso, opts
        self.t_lo, self.t_hi, self.f_lo, self.f_hi = rng
        self.gx, self.gw = gauss_legendre(QUAD_ORDER)
        self.proj = opts.projection

    def grows_at_rim(self, wo_ang: np.ndarray) -> bool:
        """Whether ``f`` rises toward the horizon of ``wi`` (then the orthographic ``g = f`` has no tight bound
        near the rim): the largest ``f`` on rings at theta_i = 89.99 and 89.9999 degrees against the largest
        ``f`` for theta_i <= 89 degrees."""
        th_i = np.radians(np.concatenate([np.linspace(0.0, 89.0, 40), [89.99, 89.9999]]))
        ph_i = np.linspace(0.0, TWO_PI, 48, endpoint=False)
        T, P = np.meshgrid(th_i, ph_i, indexing="ij")
        wi = angles_to_wo(T.ravel(), P.ravel())
        rim = T.ravel() > np.radians(89.5)
        inner = rim_max = 0.0
        for t, f in wo_ang:
            wo = np.repeat(angles_to_wo(np.array([t]), np.array([f])), len(wi), axis=0)
            vals = f_luminance(self.model, self.params, wo, wi)
            inner = max(inner, float(vals[~rim].max()))
            rim_max = max(rim_max, float(vals[rim].max()))
        return rim_max > 2.0 * inner

    def g(self, theta: np.ndarray, phi: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return target(self.model, self.params, angles_to_wo(theta, phi), X, Y, self.proj)

    def integrals(self, boxes: np.ndarray, wo_ang: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per box and per ``wo``: integral of ``g`` over box-and-disk, and the largest ``g / c`` on the rule
        (the latter only once the scale ``c`` is set)."""
        X, Y, W, O = region_rule(np.ascontiguousarray(boxes), self.gx, self.gw)
        nb, nw = len(boxes), len(wo_ang)
        P = len(X)
        th = np.repeat(wo_ang[:, 0], P)
        ph = np.repeat(wo_ang[:, 1], P)
        vals = self.g(th, ph, np.tile(X, nw), np.tile(Y, nw)).reshape(nw, P)
        out = np.zeros((nb, nw))
        vmax = np.zeros(nb)
        inv_c = 1.0 / self.scale(wo_ang[:, 0], wo_ang[:, 1]) if hasattr(self, "c_vals") else np.ones(nw)
        for w in range(nw):
            out[:, w] = np.bincount(O, weights=W * vals[w], minlength=nb)
            np.maximum.at(vmax, O, vals[w] * inv_c[w])
        return out, vmax

    def search(self, start: np.ndarray, best: np.ndarray, box: np.ndarray) -> np.ndarray:
        """Compass search for a larger ``g`` in ``(X, Y, theta_o, phi_o)`` over each box x the bin."""
        c = len(start)
        if c == 0:
            return best
        lo = np.column_stack([box[:, 0], box[:, 1], np.full(c, self.t_lo), np.full(c, self.f_lo)])
        hi = np.column_stack([box[:, 2], box[:, 3], np.full(c, self.t_hi), np.full(c, self.f_hi)])
        step = 0.25 * (hi - lo)
        dims = [0, 1, 2] if self.iso else [0, 1, 2, 3]
        cur = start.copy()
        best = best.copy()
        for _ in range(self.opts.search_iters):
            cand = np.repeat(cur[:, None, :], 2 * len(dims), axis=1)
            for j, d in enumerate(dims):
                cand[:, 2 * j, d] -= step[:, d]
                cand[:, 2 * j + 1, d] += step[:, d]
            cand = np.clip(cand, lo[:, None, :], hi[:, None, :])
            flat = cand.reshape(-1, 4)
            bx = np.repeat(box, 2 * len(dims), axis=0)
            X, Y = _clamp_to_box(flat[:, 0], flat[:, 1], bx)
            flat[:, 0], flat[:, 1] = X, Y
            vals = self.h(flat[:, 2], flat[:, 3], X, Y).reshape(c, -1)
            j = np.argmax(vals, axis=1)
            v = vals[np.arange(c), j]
            better = v > best
            cur[better] = cand[better, j[better]]
            best[better] = v[better]
            step[~better] *= 0.5
        return best

    def bound(self, boxes: np.ndarray, wo_ang: np.ndarray, qmax: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(max before search, max after search)`` of ``g`` per box over the bin."""
        nb, nw = len(boxes), len(wo_ang)
        t = np.linspace(0.0, 1.0, GRID)
        gxx, gyy = np.meshgrid(t, t, indexing="ij")
        gxx, gyy = gxx.ravel(), gyy.ravel()
        G = len(gxx)
        # grid points (per box) and probes (per box and wo): mirror, retro-reflection, normal
        X = boxes[:, 0:1] + (boxes[:, 2:3] - boxes[:, 0:1]) * gxx[None, :]
        Y = boxes[:, 1:2] + (boxes[:, 3:4] - boxes[:, 1:2]) * gyy[None, :]
        X = np.repeat(X[:, None, :], nw, axis=1)  # (nb, nw, G)
        Y = np.repeat(Y[:, None, :], nw, axis=1)
        th, ph = wo_ang[:, 0], wo_ang[:, 1]
        mirror = direction_to_disk(angles_to_wo(th, ph + math.pi), self.proj)
        retro = direction_to_disk(angles_to_wo(th, ph), self.proj)
        probes = np.stack([mirror, retro, np.zeros_like(mirror)], axis=1)  # (nw, 3, 2)
        PX = np.broadcast_to(probes[None, :, :, 0], (nb, nw, 3))
        PY = np.broadcast_to(probes[None, :, :, 1], (nb, nw, 3))
        inside = (
            (PX >= boxes[:, None, None, 0]) & (PX <= boxes[:, None, None, 2])
            & (PY >= boxes[:, None, None, 1]) & (PY <= boxes[:, None, None, 3])
        )  # fmt: skip
        PX = np.where(inside, PX, X[:, :, :1])
        PY = np.where(inside, PY, Y[:, :, :1])
        AX = np.concatenate([X, PX], axis=2).reshape(nb, -1)
        AY = np.concatenate([Y, PY], axis=2).reshape(nb, -1)
        bxr = np.repeat(boxes, AX.shape[1], axis=0)
        AXf, AYf = _clamp_to_box(AX.ravel(), AY.ravel(), bxr)
        K = G + 3
        TH = np.broadcast_to(np.repeat(th, K)[None, :], (nb, nw * K)).ravel()
        PH = np.broadcast_to(np.repeat(ph, K)[None, :], (nb, nw * K)).ravel()
        vals = self.h(TH, PH, AXf, AYf).reshape(nb, nw * K)
        order = np.argsort(-vals, axis=1)
        rows = np.arange(nb)
        before = np.maximum(vals[rows, order[:, 0]], qmax)
        # mirror and retro-reflection probes over a dense grid of the bin: the peak of a sharp lobe sits at
        # the mirror point of some wo of the bin, not necessarily of a sampled one
        dense = _tensor(
            np.linspace(self.t_lo, self.t_hi, 9),
            np.zeros(1) if self.iso else np.linspace(self.f_lo, self.f_hi, 9),
        )
        pts = np.concatenate(
            [direction_to_disk(angles_to_wo(dense[:, 0], dense[:, 1] + math.pi), self.proj),
             direction_to_disk(angles_to_wo(dense[:, 0], dense[:, 1]), self.proj)]
        )  # fmt: skip
        pang = np.concatenate([dense, dense])
        inside = (
            (pts[None, :, 0] >= boxes[:, 0:1]) & (pts[None, :, 0] <= boxes[:, 2:3])
            & (pts[None, :, 1] >= boxes[:, 1:2]) & (pts[None, :, 1] <= boxes[:, 3:4])
        )  # fmt: skip
        bi, pi = np.nonzero(inside)
        dense_start = None
        if len(bi):
            qx, qy = _clamp_to_box(pts[pi, 0], pts[pi, 1], boxes[bi])
            dv = self.h(pang[pi, 0], pang[pi, 1], qx, qy)
            dmax = np.full(nb, -1.0)
            np.maximum.at(dmax, bi, dv)
            hit = dv >= dmax[bi]
            dense_start = (
                bi[hit],
                np.column_stack([qx[hit], qy[hit], pang[pi[hit], 0], pang[pi[hit], 1]]),
                dv[hit],
            )
            before = np.maximum(before, dmax)
        best = before.copy()
        if dense_start is not None:
            b_idx, start, v0 = dense_start
            b_idx, first = np.unique(b_idx, return_index=True)
            found = self.search(start[first], v0[first], boxes[b_idx])
            best[b_idx] = np.maximum(best[b_idx], found)
        for rank in (0, 1):
            idx = order[:, rank]
            start = np.column_stack(
                [AXf.reshape(nb, -1)[rows, idx], AYf.reshape(nb, -1)[rows, idx],
                 TH.reshape(nb, -1)[rows, idx], PH.reshape(nb, -1)[rows, idx]]
            )  # fmt: skip
            best = np.maximum(best, self.search(start, vals[rows, idx], boxes))
        return before, best

    def polar_estimate(self, wo_ang: np.ndarray) -> tuple[np.ndarray, float]:
        """Estimates of ``I`` at each ``wo`` (polar Gauss-Legendre) and the largest ``g`` seen."""
        gx, gw = self.gx, self.gw
        nr = 6
        r = ((np.arange(nr)[:, None] + gx[None, :]) / nr).ravel()
        wr = np.tile(gw, nr) / nr
        nphi = 48
        phis = TWO_PI * (np.arange(nphi) + 0.5) / nphi
        R, P = np.meshgrid(r, phis, indexing="ij")
        WR = np.repeat(wr, nphi) * R.ravel() * (TWO_PI / nphi)
        X = (R * np.cos(P)).ravel()
        Y = (R * np.sin(P)).ravel()
        est = np.zeros(len(wo_ang))
        g_max = 0.0
        for k, (t, f) in enumerate(wo_ang):
            vals = self.g(np.full(len(X), t), np.full(len(X), f), X, Y)
            est[k] = float(vals @ WR)
            g_max = max(g_max, float(vals.max()))
        return est, g_max

    def scale(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """The per-``wo`` scale ``c(wo)`` (see :meth:`QuadtreeTable.scales`)."""
        theta = np.asarray(theta, dtype=np.float64)
        phi = np.asarray(phi, dtype=np.float64)
        v = normalizer_values(self.c_meta, self.c_vals, np.zeros(theta.shape, dtype=np.int64), theta, phi)
        return np.maximum(v, self.c_floor)

    def h(self, theta: np.ndarray, phi: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """The scaled target ``g / c(wo)`` the leaf bounds hold for."""
        return self.g(theta, phi, X, Y) / self.scale(theta, phi)

    def build(self) -> dict[str, np.ndarray]:
        t0 = time.perf_counter()
        o = self.opts
        t_lo, t_hi, f_lo, f_hi = self.t_lo, self.t_hi, self.f_lo, self.f_hi
        mt, mp = o.m_theta, (1 if self.iso else o.m_phi)
        wo_norm = _tensor(
            chebyshev_points(t_lo, t_hi, mt), np.zeros(1) if self.iso else chebyshev_points(f_lo, f_hi, mp)
        )
        tb = np.array([t_lo, 0.5 * (t_lo + t_hi), t_hi])
        wo_bound = (
            _tensor(tb, np.zeros(1)) if self.iso else _tensor(tb, np.array([f_lo, 0.5 * (f_lo + f_hi), f_hi]))
        )
        wo_all = np.concatenate([wo_norm, wo_bound])
        if self.proj == "auto":
            self.proj = "equidistant" if self.grows_at_rim(wo_all) else "orthographic"
        est, g_max = self.polar_estimate(wo_norm)
        # c(wo): the Chebyshev interpolant of the estimates, floored; bounds hold for g / c (exactness needs
        # only that sampling uses the same c; the closer c is to I, the less the bound varies over the bin)
        top = float(est.max())
        self.c_vals = np.ascontiguousarray(np.maximum(est, 0.0) if top > 0.0 else np.ones(len(est)))
        self.c_floor = 0.05 * float(self.c_vals.max())
        self.c_meta = np.array([[0.0, mt, mp, t_lo, t_hi, f_lo, f_hi]])
        c_norm = self.scale(wo_norm[:, 0], wo_norm[:, 1])
        i_ref = float(np.min(est / c_norm)) if top > 0.0 else 1.0
        floor = 1e-9 * g_max / float(c_norm.min()) if g_max > 0.0 else 1e-300

        # node table, grown level by level; children of a node are consecutive rows
        x0 = [np.array([-1.0])]
        y0 = [np.array([-1.0])]
        size = [np.array([2.0])]
        child_l: list[np.ndarray] = []
        M_l: list[np.ndarray] = []
        box_l: list[np.ndarray] = []
        I_l: list[np.ndarray] = []
        count = 0  # row of the first node of the current level
        depth = 0
        lx0, ly0, lsize = x0[0], y0[0], size[0]
        while len(lx0):
            n = len(lx0)
            boxes, ok = clip_boxes(lx0, lx0 + lsize, ly0, ly0 + lsize)
            M = np.zeros(n)
            I = np.zeros((n, len(wo_norm)))
            split = np.zeros(n, dtype=bool)
            if depth < o.min_depth:
                split = ok.copy()
            else:
                ev = np.flatnonzero(ok)
                if len(ev):
                    b = boxes[ev]
                    Ie, qmax = self.integrals(b, wo_norm)
                    before, after = self.bound(b, wo_all, qmax)
                    unsure = after > 1.02 * before
                    Me = np.maximum((1.0 + o.safety) * after, floor)
                    area = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
                    V = area * Me
                    # refine where it helps: the envelope is loose even for the best wo of the bin (a lobe
                    # that moves across the bin by more than its width cannot be fitted by smaller leaves)
                    i_best = (Ie / c_norm[None, :]).max(axis=1)
                    wasteful = (V > o.n_max * i_best) & (V - i_best > o.excess_tol * i_ref)
                    sp = (unsure | wasteful) & (depth < o.max_depth)
                    budget = (o.max_nodes - count - 4 * n) // 4
                    if sp.sum() > max(budget, 0):
                        sp[np.flatnonzero(sp)[max(budget, 0) :]] = False
                    Me = np.where(unsure & ~sp, 2.0 * Me, Me)  # still unsure at the guard: a wider margin
                    M[ev] = Me
                    I[ev] = Ie
                    split[ev] = sp
            ch = np.full(n, -1, dtype=np.int64)
            ns = int(split.sum())
            ch[split] = count + n + 4 * np.arange(ns)  # rows of the next level start after this one
            child_l.append(ch)
            M_l.append(np.where(ok & ~split, M, 0.0))
            box_l.append(np.where(ok[:, None], boxes, 0.0))
            I_l.append(np.where((ok & ~split)[:, None], I, 0.0))
            # next level
            h = 0.5 * lsize[split]
            sx, sy = lx0[split], ly0[split]
            nx0 = np.stack([sx, sx + h, sx, sx + h], axis=1).ravel()
            ny0 = np.stack([sy, sy, sy + h, sy + h], axis=1).ravel()
            count += n
            lx0, ly0, lsize = nx0, ny0, np.repeat(h, 4)
            depth += 1
        child = np.concatenate(child_l)
        M = np.concatenate(M_l)
        boxes = np.concatenate(box_l)
        Iall = np.concatenate(I_l)
        # level order: a node's children sit in the next level, in the order of their parents
        area = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
        vmass = np.where(child < 0, area * M, 0.0)
        for k in np.flatnonzero(child >= 0)[::-1]:
            c = child[k]
            vmass[k] = vmass[c] + vmass[c + 1] + vmass[c + 2] + vmass[c + 3]
        is_leaf = child < 0
        leaf_rows = np.flatnonzero(is_leaf)
        child32 = child.astype(np.int32)
        child32[leaf_rows] = -(np.arange(len(leaf_rows)) + 1)
        leaf = np.column_stack([M[leaf_rows], boxes[leaf_rows]])
        empty = vmass[leaf_rows] <= 0.0
        leaf[empty] = 0.0
        leaf_boxes = np.ascontiguousarray(leaf[:, 1:])
        norm = Iall[leaf_rows].sum(axis=0)
        norm, mt, mp, err = self.normalizer_table(leaf_boxes, norm, mt, mp)
        return {
            "child": child32,
            "vmass": vmass,
            "leaf": leaf,
            "norm": norm,
            "shape": np.array([mt, mp]),
            "build_seconds": np.asarray(time.perf_counter() - t0),
            "interp_error": np.asarray(err),
            "projection": np.asarray(PROJECTIONS.index(self.proj)),
            "scale": self.c_vals,
            "scale_shape": np.array([o.m_theta, 1 if self.iso else o.m_phi]),
            "scale_floor": np.asarray(self.c_floor),
        }

    def normalizer_table(self, leaf_boxes: np.ndarray, norm: np.ndarray, mt: int, mp: int):
        """Check the Chebyshev interpolation of ``I(wo)`` half-way between the nodes and refine the node set
        until the relative error is below ``interp_tol`` (or 48 nodes)."""
        t_lo, t_hi, f_lo, f_hi = self.t_lo, self.t_hi, self.f_lo, self.f_hi

        def error(mt: int, mp: int, vals: np.ndarray) -> float:
            xt = np.cos(np.arange(1, mt) * np.pi / mt)
            tt = 0.5 * (t_lo + t_hi) + 0.5 * (t_hi - t_lo) * xt
            if self.iso:
                pts = _tensor(tt, np.zeros(1))
            else:
                xp = np.cos(np.arange(1, mp) * np.pi / mp)
                ff = 0.5 * (f_lo + f_hi) + 0.5 * (f_hi - f_lo) * xp
                pts = _tensor(tt[[0, len(tt) // 2, -1]], ff[[0, len(ff) // 2, -1]])
            truth = self.integrals(leaf_boxes, pts)[0].sum(axis=0)
            meta = np.array([[0.0, mt, mp, t_lo, t_hi, f_lo, f_hi]])
            approx = normalizer_values(meta, vals, np.zeros(len(pts), dtype=np.int64), pts[:, 0], pts[:, 1])
            scale = max(float(np.max(np.abs(truth))), 1e-300)
            return float(np.max(np.abs(approx - truth)) / scale)

        err = error(mt, mp, norm)
        while err > self.opts.interp_tol and mt < 48:
            mt *= 2
            if not self.iso:
                mp = min(2 * mp, 20)
            nodes = _tensor(
                chebyshev_points(t_lo, t_hi, mt),
                np.zeros(1) if self.iso else chebyshev_points(f_lo, f_hi, mp),
            )
            norm = self.integrals(leaf_boxes, nodes)[0].sum(axis=0)
            err = error(mt, mp, norm)
        return norm, mt, mp, err


def build_tree(
    model: Any, params: np.ndarray, iso: bool, rng: tuple, opts: BuildOptions
) -> dict[str, np.ndarray]:
    """Build one bin's tree and normalizer; ``rng = (theta_lo, theta_hi, phi_lo, phi_hi)`` in radians.
    Returns the arrays :class:`core.quadtree_table.Bin` stores."""
    return _Builder(model, params, iso, rng, opts).build()
