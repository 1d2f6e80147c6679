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

**Construction** (the per-node work runs in compiled loops specialized per model,
:mod:`core.quadtree_build_kernels`; the refinement's bookkeeping is vectorized numpy). Per bin, first the *ridge*:
the peak of ``g`` over the disk at a 3 x 3 grid of ``wo`` of the bin (compass search from the mirror,
retro-reflection and normal points), its offset from the mirror point, and the lobe's half-width. A node at
depth >= ``min_depth`` gets the integral of ``g`` over its part of the disk at the normalizer nodes
(Gauss-Legendre on the exact region, :func:`core.quadtree_build_kernels.box_rule`) and a bound on ``g / c``:
the largest value on the quadrature points (at the normalizer nodes), on a 4 x 4 grid over ``B_L`` and on
circles near the rim crossing it (at the bin's edges and middle), and at the box's nearest points to the
ridge points (mirror, peak, retro) of a set of ``wo`` dense enough that the ridge moves by less than a third
of the lobe's half-width between neighbours; then a compass search in ``(X, Y, theta_o, phi_o)`` whose ``wo``
moves drag ``X`` along with the mirror point. ``M = (1 + safety) max``.
Phase 1, level by level: split while the bound is unsure (the search raised it by more than 2 %) or
``V > n_max I_L`` at the bin's best normalizer node (with an excess above ``excess_tol I``). Phase 2: while the
acceptance ``I / (c V)`` at the worst normalizer node is below ``1/n_max`` (plus a margin), split the leaves
with the largest excess ``V_L - I_L`` there, as long as a round gains at least 1 %.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit

from core.kernels import eval_batch
from core.model import LUMINANCE
from core.quadtree_build_kernels import R_MAX, build_kernels, scale_rows, scale_tables

TABLE_VERSION = 8
"""Bump when the construction changes what a table holds (part of the on-disk cache key)."""

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi
INV_PI = 1.0 / math.pi
QUAD_ORDER = 6
GRID = 4
ARC = 8
RIM_RINGS_DEG = (89.2, 89.5, 89.7, 89.85, 89.95, 89.99)
"""theta_i of the circles on which :meth:`_Builder.bound` also probes the leaves they cross (a band just inside
the horizon that the lattice and the rim's own arc step over)."""
PROJECTIONS = ("equidistant", "orthographic")
QUAD_TOL = 5e-5
"""Relative accuracy the normalizer's leaf quadrature aims at (:meth:`_Builder.quadrature_boxes`)."""
QUAD_LEVELS = 4
"""How many times a box of the normalizer's quadrature may be quartered."""
PRIOR_RATIO = 0.05
"""A leaf's rule error, as a fraction of the prediction from its ancestors' integrals
(:meth:`_NodeStore.parent_rule_error`), at most: measured up to 1.3e-2 over 18 trees of the library's lobes,
5e-3 where the error exceeds 1e-7 of ``I`` (:meth:`_Builder.quadrature_boxes`)."""


@lru_cache(maxsize=8)
def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on [0, 1] (shared, read-only)."""
    x, w = np.polynomial.legendre.leggauss(order)
    return _frozen(0.5 * (x + 1.0)), _frozen(0.5 * w)


def _f64(a: np.ndarray) -> np.ndarray:
    """Contiguous float64 (what the compiled loops take)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def _frozen(a: np.ndarray) -> np.ndarray:
    a = _f64(a)
    a.flags.writeable = False
    return a


@lru_cache(maxsize=1)
def _rim_probes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directions ``wi`` for :meth:`_Builder.grows_at_rim` as orthographic disk points ``(X, Y)`` (``g = f``
    there), and which of them lie on the rings near the horizon: rings at theta_i = 0..89 degrees (40) and at
    89.99 and 89.9999 degrees, 48 points each."""
    th_i = np.radians(np.concatenate([np.linspace(0.0, 89.0, 40), [89.99, 89.9999]]))
    ph_i = np.linspace(0.0, TWO_PI, 48, endpoint=False)
    T, P = np.meshgrid(th_i, ph_i, indexing="ij")
    s = np.sin(T.ravel())
    return _frozen(s * np.cos(P.ravel())), _frozen(s * np.sin(P.ravel())), T.ravel() > np.radians(89.5)


MIN_CHUNK = 8
"""Fewest boxes per thread in :meth:`_Builder.per_box`."""


@lru_cache(maxsize=1)
def _pool() -> ThreadPoolExecutor:
    """Threads for :meth:`_Builder.per_box` (created on first use, shared by all builders of the process)."""
    return ThreadPoolExecutor(max_workers=max(2, min(8, os.cpu_count() or 1)), thread_name_prefix="quadtree")


@lru_cache(maxsize=2)
def _rim_rings(projection: str) -> np.ndarray:
    """Radii on the disk of ``projection`` of the circles theta_i = :data:`RIM_RINGS_DEG`."""
    t = np.radians(RIM_RINGS_DEG)
    return _frozen(np.sin(t) if projection == "orthographic" else t / HALF_PI)


@lru_cache(maxsize=1)
def _polar_rule() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points ``X, Y`` and weights of the polar Gauss-Legendre rule over the disk of
    :meth:`_Builder.polar_estimate` (6 radial panels of the 6-point rule x 48 angles)."""
    gx, gw = gauss_legendre(QUAD_ORDER)
    nr = 6
    r = ((np.arange(nr)[:, None] + gx[None, :]) / nr).ravel()
    wr = np.tile(gw, nr) / nr
    nphi = 48
    phis = TWO_PI * (np.arange(nphi) + 0.5) / nphi
    R, P = np.meshgrid(r, phis, indexing="ij")
    WR = np.repeat(wr, nphi) * R.ravel() * (TWO_PI / nphi)
    return _frozen((R * np.cos(P)).ravel()), _frozen((R * np.sin(P)).ravel()), _frozen(WR)


@lru_cache(maxsize=1)
def _no_scale() -> tuple:
    """Scale tables for :meth:`_Builder.integrals` calls that need no ``g / c`` (never evaluated there)."""
    return scale_tables(np.ones(1), 1, 1, (0.0, 1.0, 0.0, 1.0), 1.0)


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


def _quarters(boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The four quarters of each box (rows ``x0, y0, x1, y1``), clipped to the disk (:func:`clip_boxes`), all
    first quarters first: row ``k n + i`` is quarter ``k`` of box ``i``; ``ok`` False where one misses the disk."""
    xm, ym = 0.5 * (boxes[:, 0] + boxes[:, 2]), 0.5 * (boxes[:, 1] + boxes[:, 3])
    return clip_boxes(
        np.concatenate([boxes[:, 0], xm, boxes[:, 0], xm]),
        np.concatenate([xm, boxes[:, 2], xm, boxes[:, 2]]),
        np.concatenate([boxes[:, 1], boxes[:, 1], ym, ym]),
        np.concatenate([ym, ym, boxes[:, 3], boxes[:, 3]]),
    )


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


def _check_whole(name: str, value: Any, lo: int, hi: int | None) -> None:
    """``value`` must be a whole number in ``[lo, hi]`` (``hi`` None: no upper limit); a ValueError naming
    the option otherwise (NaN, text, fractions included)."""
    whole = isinstance(value, int | np.integer) or (isinstance(value, float) and value.is_integer())
    if isinstance(value, bool) or not whole or value < lo or (hi is not None and value > hi):
        what = f"a whole number from {lo} to {hi}" if hi is not None else f"a whole number >= {lo}"
        raise ValueError(f"{name} must be {what}, got {value!r}")


def default_max_splits(n_max: float) -> int:
    """4 halvings of a bin for ``n_max >= 2``, more for a tighter target, up to 8 (``n_max`` 1.3: the
    grazing anisotropic bins need a slot of ~0.25 x 0.16 degrees to reach 1/1.3): ``4 + ceil(2 log2(1 /
    (n_max - 1)))``."""
    if not n_max > 1.0 or not math.isfinite(n_max):
        return 4
    return int(min(8, max(4, 4 + math.ceil(2.0 * math.log2(1.0 / (n_max - 1.0)) - 1e-9))))


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
        max_nodes: int = 16_384,
        safety: float = 0.05,
        excess_tol: float = 3e-3,
        m_theta: int = 6,
        m_phi: int = 5,
        interp_tol: float = 1e-5,
        z_min: float = 1e-6,
        search_iters: int = 12,
        acc_margin: float = 0.05,
        max_splits: int | None = None,
    ):
        if projection not in (*PROJECTIONS, "auto"):
            raise ValueError(f"projection must be 'auto' or one of {PROJECTIONS}")
        if max_splits is None:
            max_splits = default_max_splits(float(n_max))
        for name, value, lo, hi in (
            ("phi_bins", phi_bins, 1, None),
            ("max_nodes", max_nodes, 1, None),
            ("max_splits", max_splits, 0, 16),
        ):
            _check_whole(name, value, lo, hi)
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
        self.acc_margin = float(acc_margin)
        self.max_splits = int(max_splits)
        """How many times a bin may be halved (in theta_o or phi_o) when its tree cannot reach the
        acceptance 1/n_max over the whole bin (``core.quadtree_table``); by default
        :func:`default_max_splits`."""

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


class _NodeStore:
    """Nodes of one tree under construction, in creation order (children of a node are 4 consecutive
    rows); :meth:`linearize` writes them in level order."""

    def __init__(self, nw: int):
        self.n = 0
        self.cap = 0
        self.nw = nw
        self._grow(256)

    def _grow(self, cap: int) -> None:
        def ext(a, shape, fill, dtype=np.float64):
            out = np.full(shape, fill, dtype=dtype)
            if a is not None:
                out[: self.n] = a[: self.n]
            return out

        g = getattr
        self.x0 = ext(g(self, "x0", None), cap, 0.0)
        self.y0 = ext(g(self, "y0", None), cap, 0.0)
        self.size = ext(g(self, "size", None), cap, 0.0)
        self.depth = ext(g(self, "depth", None), cap, 0, np.int64)
        self.child = ext(g(self, "child", None), cap, -1, np.int64)
        self.box = ext(g(self, "box", None), (cap, 4), 0.0)
        self.ok = ext(g(self, "ok", None), cap, False, bool)
        self.M = ext(g(self, "M", None), cap, 0.0)
        self.V = ext(g(self, "V", None), cap, 0.0)
        self.I = ext(g(self, "I", None), (cap, self.nw), 0.0)
        self.raw_unsure = ext(g(self, "raw_unsure", None), cap, False, bool)
        self.cap = cap

    def add(self, x0: np.ndarray, y0: np.ndarray, size: np.ndarray, depth: np.ndarray) -> np.ndarray:
        k = len(x0)
        if self.n + k > self.cap:
            self._grow(max(2 * self.cap, self.n + k))
        rows = np.arange(self.n, self.n + k)
        self.x0[rows], self.y0[rows], self.size[rows], self.depth[rows] = x0, y0, size, depth
        boxes, ok = clip_boxes(x0, x0 + size, y0, y0 + size)
        self.box[rows] = np.where(ok[:, None], boxes, 0.0)
        self.ok[rows] = ok
        self.n += k
        return rows

    def split(self, rows: np.ndarray) -> np.ndarray:
        """Give each listed node its four children (order (x0,y0), (x0+h,y0), (x0,y0+h), (x0+h,y0+h));
        the parents' own bound and integrals are dropped. Returns the new rows."""
        if len(rows) == 0:
            return rows
        h = 0.5 * self.size[rows]
        sx, sy = self.x0[rows], self.y0[rows]
        nx0 = np.stack([sx, sx + h, sx, sx + h], axis=1).ravel()
        ny0 = np.stack([sy, sy, sy + h, sy + h], axis=1).ravel()
        kids = self.add(nx0, ny0, np.repeat(h, 4), np.repeat(self.depth[rows] + 1, 4))
        self.child[rows] = kids[::4]
        self.M[rows] = 0.0
        self.V[rows] = 0.0
        self.I[rows] = 0.0
        self.raw_unsure[rows] = False
        return kids

    def leaves(self) -> np.ndarray:
        return np.flatnonzero(self.child[: self.n] < 0)

    def linearize(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``child`` (int32; leaves as ``-(index + 1)``), ``vmass``, ``leaf (L, 5)`` rows ``M, x0, y0, x1,
        y1`` and the leaves' integrals, in level order (children of the r-th internal node at 1 + 4r)."""
        order = [0]
        i = 0
        while i < len(order):  # breadth first
            c = self.child[order[i]]
            if c >= 0:
                order.extend((c, c + 1, c + 2, c + 3))
            i += 1
        order = np.asarray(order)
        pos = np.empty(self.n, dtype=np.int64)
        pos[order] = np.arange(len(order))
        child = self.child[order]
        internal = child >= 0
        child = np.where(internal, pos[np.maximum(child, 0)], -1)
        is_leaf = ~internal
        n_leaves = int(is_leaf.sum())
        child32 = child.astype(np.int32)
        child32[is_leaf] = -(np.arange(n_leaves) + 1)
        rows = order[is_leaf]
        M = np.where(self.ok[rows], self.M[rows], 0.0)
        box = self.box[rows]
        area = (box[:, 2] - box[:, 0]) * (box[:, 3] - box[:, 1])
        vmass = np.zeros(len(order))
        vmass[is_leaf] = np.where(self.ok[rows], area * M, 0.0)
        for k in np.flatnonzero(internal)[::-1]:
            c = child[k]
            vmass[k] = vmass[c] + vmass[c + 1] + vmass[c + 2] + vmass[c + 3]
        leaf = np.column_stack([M, box])
        leaf[vmass[is_leaf] <= 0.0] = 0.0
        return child32, vmass, leaf, rows

    def parent_rule_error(self, rows: np.ndarray, min_depth: int) -> np.ndarray:
        """Per listed leaf and normalizer node: a prediction of its rule's error from its ancestors' stored
        integrals. ``d(n) = |I_n - sum of I over n's children|`` estimates node ``n``'s rule error; the
        leaf's is predicted as ``d(p) min(1, d(p) / d(gp))`` (parent ``p``, grandparent ``gp``: the error
        shrinks by the same factor again, as it does where the integrand is smooth on the leaf's scale), or
        ``d(p)`` without a grandparent; infinite where the parent's integrals were not computed."""
        n = self.n
        parent = np.full(n, -1, dtype=np.int64)
        internal = np.flatnonzero(self.child[:n] >= 0)
        for k in range(4):
            parent[self.child[internal] + k] = internal

        def d(nodes: np.ndarray) -> np.ndarray:
            first = self.child[np.maximum(nodes, 0)]
            kids = self.I[first] + self.I[first + 1] + self.I[first + 2] + self.I[first + 3]
            out = np.abs(self.I[np.maximum(nodes, 0)] - kids)
            out[(nodes < 0) | (self.depth[np.maximum(nodes, 0)] < min_depth - 1)] = np.inf
            return out

        p = parent[rows]
        gp = np.where(p >= 0, parent[np.maximum(p, 0)], -1)
        dp, dgp = d(p), d(gp)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(np.isfinite(dgp) & (dgp > 0.0), np.minimum(1.0, dp / dgp), 1.0)
        return np.where(np.isfinite(dp), dp * np.nan_to_num(ratio, nan=1.0), np.inf)


class _Builder:
    """Vectorized construction of one bin's tree."""

    def __init__(
        self, model: Any, params: np.ndarray, iso: bool, rng: tuple, opts: BuildOptions, threads: int = 1
    ):
        self.model, self.params, self.iso, self.opts = model, params, iso, opts
        self.t_lo, self.t_hi, self.f_lo, self.f_hi = rng
        self.gx, self.gw = gauss_legendre(QUAD_ORDER)
        self.proj = opts.projection
        self.k = build_kernels(model.eval)
        self.threads = max(1, int(threads))

    def per_box(self, n: int, work: Callable[[slice], tuple]) -> tuple[np.ndarray, ...]:
        """``work(rows)`` over the boxes ``0..n`` in contiguous chunks, on up to :attr:`threads` threads (the
        compiled loops release the GIL and treat every box on its own), concatenated in order: the result
        is the same whatever the number of threads."""
        k = min(self.threads, n // MIN_CHUNK)
        if k <= 1:
            return work(slice(0, n))
        edges = np.linspace(0, n, k + 1).astype(int)
        parts = list(_pool().map(work, [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True)]))
        return tuple(np.concatenate(arrays) for arrays in zip(*parts, strict=True))

    def own_tables(self) -> tuple:
        """The scale tables with a scratch array of their own (one per thread)."""
        meta, vals, nodes, tmp = self.c_tables
        return meta, vals, nodes, np.empty_like(tmp)

    def grows_at_rim(self, wo_ang: np.ndarray) -> bool:
        """Whether ``f`` rises toward the horizon of ``wi`` (then the orthographic ``g = f`` has no tight bound
        near the rim): the largest ``f`` on rings at theta_i = 89.99 and 89.9999 degrees against the largest
        ``f`` for theta_i <= 89 degrees, at the given ``wo``."""
        X, Y, rim = _rim_probes()
        n, nw = len(X), len(wo_ang)
        vals = self.k.g_rows(
            np.repeat(wo_ang[:, 0], n), np.repeat(wo_ang[:, 1], n), np.tile(X, nw), np.tile(Y, nw),
            PROJECTIONS.index("orthographic"), self.params,
        ).reshape(nw, n)  # fmt: skip
        return float(vals[:, rim].max()) > 2.0 * float(vals[:, ~rim].max())

    def g(self, theta: np.ndarray, phi: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """``g(wo(theta, phi), X)`` per row (one compiled pass)."""
        return self.k.g_rows(
            _f64(theta), _f64(phi), _f64(X), _f64(Y), PROJECTIONS.index(self.proj), self.params
        )

    def integrals(
        self, boxes: np.ndarray, wo_ang: np.ndarray, scaled: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per box and per ``wo``: integral of ``g`` over box-and-disk; with ``scaled`` (once the scale ``c`` is
        set), also the largest ``g / c`` on the rule per box and where it lies (rows ``X, Y, theta, phi``: a
        start for the bound's search)."""
        scaled = scaled and hasattr(self, "c_tables")
        return self.k.node_integrals(
            _f64(boxes), self.gx, self.gw, _f64(wo_ang[:, 0]), _f64(wo_ang[:, 1]),
            PROJECTIONS.index(self.proj), self.params, scaled, *(self.own_tables() if scaled else _no_scale()),
        )  # fmt: skip

    def box_integrals(self, boxes: np.ndarray, wo_ang: np.ndarray) -> np.ndarray:
        """Per box and ``wo``: the integral of ``g`` over box-and-disk (:meth:`per_box`)."""
        if len(boxes) == 0:
            return np.zeros((0, len(wo_ang)))
        boxes = np.ascontiguousarray(boxes)
        return self.per_box(len(boxes), lambda sl: (self.integrals(boxes[sl], wo_ang, scaled=False)[0],))[0]

    def box_integrals_given(
        self, boxes: np.ndarray, wo_ang: np.ndarray, known: np.ndarray, values: np.ndarray
    ) -> np.ndarray:
        """:meth:`box_integrals` at every ``wo`` where the columns ``known`` are already ``values`` (each
        column is computed on its own, so the result is the same as computing them all)."""
        out = np.empty((len(boxes), len(wo_ang)))
        out[:, known] = values
        rest = np.setdiff1d(np.arange(len(wo_ang)), known)
        if len(rest):
            out[:, rest] = self.box_integrals(boxes, wo_ang[rest])
        return out

    def integral_sums(self, boxes: np.ndarray, wo_ang: np.ndarray) -> np.ndarray:
        """Per ``wo``: the integral of ``g`` over all the boxes (:meth:`per_box`)."""
        return self.box_integrals(boxes, wo_ang).sum(axis=0)

    # -- the lobe's ridge: where the peak of g sits for each wo of the bin
    def ridge_setup(self, wo_all: np.ndarray) -> None:
        """Find the peak of ``g`` over the disk at a 3 x 3 (3 x 1) grid of ``wo`` of the bin, the lobe's
        half-width there, and from them the density of the ``wo`` samples along which :meth:`bound` probes
        each leaf: the ridge (the peak's position as a function of ``wo``) must move by less than a third of
        the half-width between neighbouring samples, so no leaf can sit between two probes unseen."""
        tb = np.linspace(self.t_lo, self.t_hi, 3)
        fb = np.zeros(1) if self.iso else np.linspace(self.f_lo, self.f_hi, 3)
        grid = _tensor(tb, fb)
        k = len(grid)
        mirror = self.mirror(grid[:, 0], grid[:, 1])
        retro = self.retro(grid[:, 0], grid[:, 1])
        starts = np.concatenate([mirror, retro, np.zeros_like(mirror)])
        ang = np.concatenate([grid, grid, grid])
        pts, vals = self.peak_search(ang, starts)
        pts, vals = pts.reshape(3, k, 2), vals.reshape(3, k)
        best = np.argmax(vals, axis=0)
        peak = pts[best, np.arange(k)]
        self.peak_offset = (peak - mirror).reshape(len(tb), len(fb), 2)
        self.tb, self.fb = tb, fb
        # half-width of the lobe around each peak: the smallest radius where g falls to half its peak
        radii = np.geomspace(1e-5, 1.0, 48)
        dirs = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)
        P = peak[:, None, None, :] + radii[None, :, None, None] * dirs[None, None, :, :]  # (k, 48, 8, 2)
        m = P.shape[1] * P.shape[2]
        v = self.g(
            np.repeat(grid[:, 0], m), np.repeat(grid[:, 1], m), P[..., 0].ravel(), P[..., 1].ravel()
        ).reshape(k, len(radii), len(dirs))
        top = vals[best, np.arange(k)]
        outside = (P * P).sum(axis=-1) >= R_MAX * R_MAX  # g is 0 there: not a sign of a narrow lobe
        below = (v < 0.5 * top[:, None, None]) & ~outside
        first = np.where(below.any(axis=1), np.argmax(below, axis=1), len(radii) - 1)  # (k, 8)
        width = radii[first].min(axis=1)
        self.lobe_width = float(width[top > 0.0].min()) if np.any(top > 0.0) else 1.0
        width = self.lobe_width
        # ridge speed in disk units per radian of theta_o and phi_o (finite differences of the mirror map)
        eps = 1e-4
        tc, fc = 0.5 * (self.t_lo + self.t_hi), (0.0 if self.iso else 0.5 * (self.f_lo + self.f_hi))
        c0 = self.mirror(np.array([tc]), np.array([fc]))[0]
        self.j_theta = (self.mirror(np.array([tc + eps]), np.array([fc]))[0] - c0) / eps
        self.j_phi = (self.mirror(np.array([tc]), np.array([fc + eps]))[0] - c0) / eps
        spacing = width / 3.0
        nt = int(np.clip(math.ceil(np.hypot(*self.j_theta) * (self.t_hi - self.t_lo) / spacing) + 1, 3, 96))
        npf = 1
        if not self.iso:
            npf = int(
                np.clip(math.ceil(np.hypot(*self.j_phi) * (self.f_hi - self.f_lo) / spacing) + 1, 3, 96)
            )
            while nt * npf > 1536:  # a cap on the cost; the search below covers the rest
                nt, npf = max(3, nt - 1), max(3, npf - 1)
        self.dense = _tensor(
            np.linspace(self.t_lo, self.t_hi, nt),
            np.zeros(1) if self.iso else np.linspace(self.f_lo, self.f_hi, npf),
        )
        self.step_theta = (self.t_hi - self.t_lo) / max(nt - 1, 1)
        self.step_phi = (self.f_hi - self.f_lo) / max(npf - 1, 1)
        d = self.dense
        self.ridge_pts = np.concatenate(
            [self.mirror(d[:, 0], d[:, 1]), self.peak(d[:, 0], d[:, 1]), self.retro(d[:, 0], d[:, 1])]
        )
        self.ridge_ang = np.concatenate([d, d, d])
        self.ridge = np.ascontiguousarray(np.column_stack([self.ridge_pts, self.ridge_ang]))

    def mirror(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        return direction_to_disk(angles_to_wo(theta, phi + math.pi), self.proj)

    def retro(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        return direction_to_disk(angles_to_wo(theta, phi), self.proj)

    def peak(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """The ridge: mirror point plus the peak's offset from it, interpolated (bilinear) over the bin."""
        off = self.peak_offset
        ut = np.clip((theta - self.tb[0]) / max(self.tb[-1] - self.tb[0], 1e-300) * 2.0, 0.0, 2.0)
        it = np.minimum(ut.astype(np.int64), 1)
        at = (ut - it)[:, None]
        if self.iso:
            o = off[it, 0] * (1 - at) + off[it + 1, 0] * at
        else:
            up = np.clip((phi - self.fb[0]) / max(self.fb[-1] - self.fb[0], 1e-300) * 2.0, 0.0, 2.0)
            ip = np.minimum(up.astype(np.int64), 1)
            ap = (up - ip)[:, None]
            o = (off[it, ip] * (1 - at) * (1 - ap) + off[it + 1, ip] * at * (1 - ap)
                 + off[it, ip + 1] * (1 - at) * ap + off[it + 1, ip + 1] * at * ap)  # fmt: skip
        p = self.mirror(theta, phi) + o
        r = np.sqrt((p * p).sum(axis=1))
        return p * np.where(r > R_MAX, R_MAX / np.where(r > 0, r, 1.0), 1.0)[:, None]

    def peak_search(self, ang: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Compass search for the largest ``g(wo, X)`` over the disk for fixed ``wo`` (rows), from ``start``."""
        px, py, pv = self.k.peak_search(
            _f64(ang[:, 0]), _f64(ang[:, 1]), _f64(start[:, 0]), _f64(start[:, 1]),
            PROJECTIONS.index(self.proj), self.params,
        )  # fmt: skip
        return np.column_stack([px, py]), pv

    def bound(
        self, boxes: np.ndarray, wo_ang: np.ndarray, qmax: np.ndarray, qstart: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(max before search, max after search)`` of ``g / c`` per box over the bin.

        Candidates: at the 3 (3 x 3) ``wo`` of the bin's edges and middle, a 4 x 4 grid over the box, 2 x 8
        points of the unit circle clamped into it and 8 on each circle theta_i = :data:`RIM_RINGS_DEG` crossing
        it; the best quadrature point of :meth:`integrals` over the normalizer's ``wo`` (``qstart``, value
        ``qmax``); the box's nearest points to the ridge points (mirror, peak, retro-reflection) of a dense set
        of ``wo`` (paired with that ``wo``). Then a compass search from the best two and from ``qstart``
        (``node_bounds`` in :data:`core.quadtree_build_kernels.BUILD_TEMPLATE`)."""
        srch = np.array([self.t_lo, self.t_hi, self.f_lo, self.f_hi, *self.j_theta, *self.j_phi,
                         self.step_theta, self.step_phi])  # fmt: skip
        return self.k.node_bounds(
            _f64(boxes), _f64(wo_ang[:, 0]), _f64(wo_ang[:, 1]), self.ridge, _f64(qmax), _f64(qstart),
            srch, self.iso, self.opts.search_iters, GRID, ARC, _rim_rings(self.proj), self.probe_from,
            PROJECTIONS.index(self.proj), self.params, *self.own_tables(),
        )  # fmt: skip

    def polar_estimate(self, wo_ang: np.ndarray) -> tuple[np.ndarray, float]:
        """Estimates of ``I`` at each ``wo`` (polar Gauss-Legendre) and the largest ``g`` seen."""
        X, Y, WR = _polar_rule()
        nw, P = len(wo_ang), len(X)
        vals = self.g(np.repeat(wo_ang[:, 0], P), np.repeat(wo_ang[:, 1], P), np.tile(X, nw), np.tile(Y, nw))
        vals = vals.reshape(nw, P)
        return vals @ WR, float(vals.max())

    def scale(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """The per-``wo`` scale ``c(wo)``, floored (see :meth:`QuadtreeTable.scales`)."""
        return scale_rows(_f64(theta), _f64(phi), *self.c_tables)

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
        self.probe_from = len(wo_norm)  # the bound's candidate points are probed at wo_bound
        if self.proj == "auto":
            self.proj = "equidistant" if self.grows_at_rim(wo_bound) else "orthographic"
        est, g_max = self.polar_estimate(wo_norm)
        self.ridge_setup(wo_all)
        # c(wo): the Chebyshev interpolant of the estimates, floored; bounds hold for g / c (exactness needs
        # only that sampling uses the same c; the closer c is to I, the less the bound varies over the bin)
        top = float(est.max())
        self.c_vals = np.ascontiguousarray(np.maximum(est, 0.0) if top > 0.0 else np.ones(len(est)))
        self.c_floor = 0.05 * float(self.c_vals.max())
        self.c_tables = scale_tables(self.c_vals, mt, mp, (t_lo, t_hi, f_lo, f_hi), self.c_floor)
        c_norm = self.scale(wo_norm[:, 0], wo_norm[:, 1])
        i_ref = float(np.min(est / c_norm)) if top > 0.0 else 1.0
        floor = 1e-9 * g_max / float(c_norm.min()) if g_max > 0.0 else 1e-300
        nw = len(wo_norm)

        # the node store: rows in creation order; children of a node are 4 consecutive rows
        store = _NodeStore(nw)
        store.add(np.array([-1.0]), np.array([-1.0]), np.array([2.0]), np.array([0]))

        def evaluate(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """Integrals and bounds of the listed nodes; returns (unsure, V / (I at the best node))."""
            boxes, ok = store.box[rows], store.ok[rows]
            unsure = np.zeros(len(rows), dtype=bool)
            ratio = np.zeros(len(rows))
            ev = np.flatnonzero(ok)
            if len(ev):
                b = boxes[ev]

                def work(sl: slice) -> tuple[np.ndarray, ...]:
                    Ie, qmax, qstart = self.integrals(b[sl], wo_norm)
                    return (Ie, *self.bound(b[sl], wo_all, qmax, qstart))

                Ie, before, after = self.per_box(len(b), work)
                un = after > 1.02 * before
                Me = np.maximum((1.0 + o.safety) * after, floor)
                area = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
                store.M[rows[ev]] = Me
                store.I[rows[ev]] = Ie / c_norm[None, :]
                store.V[rows[ev]] = area * Me
                store.raw_unsure[rows[ev]] = un
                unsure[ev] = un
            return unsure, ratio

        # phase 1, level by level: split where the bound is unsure, or where the envelope is loose even for the
        # best wo of the bin (a lobe that moves across the bin by more than its width cannot be fitted by
        # smaller leaves at every wo: phase 2 handles the acceptance over the whole bin)
        level = np.array([0])
        depth = 0
        while len(level):
            if depth < o.min_depth:
                split = store.ok[level].copy()
                if depth == o.min_depth - 1 and split.any():  # integrals only: the leaves' rule-error prior
                    rows = level[split]
                    store.I[rows] = self.box_integrals(store.box[rows], wo_norm) / c_norm[None, :]
            else:
                unsure, _ = evaluate(level)
                V = store.V[level]
                i_best = store.I[level].max(axis=1)
                wasteful = (V > o.n_max * i_best) & (V - i_best > o.excess_tol * i_ref)
                split = store.ok[level] & (unsure | wasteful) & (depth < o.max_depth)
                budget = max((o.max_nodes - store.n) // 4, 0)
                if split.sum() > budget:
                    split[np.flatnonzero(split)[budget:]] = False
            level = store.split(level[split])
            depth += 1

        def widen_unsure() -> None:
            """Leaves whose bound is still unsure (depth guard, node budget): a 2x margin."""
            leaves = store.leaves()
            un = leaves[store.raw_unsure[leaves]]
            store.M[un] *= 2.0
            store.V[un] *= 2.0
            store.raw_unsure[un] = False

        widen_unsure()
        # phase 2: the acceptance I(wo) / (c V) must reach 1/n_max at every normalizer node; split greedily
        # the leaves with the largest excess V_L - I_L(wo)/c at the worst node, while that helps
        # (a lobe that moves across the bin by more than its width cannot reach it: stop when a round gains
        # less than 1 %, or at 1.5 times the leaves phase 1 made: 1.5 / (n_max - 1) times, up to 6, for n_max
        # below 2, whose tighter target needs more leaves; n_max 1.3 missed 1/n_max by 1-2 % at the old cap)
        target_acc = 1.0 / o.n_max
        last = -1.0
        leaf_cap = int(min(6.0, max(1.5, 1.5 / (o.n_max - 1.0))) * len(store.leaves())) + 64
        for _ in range(40):
            leaves = store.leaves()
            live = leaves[store.ok[leaves]]
            tot_V = float(store.V[live].sum())
            tot_I = store.I[live].sum(axis=0)
            if tot_V <= 0.0:
                break
            acc = tot_I / tot_V
            w = int(np.argmin(acc))
            if (
                acc[w] >= target_acc * (1.0 + o.acc_margin)
                or acc[w] <= last * 1.01
                or len(leaves) >= leaf_cap
            ):
                break
            last = float(acc[w])
            excess = store.V[live] - store.I[live, w]
            excess[store.depth[live] >= o.max_depth] = 0.0
            order = np.argsort(-excess)
            need = tot_V - tot_I[w] / (target_acc * (1.0 + o.acc_margin))  # V to remove
            cum = np.cumsum(excess[order])
            k = int(np.searchsorted(cum, 2.0 * need)) + 1
            pick = order[: max(1, min(k, len(order)))]
            pick = pick[excess[pick] > 0.0]
            budget = max(min((o.max_nodes - store.n) // 4, (leaf_cap - len(leaves) + 2) // 3), 0)
            pick = pick[:budget]
            if len(pick) == 0:
                break
            evaluate(store.split(live[pick]))
            widen_unsure()  # phase 2 does not chase unsure bounds

        child32, vmass, leaf, rows = store.linearize()
        live = vmass[child32 < 0] > 0.0
        rows = rows[live]
        quad_boxes, quad_vals = self.quadrature_boxes(
            np.ascontiguousarray(leaf[live, 1:]),
            store.I[rows] * c_norm,
            vmass[child32 < 0][live],
            store.parent_rule_error(rows, o.min_depth) * c_norm,
            c_norm,
            wo_norm,
        )
        norm, mt, mp, err = self.normalizer_table(quad_boxes, quad_vals.sum(axis=0), mt, mp)
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

    def quadrature_boxes(
        self,
        boxes: np.ndarray,
        vals: np.ndarray,
        mass: np.ndarray,
        prior: np.ndarray,
        c_norm: np.ndarray,
        wo_norm: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Boxes over which the leaf rule integrates ``g`` to the normalizer's accuracy, and their integrals at
        the normalizer nodes: the leaves, with those whose 6 x 6 rule may be off refined into quarters
        (recursively, up to :data:`QUAD_LEVELS` times).

        The leaves are made for sampling, not for quadrature: at a large ``n_max`` a leaf may hold most of a
        sharp lobe, and its rule is then 0.1 % off (Cook-Torrance at 60 degrees, ``n_max`` 3), which would
        make the reported pdf integrate to 1.001. The estimate of a box's error is the difference between its
        rule and the sum of its quarters' rules, at three of the normalizer nodes (the first, middle and
        last); boxes are refined, largest estimate first, until the estimates left sum to at most
        ``QUAD_TOL * I``. Refined boxes keep their quarters' rules (the more accurate ones). Shortcuts where
        the check would find nothing:

        - a box's true integral is at most ``c(wo) V_L`` (the leaf's bound), and a leaf's rule error is in
          practice at most ``PRIOR_RATIO`` of ``prior``, its prediction from the parent's and grandparent's
          rules against their children's (known from the construction): the smallest leaves whose sizes by
          either measure sum to half the tolerance are kept as they are (quarters: a tenth, by the bound);
        - the other leaves are first compared with their quarters at the middle node only: if they differ by
          at most a fifth of the tolerance in all, the lobe is resolved and nothing is refined.

        Measured on the leaves' own rules, the normalizer was 6.9e-4 off for Cook-Torrance at 30 degrees
        (``n_max`` 2), 1.1e-3 at 60 degrees (``n_max`` 3); refined, 1.4e-5 and 2.9e-5 (by hand)."""
        total = np.maximum(vals.sum(axis=0), 1e-300)
        nw = len(wo_norm)
        probe = np.arange(nw) if nw <= 3 else np.array([0, nw // 2, nw - 1])
        keep_b, keep_v = [], []
        for level in range(QUAD_LEVELS + 1):
            if len(boxes) == 0:
                break
            size = np.max(np.maximum(vals, mass[:, None] * c_norm[None, :]) / total[None, :], axis=1)
            skip = 0.1 * QUAD_TOL
            if level == 0:  # the leaves: their parents' rule errors too
                size = np.minimum(size, PRIOR_RATIO * np.max(prior / total[None, :], axis=1))
                skip = 0.5 * QUAD_TOL
            order = np.argsort(size)
            small = np.zeros(len(boxes), dtype=bool)
            small[order[np.cumsum(size[order]) <= skip]] = True
            if level == QUAD_LEVELS or not (~small).any():
                keep_b.append(boxes)
                keep_v.append(vals)
                break
            keep_b.append(boxes[small])
            keep_v.append(vals[small])
            boxes, vals, mass = boxes[~small], vals[~small], mass[~small]
            n = len(boxes)
            quarters, ok = _quarters(boxes)
            qvals = np.zeros((4 * n, len(probe)))
            known = np.zeros(0, dtype=np.int64)  # columns of qvals computed already
            if level == 0:
                # a first look at the middle node only: where the leaves' rules already agree with their
                # quarters' there (the lobe is resolved), the lobe's shape at the other nodes is too
                known = np.flatnonzero(probe == nw // 2)
                qvals[ok, known[0]] = self.box_integrals(quarters[ok], wo_norm[probe[known]])[:, 0]
                diff = (
                    np.abs(qvals[:, known[0]].reshape(4, n).sum(axis=0) - vals[:, nw // 2]) / total[nw // 2]
                )
                if float(diff.sum()) <= 0.2 * QUAD_TOL:
                    keep_b.append(boxes)
                    keep_v.append(vals)
                    break
            qvals[ok] = self.box_integrals_given(quarters[ok], wo_norm[probe], known, qvals[ok][:, known])
            est = np.max(np.abs(qvals.reshape(4, n, -1).sum(axis=0) - vals[:, probe]) / total[probe], axis=1)
            order = np.argsort(est)
            refine = np.ones(n, dtype=bool)
            refine[order[np.cumsum(est[order]) <= QUAD_TOL]] = False
            keep_b.append(boxes[~refine])
            keep_v.append(vals[~refine])
            # the refined boxes' quarters, at every normalizer node, are the next level's boxes
            pick = (np.tile(refine, 4) & ok).nonzero()[0]
            boxes = np.ascontiguousarray(quarters[pick])
            vals = self.box_integrals_given(boxes, wo_norm, probe, qvals[pick])
            mass = np.tile(mass, 4)[pick]
        return np.ascontiguousarray(np.concatenate(keep_b)), np.concatenate(keep_v)

    def normalizer_table(self, leaf_boxes: np.ndarray, norm: np.ndarray, mt: int, mp: int):
        """Check the Chebyshev interpolation of ``I(wo)`` and refine the node set until the relative error
        is below ``interp_tol``.

        Isotropic bins triple the nodes (6, 18, 54): the first-kind Chebyshev points of ``m`` are among
        those of ``3m``, so every value is reused, and the ``2m`` new values measure the error of the
        ``m``-point interpolant. The coarsest passing set is stored; if none passes below 54 nodes, the 54
        are stored and the error of the 18-point interpolant is reported (an upper bound in practice).
        Anisotropic bins check half-way between the nodes; on failure they double the nodes of the
        dimension(s) whose error alone fails (up to 48 x 20), and stop when a doubling does not halve the
        error: near the horizon the measured error is the leaf quadrature's wobble in ``wo``, not the
        interpolant's (the smaller error's set is kept, and reported)."""
        t_lo, t_hi, f_lo, f_hi = self.t_lo, self.t_hi, self.f_lo, self.f_hi

        def interp(vals: np.ndarray, m_t: int, m_p: int, pts: np.ndarray) -> np.ndarray:
            meta = np.array([[0.0, m_t, m_p, t_lo, t_hi, f_lo, f_hi]])
            return normalizer_values(meta, vals, np.zeros(len(pts), dtype=np.int64), pts[:, 0], pts[:, 1])

        def rel(approx: np.ndarray, truth: np.ndarray) -> float:
            scale = max(float(np.max(np.abs(truth))), 1e-300)
            return float(np.max(np.abs(approx - truth)) / scale)

        if self.iso:
            err = math.inf
            while True:
                fine = chebyshev_points(t_lo, t_hi, 3 * mt)
                old = np.arange(3 * mt) % 3 == 1  # the m coarse points sit at every third fine point
                pts = _tensor(fine[~old], np.zeros(1))
                new_vals = self.integral_sums(leaf_boxes, pts)
                err = rel(interp(norm, mt, 1, pts), new_vals)
                vals = np.empty(3 * mt)
                vals[old] = norm
                vals[~old] = new_vals
                if err <= self.opts.interp_tol:
                    return norm, mt, mp, err
                norm, mt = vals, 3 * mt
                if mt >= 54:
                    return norm, mt, mp, err

        def error(mt: int, mp: int, vals: np.ndarray, along: str = "tp") -> float:
            """Relative error of the interpolant at 3 x 3 points: half-way between the nodes in the
            dimensions of ``along``, at nodes in the others (where it measures the other dimension only)."""
            pts = []
            for lo, hi, m, dim in ((t_lo, t_hi, mt, "t"), (f_lo, f_hi, mp, "p")):
                x = (
                    np.cos(np.arange(1, m) * np.pi / m)
                    if dim in along
                    else np.cos((np.arange(m) + 0.5) * np.pi / m)
                )
                v = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x
                pts.append(v[[0, len(v) // 2, -1]])
            pts = _tensor(*pts)
            truth = self.integral_sums(leaf_boxes, pts)
            return rel(interp(vals, mt, mp, pts), truth)

        err = error(mt, mp, norm)
        while err > self.opts.interp_tol and (mt < 48 or mp < 20):
            # double the dimension(s) that fail on their own
            grow_t = mt < 48 and error(mt, mp, norm, "t") > 0.5 * self.opts.interp_tol
            grow_p = mp < 20 and error(mt, mp, norm, "p") > 0.5 * self.opts.interp_tol
            if not (grow_t or grow_p):
                grow_t, grow_p = mt < 48, mp < 20
            mt2, mp2 = (2 * mt if grow_t else mt), (min(2 * mp, 20) if grow_p else mp)
            nodes = _tensor(chebyshev_points(t_lo, t_hi, mt2), chebyshev_points(f_lo, f_hi, mp2))
            norm2 = self.integral_sums(leaf_boxes, nodes)
            err2 = error(mt2, mp2, norm2)
            if err2 > 0.5 * err:
                # Doubling the nodes did not halve the error: what is measured is the leaf quadrature's own
                # wobble in wo (a sharp lobe crossing leaf edges), which more nodes cannot fix.
                return (norm2, mt2, mp2, err2) if err2 < err else (norm, mt, mp, err)
            norm, mt, mp, err = norm2, mt2, mp2, err2
        return norm, mt, mp, err


def build_tree(
    model: Any, params: np.ndarray, iso: bool, rng: tuple, opts: BuildOptions, threads: int = 1
) -> dict[str, np.ndarray]:
    """Build one bin's tree and normalizer; ``rng = (theta_lo, theta_hi, phi_lo, phi_hi)`` in radians.
    Returns the arrays :class:`core.quadtree_table.Bin` stores. ``threads``: how many threads share the
    per-node work (the tree is the same for any number)."""
    return _Builder(model, params, iso, rng, opts, threads).build()
