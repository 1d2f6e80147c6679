"""The adaptive sampler's tables: the trees of one BRDF (:class:`QuadtreeTable`) in compact form, and the
entry points of exact rejection sampling and the pdf (fused numba kernels, :mod:`core.quadtree_kernels`).
The construction of one tree and the disk projections live in :mod:`core.quadtree`; the sampling proof is in
its docstring and in ``docs/adaptive.md``.
"""

from __future__ import annotations

import copy
import os
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from numba import njit

from core._numba_cache import source_hash
from core.errors import BrdfStudioError
from core.quadtree import (
    PROJECTIONS,
    TABLE_VERSION,
    TWO_PI,
    BuildOptions,
    angles_to_wo,
    build_tree,
    target,
    theta_edges,
)
from core.quadtree_kernels import (
    CHUNK,
    FRAME_FULL,
    FRAME_ISO,
    FRAME_MIRROR,
    HALF_PI,
    bins_present,
    chebyshev_coefficients,
    locate_rows,
    model_kernels,
    setup_rows,
    tree_leaves,
    values_rows,
)

SPLIT = "split"
"""The one array of a stored split marker: the bin was halved in this dimension (0 theta, 1 phi)."""

SPLIT_MARGIN = 0.01
"""A tree whose acceptance on the check grid is below ``(1 + SPLIT_MARGIN) / n_max`` is split (the margin
covers the dips between the grid's points)."""

SPLIT_GAIN = 1.1
"""A half is split again only if halving paid: its acceptance is at least this factor above what its parent's
tree had over the half, or it closed at least ``SPLIT_CLOSED`` of the gap to the target. When halving stops
paying (the lobe is narrower than the leaves the depth guard allows, not moving), more halves would only
multiply the trees."""

SPLIT_CLOSED = 0.2
"""The part of the gap between the parent's acceptance and the target ``(1 + SPLIT_MARGIN) / n_max`` that a
half must close to count as paid when it gained less than ``SPLIT_GAIN`` (near the target, as at
``n_max`` 1.3, a halving that gains 7 % may be all that is missing)."""


def halving_paid(own: float, inherited: float, n_max: float) -> bool:
    """Whether a half whose tree accepts ``own`` improved enough on ``inherited`` (what its parent's tree
    accepted over the half) to be halved again: by ``SPLIT_GAIN``, or by ``SPLIT_CLOSED`` of the gap to the
    target."""
    target = (1.0 + SPLIT_MARGIN) / n_max
    return own >= SPLIT_GAIN * inherited or own - inherited >= SPLIT_CLOSED * (target - inherited)


BUILD_THREADS = max(1, min(4, os.cpu_count() or 1))
"""Threads that build the trees of several missing bins at once (a render's warm-up asks for hundreds)."""

MASS_UNITS = float(2**30)
"""A tree's total mass in integer units: leaf masses are rounded up to multiples of ``V / 2^30`` (the bound
grows by at most one unit per leaf, ~1e-9 V), and the sums stay below ``2^32``."""


@njit(nogil=True, cache=True)
def _sum_up(mass, first):
    """Internal nodes' masses as the exact sums of their children's (children after parents)."""
    for k in range(mass.shape[0] - 1, -1, -1):
        c = first[k]
        if c >= 0:
            mass[k] = mass[c] + mass[c + 1] + mass[c + 2] + mass[c + 3]


COEF_TOL = 1e-13
"""Chebyshev coefficients of a normalizer table below ``COEF_TOL * sum |c|`` at the end of either axis are
dropped: the interpolant changes by less than ~1e-10 relative (the builder's interpolation tolerance is
1e-5), and a grazing anisotropic bin's table (48 x 20 values) shrinks to about half."""


def truncated_coefficients(values: np.ndarray, shape: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients ``(flattened, shape)`` of the Chebyshev interpolant through ``values`` (the builder's
    ``m_theta x m_phi`` table at Chebyshev points of the first kind), trailing negligible ones dropped."""
    mt, mp = int(shape[0]), int(shape[1])
    c = chebyshev_coefficients(np.asarray(values, dtype=np.float64), mt, mp).reshape(mt, mp)
    a = np.abs(c)
    tol = COEF_TOL * float(a.sum())
    rows = int(np.flatnonzero(a.max(axis=1) > tol).max(initial=0)) + 1
    cols = int(np.flatnonzero(a.max(axis=0) > tol).max(initial=0)) + 1
    return np.ascontiguousarray(c[:rows, :cols].ravel()), np.array([rows, cols], dtype=np.int64)


def compact_tree(child: np.ndarray, vmass: np.ndarray, leaf: np.ndarray) -> dict[str, Any]:
    """The stored form of a tree from the builder's arrays (``child`` with leaves as ``-(index + 1)``,
    ``vmass`` per node, ``leaf (L, 5)`` rows ``M, x0, y0, x1, y1``): integer masses per node, one bit per node
    marking internal nodes, the count of internal nodes before each 64-bit word, and the mass unit."""
    child = np.asarray(child, dtype=np.int64)
    n = len(child)
    internal = child >= 0
    rank = np.cumsum(internal) - internal
    if np.any(child[internal] != 1 + 4 * rank[internal]):
        raise ValueError("the tree is not in level order (children of internal node r at 1 + 4 r)")
    leaf_rows = np.flatnonzero(~internal)
    if not np.array_equal(-child[leaf_rows] - 1, np.arange(len(leaf_rows))):
        raise ValueError("leaves are not numbered in level order")
    M = leaf[:, 0]
    area = (leaf[:, 3] - leaf[:, 1]) * (leaf[:, 4] - leaf[:, 2])
    v_leaf = np.asarray(vmass, dtype=np.float64)[leaf_rows]
    total = float(vmass[0])
    unit = total / MASS_UNITS if total > 0.0 else 1.0
    pos = v_leaf > 0.0
    q = np.where(pos, np.ceil(np.where(pos, v_leaf, 0.0) / unit), 0.0)
    for _ in range(8):  # the bound the sampler derives, V unit / area, must not fall below M
        safe = np.where(pos, area, 1.0)
        low = pos & (q * unit / safe < M)
        if not low.any():
            break
        q[low] += 1.0
    mass = np.zeros(n, dtype=np.int64)
    mass[leaf_rows] = q.astype(np.int64)
    _sum_up(mass, np.where(internal, child, -1))
    if n and mass[0] >= 2**32:
        raise ValueError("tree mass does not fit 32 bits")
    words = (n + 63) // 64
    padded = np.zeros(words * 64, dtype=bool)
    padded[:n] = internal
    bits = np.packbits(padded, bitorder="little").view("<u8").astype(np.uint64)
    per_word = padded.reshape(words, 64).sum(axis=1)
    cum = (np.cumsum(per_word) - per_word).astype(np.uint32)
    return {"mass": mass.astype(np.uint32), "bits": bits, "cum": cum, "unit": np.asarray(unit)}


class Bin:
    """One incident-angle bin: its tree in compact form (see :mod:`core.quadtree_kernels`) and its
    normalizer and scale tables. Made from the builder's arrays or from a stored (cached) bin."""

    def __init__(self, arrays: dict[str, np.ndarray]):
        if "leaf" in arrays:  # the builder's form
            arrays = {**arrays, **compact_tree(arrays["child"], arrays["vmass"], arrays["leaf"])}
        self.mass = np.ascontiguousarray(arrays["mass"], dtype=np.uint32)
        """Integer mass per node (level order), in units of :attr:`unit`."""
        self.bits = np.ascontiguousarray(arrays["bits"], dtype=np.uint64)
        """One bit per node: internal (1) or leaf (0)."""
        self.cum = np.ascontiguousarray(arrays["cum"], dtype=np.uint32)
        """Internal nodes before each word of :attr:`bits`."""
        self.unit = float(arrays["unit"])
        if "norm_coef" in arrays:  # the stored form
            self.norm_coef = np.ascontiguousarray(arrays["norm_coef"], dtype=np.float64)
            self.norm_shape = np.asarray(arrays["norm_shape"], dtype=np.int64)
            self.scale_coef = np.ascontiguousarray(arrays["scale_coef"], dtype=np.float64)
            self.scale_shape = np.asarray(arrays["scale_shape"], dtype=np.int64)
        else:  # the builder's values at Chebyshev points
            self.norm_coef, self.norm_shape = truncated_coefficients(arrays["norm"], arrays["shape"])
            self.scale_coef, self.scale_shape = truncated_coefficients(arrays["scale"], arrays["scale_shape"])
        """Chebyshev coefficients ``[k_theta, k_phi]`` (flattened, ``*_shape`` = counts) of ``I(wo)`` and of
        the scale ``c(wo)`` over the bin."""
        self.build_seconds = float(arrays["build_seconds"])
        self.interp_error = float(arrays["interp_error"])
        self.projection = int(arrays["projection"])
        """Index into ``PROJECTIONS``."""
        self.scale_floor = float(arrays["scale_floor"])
        self.domain: tuple[float, ...] | None = (
            tuple(float(v) for v in np.asarray(arrays["domain"]).ravel()) if "domain" in arrays else None
        )
        """The bin the tree was built for, when it serves a smaller one (a half whose own tree was worse:
        :class:`QuadtreeTable`); its tables are functions over this range."""
        if self.domain is not None and len(self.domain) != 4:
            raise ValueError("a tree's domain has 4 numbers")
        if self.norm_coef.size != int(np.prod(self.norm_shape)) or self.scale_coef.size != int(
            np.prod(self.scale_shape)
        ):
            raise ValueError("inconsistent normalizer tables")
        if len(self.bits) != (len(self.mass) + 63) // 64 or len(self.cum) != len(self.bits):
            raise ValueError("inconsistent tree arrays")

    def serving(self, domain: tuple[float, ...]) -> Bin:
        """This tree (the same arrays) as the tree of a part of ``domain``, the bin it was built for."""
        other = copy.copy(self)
        other.domain = tuple(float(v) for v in domain)
        other.build_seconds = 0.0  # counted where it was built
        return other

    def arrays(self) -> dict[str, np.ndarray]:
        extra = {} if self.domain is None else {"domain": np.asarray(self.domain)}
        return {
            **extra,
            "mass": self.mass,
            "bits": self.bits,
            "cum": self.cum,
            "unit": np.asarray(self.unit),
            "norm_coef": self.norm_coef,
            "norm_shape": self.norm_shape,
            "build_seconds": np.asarray(self.build_seconds),
            "interp_error": np.asarray(self.interp_error),
            "projection": np.asarray(self.projection),
            "scale_coef": self.scale_coef,
            "scale_shape": self.scale_shape,
            "scale_floor": np.asarray(self.scale_floor),
        }

    @property
    def nbytes(self) -> int:
        """Memory of the tree and its normalizer and scale tables (the arrays held; a few scalars aside)."""
        return int(
            self.mass.nbytes
            + self.bits.nbytes
            + self.cum.nbytes
            + self.norm_coef.nbytes
            + self.scale_coef.nbytes
        )

    @property
    def total_mass(self) -> float:
        """``V``, the sum of the leaves' envelope masses (in the units of ``g / c``)."""
        return float(self.mass[0]) * self.unit

    @property
    def n_nodes(self) -> int:
        return int(len(self.mass))

    @property
    def n_leaves(self) -> int:
        internal = int(self.cum[-1]) + int(np.unpackbits(self.bits[-1:].view(np.uint8)).sum())
        return self.n_nodes - internal

    def leaf_rows(self) -> np.ndarray:
        """``(L, 5)`` rows ``M, x0, y0, x1, y1`` of every leaf in level order: the bound the sampler uses
        (``V_L unit / area``, in the units of ``g / c``) and the disk-clipped box, recomputed from the leaf's
        position exactly as sampling does (zeros for leaves of mass 0, outside the disk)."""
        return tree_leaves(self.mass, self.bits, self.cum, self.unit, self.n_nodes)


# ------------------------------------------------------------------------------------------- the table


def build_bin(
    model: Any, params: np.ndarray, iso: bool, rng: tuple, opts: BuildOptions, threads: int = 1
) -> Bin:
    """Build one bin's tree and normalizer; ``rng = (theta_lo, theta_hi, phi_lo, phi_hi)`` in radians."""
    return Bin(build_tree(model, params, iso, rng, opts, threads))


def min_acceptance(tree: Bin, rng: tuple, iso: bool, n: int = 9, part: tuple | None = None) -> float:
    """The smallest per-trial acceptance ``I(wo) / (c(wo) V)`` of the tree of bin ``rng`` on an ``n x n``
    grid of ``wo`` over the bin, or over ``part`` of it (edges and corners included; ``n`` points in
    ``theta_o`` when isotropic). Points where ``I(wo) <= 0`` use the cosine density and do not count."""
    at = rng if part is None else part
    t = np.linspace(at[0], at[1], n)
    p = np.zeros(1) if iso else np.linspace(at[2], at[3], n)
    theta = np.repeat(t, len(p))
    phi = np.tile(p, len(t))
    zero = np.zeros(len(theta), dtype=np.int64)
    m_max = int(max(tree.norm_shape.max(), tree.scale_shape.max()))
    norm = values_rows(np.array([[0.0, *tree.norm_shape, *rng]]), tree.norm_coef, zero, theta, phi, m_max)
    scale = values_rows(np.array([[0.0, *tree.scale_shape, *rng]]), tree.scale_coef, zero, theta, phi, m_max)
    env = np.maximum(scale, tree.scale_floor) * tree.total_mass
    live = (norm > 0.0) & (env > 0.0)
    if not live.any():
        return 1.0
    return float(np.min(norm[live] / env[live]))


def halves(rng: tuple, dim: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The lower and upper half of the bin ``rng`` halved in ``dim`` (0 theta, 1 phi)."""
    lo, hi = list(rng), list(rng)
    lo[2 * dim + 1] = hi[2 * dim] = 0.5 * (rng[2 * dim] + rng[2 * dim + 1])
    return tuple(lo), tuple(hi)


def split_dimension(model: Any, params: np.ndarray, tree: Bin, rng: tuple, iso: bool) -> int:
    """The dimension to halve a bin in (0 theta, 1 phi; always theta when isotropic): the one across which
    the normalized ``g(wo, .)`` changes more, measured as the total-variation distance between the density
    at the bin's centre and at the middle of each of its edges, on the tree's leaves (centre value times
    area: the leaves are finest where the lobes are). A lobe that moves, and a lobe that changes shape (near
    the horizon), both count."""
    if iso:
        return 0
    leaf = tree.leaf_rows()
    leaf = leaf[leaf[:, 0] > 0.0]
    X, Y = 0.5 * (leaf[:, 1] + leaf[:, 3]), 0.5 * (leaf[:, 2] + leaf[:, 4])
    area = (leaf[:, 3] - leaf[:, 1]) * (leaf[:, 4] - leaf[:, 2])
    proj = PROJECTIONS[tree.projection]
    tc, pc = 0.5 * (rng[0] + rng[1]), 0.5 * (rng[2] + rng[3])
    probes = [(tc, pc), (rng[0], pc), (rng[1], pc), (tc, rng[2]), (tc, rng[3])]
    dens = []
    for t, p in probes:
        wo = np.repeat(angles_to_wo(np.array([t]), np.array([p])), len(X), axis=0)
        g = np.nan_to_num(target(model, params, wo, X, Y, proj)) * area
        total = float(g.sum())
        dens.append(g / total if total > 0.0 else g)
    tv = [0.5 * float(np.abs(d - dens[0]).sum()) for d in dens[1:]]
    return 0 if max(tv[0], tv[1]) >= max(tv[2], tv[3]) else 1


class QuadtreeTable:
    """The lazily built trees of one BRDF: one per incident-angle bin, built on first use, kept in memory and
    (with a :class:`core.cache.TableCache`) on disk.

    Isotropic BRDFs have bins over ``theta_o`` only and work in the frame rotated so that ``phi_o = 0``;
    anisotropic ones have bins over ``(theta_o, phi_o)``: over the quadrant ``0 <= phi_o <= 90`` degrees
    (``phi_bins / 4`` bins, mirrored to the row's quadrant) when the model is mirror-symmetric, over the whole
    circle otherwise. A bin whose tree cannot reach the acceptance ``1/n_max`` over the whole bin (a lobe that
    moves across the bin by more than its width) is **split**: halved in ``theta_o`` or ``phi_o``
    (:func:`split_dimension`), up to ``max_splits`` times, each half built when first needed. Slots
    ``0 .. n_bins - 1`` are the base bins; halves are appended (``sub``: first child and dimension, -1 for
    a slot that holds a tree or is not built yet). ``sample`` and ``pdf`` use the same slot for a given ``wo``. Where
    ``cos(theta_o) < z_min`` or ``I(wo) = 0`` (``f`` vanishes) both use the cosine density.
    Sampling and the pdf run in fused numba kernels specialized to the model's ``eval``
    (:mod:`core.quadtree_kernels`); the trees are built in Python before a kernel runs.
    """

    def __init__(self, model: Any, params: np.ndarray, opts: BuildOptions, cache: Any = None):
        from core.cache import table_key

        self.model = model
        self.params = np.ascontiguousarray(params, dtype=np.float64)
        self.opts = opts
        self.iso = bool(model.isotropic)
        self.mirror = not self.iso and bool(model.mirror_symmetric)
        """Trees over one quadrant of ``phi_o``, mirrored to the others (``FRAME_MIRROR``)."""
        self.frame = FRAME_ISO if self.iso else (FRAME_MIRROR if self.mirror else FRAME_FULL)
        self.t_edges = np.ascontiguousarray(theta_edges(opts.theta_step, opts.z_min), dtype=np.float64)
        self.n_theta = len(self.t_edges) - 1
        self.n_phi = 1 if self.iso else (-(-opts.phi_bins // 4) if self.mirror else opts.phi_bins)
        self.n_bins = self.n_theta * self.n_phi
        """Base bins (before any split)."""
        it, ip = np.divmod(np.arange(self.n_bins), self.n_phi)
        step = 0.0 if self.iso else (HALF_PI if self.mirror else TWO_PI) / self.n_phi
        self.ranges = np.ascontiguousarray(
            np.stack([self.t_edges[it], self.t_edges[it + 1], ip * step, (ip + 1) * step], axis=1)
        )
        """``(theta_lo, theta_hi, phi_lo, phi_hi)`` per slot (radians)."""
        self.sub = np.full(self.n_bins, -1, dtype=np.int64)
        """Per slot: ``2 * first_child + dim`` if split, else -1 (arrays are replaced, never changed in place:
        a kernel running on an older ``tab`` keeps a consistent view)."""
        self.paths = [str(b) for b in range(self.n_bins)]
        """Per slot its cache name after ``bin``: the base bin, then ``-`` and a 0/1 per halving."""
        self.parent = [-1] * self.n_bins
        self.split_trees: dict[int, Bin] = {}
        """The tree each split slot had: a half whose own tree is worse over it serves it instead."""
        self.inherited = [0.0] * self.n_bins
        """Per slot made by a split: the acceptance its parent's tree had over it (``SPLIT_GAIN``)."""
        self.split_seconds = 0.0
        """Build time of the trees that were split (discarded)."""
        self.cache = cache
        self.key = table_key(
            [
                "adaptive-quadtree",
                TABLE_VERSION,
                source_hash(),  # every core source: a model's eval changes its trees too
                model.name,
                self.frame,
                self.params,
                opts.key_parts(),
            ]
        )
        self.bins: dict[int, Bin] = {}
        self.lock = threading.RLock()
        """Held while bins are added; readers of ``bins`` take :meth:`trees` (a snapshot)."""
        self.violations = 0
        self.trials = 0
        self.samples = 0
        self.cache_hits = 0
        self._kernels: Any = None
        self._pack()

    # -- bins
    def bin_range(self, b: int) -> tuple[float, float, float, float]:
        """``(theta_lo, theta_hi, phi_lo, phi_hi)`` of slot ``b`` (a base bin or a half)."""
        t_lo, t_hi, f_lo, f_hi = (float(v) for v in self.ranges[b])
        return t_lo, t_hi, f_lo, f_hi

    def depth(self, b: int) -> int:
        """How many times slot ``b``'s base bin was halved to make it."""
        return len(self.paths[b].partition("-")[2])

    @property
    def n_slots(self) -> int:
        return len(self.sub)

    @property
    def n_split(self) -> int:
        """Slots that were split (their halves hold the trees)."""
        return int(np.count_nonzero(self.sub >= 0))

    def _split(self, b: int, dim: int, acc: tuple[float, float]) -> None:
        """Halve slot ``b`` in ``dim``: two new slots (lower half first), new arrays (see ``sub``)."""
        lo, hi = halves(self.bin_range(b), dim)
        first = len(self.sub)
        sub = np.concatenate([self.sub, [-1, -1]])
        sub[b] = 2 * first + dim
        self.ranges = np.ascontiguousarray(np.vstack([self.ranges, lo, hi]))
        self.sub = sub
        sep = "" if "-" in self.paths[b] else "-"
        self.paths += [f"{self.paths[b]}{sep}0", f"{self.paths[b]}{sep}1"]
        self.inherited += [float(acc[0]), float(acc[1])]
        self.parent += [b, b]

    def _split_dim(self, b: int, tree: Bin, acc: float) -> tuple[int, tuple[float, float]]:
        """``(dim, (a0, a1))``: dim -1 to keep slot ``b``'s tree, else the dimension to halve the slot in and
        the tree's acceptance over each half. Split when the tree's acceptance is below ``1/n_max``
        somewhere in the slot, the slot may still be halved (``max_splits``), and the halving that made it
        paid (``SPLIT_GAIN``); ``acc`` is the tree's acceptance over the slot (:func:`min_acceptance`)."""
        rng = self.bin_range(b)
        if (
            acc >= (1.0 + SPLIT_MARGIN) / self.opts.n_max
            or self.depth(b) >= self.opts.max_splits
            or not halving_paid(acc, self.inherited[b], self.opts.n_max)
        ):
            return -1, (acc, acc)
        dim = split_dimension(self.model, self.params, tree, rng, self.iso)
        lo, hi = (min_acceptance(tree, rng, self.iso, part=h) for h in halves(rng, dim))
        return dim, (lo, hi)

    def mirror_signs(self, wo: np.ndarray) -> np.ndarray:
        """``(n, 2)`` signs that take each row's tree (built for the first quadrant of ``phi_o``) to the row's
        frame: ``x`` and ``y`` are multiplied by them (all ones unless the table is mirrored)."""
        wo = _rows(wo)
        if not self.mirror:
            return np.ones((len(wo), 2))
        return np.where(wo[:, :2] < 0.0, -1.0, 1.0)

    def _where(self) -> tuple:
        return self.t_edges, self.n_phi, self.frame, float(self.opts.z_min), self.sub, self.ranges

    def locate(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(slot, theta_o, phi_o)`` per row with the splits known so far (a slot not built yet may still
        be split: :meth:`tree_at` builds first); slot -1 where ``cos(theta_o) < z_min`` (the cosine
        fallback)."""
        return locate_rows(_rows(wo), *self.tab[:6])

    def tree_at(self, wo: np.ndarray) -> tuple[int, Bin | None]:
        """``(slot, tree)`` that samples the direction ``wo (3,)``, built or loaded (and split) first;
        ``(-1, None)`` where the cosine density is used."""
        wo1 = _rows(np.reshape(wo, (1, 3)))
        self.ensure_rows(wo1)
        b = int(self.locate(wo1)[0][0])
        if b < 0:
            return -1, None
        with self.lock:
            return b, self.bins.get(b)

    def ensure(self, bins: np.ndarray) -> None:
        """Build (or load) the trees of every listed slot that is not in memory yet (a slot whose tree must
        be split gets its halves' slots, not built until asked for)."""
        bins = np.asarray(bins, dtype=np.int64)
        self._ensure_slots(bins[(bins >= 0) & (bins < self.n_slots)])

    def ensure_rows(self, wo: np.ndarray) -> None:
        """Build (or load) the trees of the slots the rows of ``wo`` fall in, splitting as needed."""
        wo = _rows(wo)
        for _ in range(2 * self.opts.max_splits + 4):  # a level per run; another thread may split first
            tab = self.tab
            present = bins_present(wo, *tab[:6])
            unbuilt = present & (tab[6] < 0) & (tab[4] < 0)
            if not unbuilt.any():
                return
            self._ensure_slots(np.flatnonzero(unbuilt))
        raise BrdfStudioError("adaptive sampler: bins still missing after their splits")  # pragma: no cover

    def preload(self) -> int:
        """Load every tree of this table that the disk cache holds, and the splits it records (a render's
        preparation calls it, so that its timed passes do not pay ~1 ms per tree on first use); returns how
        many trees were loaded."""
        if self.cache is None:
            return 0
        stored = set(self.cache.names(self.key))
        before = len(self.bins)
        while True:
            slots = [
                b
                for b in range(self.n_slots)
                if self.sub[b] < 0 and b not in self.bins and f"bin{self.paths[b]}" in stored
            ]
            if not slots:
                return len(self.bins) - before
            self._ensure_slots(np.array(slots, dtype=np.int64))

    def _ensure_slots(self, slots: np.ndarray) -> None:
        if not len(slots):
            return
        with self.lock:  # one builder at a time; the app samples from several threads
            self._ensure_locked([int(b) for b in slots])

    def _load(self, b: int) -> tuple[Bin, int, tuple[float, float]] | None:
        """Slot ``b``'s stored ``(tree, dim, acceptance over the halves)`` (dim -1: the slot keeps the tree;
        else it was split and this was its tree), or None (missing, stale or corrupt)."""
        entry = self.cache.load(self.key, f"bin{self.paths[b]}") if self.cache is not None else None
        if entry is None:
            return None
        try:
            tree = Bin(entry)
            if SPLIT not in entry:
                return tree, -1, (1.0, 1.0)
            dim, acc = int(entry[SPLIT]), np.asarray(entry["acc"], dtype=np.float64)
            ok = dim in (0, 1) and (dim == 0 or not self.iso) and self.depth(b) < self.opts.max_splits
            ok = ok and acc.shape == (2,) and bool(np.all(np.isfinite(acc))) and tree.domain is None
            return (tree, dim, (float(acc[0]), float(acc[1]))) if ok else None
        except (KeyError, ValueError, TypeError):
            return None

    def _place(self, b: int, tree: Bin, dim: int, acc: tuple[float, float]) -> None:
        if dim < 0:
            self.bins[b] = tree
        else:
            self.split_trees[b] = tree
            self._split(b, dim, acc)

    def _ensure_locked(self, slots: list[int]) -> None:
        todo = [b for b in slots if self.sub[b] < 0 and b not in self.bins]
        if not todo:
            return
        to_build = []
        for b in todo:
            got = self._load(b)
            if got is None:
                to_build.append(b)
            else:
                self.cache_hits += 1
                self._place(b, *got)
        for b, (tree, dim, acc, wasted) in zip(to_build, self._build(to_build), strict=True):
            self.split_seconds += wasted
            if self.cache is not None:
                extra = {SPLIT: np.asarray(dim), "acc": np.asarray(acc)} if dim >= 0 else {}
                self.cache.save(self.key, f"bin{self.paths[b]}", {**tree.arrays(), **extra})
            self._place(b, tree, dim, acc)
        self._pack()

    def _build(self, bins: list[int]) -> Iterator[tuple[Bin, int, tuple[float, float], float]]:
        """Per slot of ``bins``, in order, as they are built: ``(tree, dim, acceptance over the halves,
        seconds spent on trees not used)`` (:meth:`_split_dim`; the caller stores each at once, so an
        interrupted batch keeps the trees already stored). A half whose own tree is worse over it than its
        parent's tree was gets the parent's tree (exact for any ``wo`` of the parent's bin) and is not split
        again: a split never lowers the acceptance anywhere. The first slot is built here (it compiles or
        loads the model's construction kernels), the others on ``BUILD_THREADS`` threads (the kernels
        release the GIL; a tree does not depend on which thread builds it). A slot asked for alone (the app's
        view of one direction) is built with ``BUILD_THREADS`` threads sharing its nodes instead."""

        def build(b: int, threads: int = 1) -> tuple[Bin, int, tuple[float, float], float]:
            tree = build_bin(self.model, self.params, self.iso, self.bin_range(b), self.opts, threads)
            own = min_acceptance(tree, self.bin_range(b), self.iso)
            p = self.parent[b]
            if p >= 0 and own < self.inherited[b]:
                kept = self.split_trees[p].serving(self.bin_range(p))
                return kept, -1, (1.0, 1.0), tree.build_seconds
            dim, acc = self._split_dim(b, tree, own)
            return tree, dim, acc, (tree.build_seconds if dim >= 0 else 0.0)

        if not bins:
            return
        yield build(bins[0], BUILD_THREADS if len(bins) == 1 else 1)  # alone: threads share its nodes
        if len(bins) == 1 or BUILD_THREADS <= 1:
            yield from (build(b) for b in bins[1:])
            return
        with ThreadPoolExecutor(max_workers=min(BUILD_THREADS, len(bins) - 1)) as pool:
            yield from pool.map(build, bins[1:])

    def _pack(self) -> None:
        """Concatenate the bins' arrays into the tuple the kernels read (``tab``)."""
        nb = self.n_slots
        self.node_off = np.full(nb, -1, dtype=np.int64)
        self.word_off = np.zeros(nb, dtype=np.int64)
        self.proj_of = np.zeros(nb, dtype=np.int64)
        self.unit_of = np.ones(nb)
        self.meta = np.zeros((nb, 7))
        self.c_meta = np.zeros((nb, 7))
        self.c_floor = np.zeros(nb)
        mass, bits, cum, vals, cvals = [], [], [], [], []
        n_nodes = n_words = n_vals = n_c = 0
        m_max = 1
        for b, t in sorted(self.bins.items()):
            self.node_off[b] = n_nodes
            self.word_off[b] = n_words
            self.proj_of[b] = t.projection
            self.unit_of[b] = t.unit
            t_lo, t_hi, f_lo, f_hi = t.domain if t.domain is not None else self.bin_range(b)
            self.meta[b] = (n_vals, t.norm_shape[0], t.norm_shape[1], t_lo, t_hi, f_lo, f_hi)
            self.c_meta[b] = (n_c, t.scale_shape[0], t.scale_shape[1], t_lo, t_hi, f_lo, f_hi)
            self.c_floor[b] = t.scale_floor
            m_max = max(m_max, int(t.norm_shape.max()), int(t.scale_shape.max()))
            mass.append(t.mass)
            bits.append(t.bits)
            cum.append(t.cum)
            vals.append(t.norm_coef)
            cvals.append(t.scale_coef)
            n_nodes += t.n_nodes
            n_words += len(t.bits)
            n_vals += len(t.norm_coef)
            n_c += len(t.scale_coef)
        self.mass = _cat(mass, np.uint32)
        self.bits = _cat(bits, np.uint64)
        self.cum = _cat(cum, np.uint32)
        self.coef = _cat(vals, np.float64)
        self.c_coef = _cat(cvals, np.float64)
        self.m_max = int(m_max)
        self.tab = (
            *self._where(),
            self.node_off, self.word_off, self.proj_of, self.unit_of,
            self.mass, self.bits, self.cum,
            self.meta, self.coef, self.c_meta, self.c_coef, self.c_floor,
            self.m_max,
        )  # fmt: skip

    @property
    def kernels(self) -> Any:
        """The fused entry points for this model (compiled on first use, cached on disk)."""
        if self._kernels is None:
            self._kernels = model_kernels(self.model.eval)
        return self._kernels

    # -- densities
    def normalizer(self, bins: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """``I(wo)`` per row from the bins' Chebyshev tables (0 where ``bins < 0``)."""
        return values_rows(self.meta, self.coef, *_bin_rows(bins, theta, phi), self.m_max)

    def scales(self, bins: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """The per-``wo`` scale ``c(wo) > 0`` of each row's bin: the leaf bounds hold for ``g(wo, X) / c(wo)``
        over the whole bin, and sampling accepts with probability ``g / (c M_L)``. Any positive ``c`` keeps
        the sampler exact (for one ``wo`` it is a constant); ``c`` is a smooth estimate of ``I(wo)``, so the
        bounds need not follow the overall change of ``f`` across the bin."""
        bins, theta, phi = _bin_rows(bins, theta, phi)
        v = values_rows(self.c_meta, self.c_coef, bins, theta, phi, self.m_max)
        return np.where(bins >= 0, np.maximum(v, self.c_floor[np.maximum(bins, 0)]), 1.0)

    def _prepare(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bins and normalizers of the rows, with the fallback (-1) where ``I(wo)`` is not positive."""
        bins, norm, _ = self._prepare_scaled(wo)
        return bins, norm

    def _prepare_scaled(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        wo = _rows(wo)
        self.ensure_rows(wo)
        return setup_rows(wo, self.tab)

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        wo, wi = _rows(wo), _rows(wi)
        out = np.empty(len(wo))
        self._run(lambda tab, missing: self.kernels.pdf_rows(wo, wi, self.params, tab, out, missing))
        return out

    def _run(self, kernel: Any) -> Any:
        """Run a fused kernel ``kernel(tab, missing)``; if it met rows whose slots are not built yet (it
        skips them and flags the slots), build those and run it again, until none is missing (a built slot
        may have been split: its halves are met on the next run). The slots are located inside the kernel:
        no extra pass."""
        for _ in range(2 * self.opts.max_splits + 4):  # a level per run; another thread may split first
            tab = self.tab  # one snapshot: ``missing`` has its slots
            missing = np.zeros(len(tab[4]), dtype=bool)
            result = kernel(tab, missing)
            if not missing.any():
                return result
            self._ensure_slots(np.flatnonzero(missing))
        raise BrdfStudioError("adaptive sampler: tables missing after the build")  # pragma: no cover

    # -- sampling
    def sample_each(
        self, wo: np.ndarray, seed: int, threads: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One sample per row: ``(wi (n,3), pdf (n,), trials (n,))``; sample ``i`` uses stream ``(seed, i)``.
        ``threads``: run large batches on numba's threads (the same samples)."""
        wo = _rows(wo)
        n = len(wo)
        wi = np.empty((n, 3))
        pdf = np.empty(n)
        trials = np.empty(n, dtype=np.int64)
        run = self.kernels.sample_rows_parallel if threads and n >= 2 * CHUNK else self.kernels.sample_rows
        viol, _ = self._run(
            lambda tab, missing: run(wo, self.params, np.uint64(seed), tab, wi, pdf, trials, missing)
        )
        self.violations += int(viol)
        self.trials += int(trials.sum())
        self.samples += n
        return wi, pdf, trials

    def sample_batch(self, wo: np.ndarray, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, int]:
        """``n`` samples for one direction ``wo (3,)`` by the batch variant; ``(wi, pdf, trials)``."""
        wo1 = _rows(np.reshape(wo, (1, 3)))
        bins, _, _ = self._prepare_scaled(wo1)
        if bins[0] < 0:
            wi, pdf, trials = self.sample_each(np.repeat(wo1, n, axis=0), seed)
            return wi, pdf, int(trials.sum())
        wi = np.empty((n, 3))
        pdf = np.empty(n)
        filled, total, viol = self.kernels.sample_batch(
            wo1[0], self.params, np.uint64(seed), int(n), self.tab, wi, pdf
        )
        self.violations += int(viol)
        if filled < n:  # never seen: a round budget of 1e5 exhausted
            raise BrdfStudioError(f"adaptive sampler: only {filled} of {n} samples accepted")
        order = np.random.default_rng([int(seed), 0x5EED]).permutation(n)
        self.trials += int(total)
        self.samples += n
        return wi[order], pdf[order], int(total)

    # -- facts
    def acceptance(self, wo: np.ndarray) -> np.ndarray:
        """Exact per-trial acceptance ``I(wo) / (c V)`` per row (1 for the cosine fallback)."""
        wo = _rows(wo)
        self.ensure_rows(wo)
        tab = self.tab  # offsets and masses from the same packing
        bins, norm, scale = setup_rows(wo, tab)
        node_off, unit_of, all_mass = tab[6], tab[9], tab[10]
        safe = np.maximum(bins, 0)
        off = np.maximum(node_off[safe], 0)
        mass = all_mass[off].astype(np.float64) * unit_of[safe] if len(all_mass) else np.ones(len(bins))
        return np.where(bins >= 0, norm / (scale * np.where(bins >= 0, mass, 1.0)), 1.0)

    def trees(self) -> list[Bin]:
        """A snapshot of the built trees (safe while another thread adds bins)."""
        with self.lock:
            return list(self.bins.values())

    def memory_bytes(self) -> int:
        return int(sum(t.nbytes for t in self.trees()))

    def build_seconds(self) -> float:
        """Build time of every tree made, the split ones included."""
        return float(sum(t.build_seconds for t in self.trees())) + self.split_seconds


def _rows(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.atleast_2d(a), dtype=np.float64)


def _bin_rows(bins, theta, phi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (
        np.ascontiguousarray(bins, dtype=np.int64),
        np.ascontiguousarray(theta, dtype=np.float64),
        np.ascontiguousarray(phi, dtype=np.float64),
    )


def _cat(parts: list[np.ndarray], dtype) -> np.ndarray:
    return np.ascontiguousarray(np.concatenate(parts) if parts else np.zeros(0), dtype=dtype)
