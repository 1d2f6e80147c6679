"""The adaptive sampler's tables: the trees of one BRDF (:class:`QuadtreeTable`) in compact form, and the
entry points of exact rejection sampling and the pdf (fused numba kernels, :mod:`core.quadtree_kernels`).
The construction of one tree and the disk projections live in :mod:`core.quadtree`; the sampling proof is in
its docstring and in ``docs/adaptive.md``.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit

from core.errors import BrdfStudioError
from core.quadtree import TABLE_VERSION, TWO_PI, BuildOptions, build_tree, theta_edges
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
        if self.norm_coef.size != int(np.prod(self.norm_shape)) or self.scale_coef.size != int(
            np.prod(self.scale_shape)
        ):
            raise ValueError("inconsistent normalizer tables")
        if len(self.bits) != (len(self.mass) + 63) // 64 or len(self.cum) != len(self.bits):
            raise ValueError("inconsistent tree arrays")

    def arrays(self) -> dict[str, np.ndarray]:
        return {
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


def build_bin(model: Any, params: np.ndarray, iso: bool, rng: tuple, opts: BuildOptions) -> Bin:
    """Build one bin's tree and normalizer; ``rng = (theta_lo, theta_hi, phi_lo, phi_hi)`` in radians."""
    return Bin(build_tree(model, params, iso, rng, opts))


@lru_cache(maxsize=1)
def _source_hash() -> str:
    """Hash of the construction and table code (part of the on-disk cache key; read once per process, not
    for every table: the app makes a table per edited material)."""
    import hashlib
    from pathlib import Path

    here = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for name in ("quadtree.py", "quadtree_build_kernels.py", "quadtree_table.py", "quadtree_kernels.py"):
        h.update((here / name).read_bytes())
    return h.hexdigest()[:16]


class QuadtreeTable:
    """The lazily built trees of one BRDF: one per incident-angle bin, built on first use, kept in memory and
    (with a :class:`core.cache.TableCache`) on disk.

    Isotropic BRDFs have bins over ``theta_o`` only and work in the frame rotated so that ``phi_o = 0``;
    anisotropic ones have bins over ``(theta_o, phi_o)``: over the quadrant ``0 <= phi_o <= 90`` degrees
    (``phi_bins / 4`` bins, mirrored to the row's quadrant) when the model is mirror-symmetric, over the whole
    circle otherwise. ``sample`` and ``pdf`` use the same bin for a given ``wo``. Where
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
        self.cache = cache
        self.key = table_key(
            [
                "adaptive-quadtree",
                TABLE_VERSION,
                _source_hash(),
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
        it, ip = divmod(b, self.n_phi)
        if self.iso:
            return float(self.t_edges[it]), float(self.t_edges[it + 1]), 0.0, 0.0
        step = (HALF_PI if self.mirror else TWO_PI) / self.n_phi
        return float(self.t_edges[it]), float(self.t_edges[it + 1]), ip * step, (ip + 1) * step

    def mirror_signs(self, wo: np.ndarray) -> np.ndarray:
        """``(n, 2)`` signs that take each row's tree (built for the first quadrant of ``phi_o``) to the row's
        frame: ``x`` and ``y`` are multiplied by them (all ones unless the table is mirrored)."""
        wo = _rows(wo)
        if not self.mirror:
            return np.ones((len(wo), 2))
        return np.where(wo[:, :2] < 0.0, -1.0, 1.0)

    def _where(self) -> tuple:
        return self.t_edges, self.n_phi, self.frame, float(self.opts.z_min)

    def locate(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(bin, theta_o, phi_o)`` per row; bin -1 where ``cos(theta_o) < z_min`` (the cosine fallback)."""
        return locate_rows(_rows(wo), *self._where())

    def ensure(self, bins: np.ndarray) -> None:
        """Build (or load) the trees of every listed bin that is not in memory yet."""
        present = np.zeros(self.n_bins, dtype=bool)
        bins = np.asarray(bins, dtype=np.int64)
        present[bins[bins >= 0]] = True
        self._ensure_present(present)

    def ensure_rows(self, wo: np.ndarray) -> None:
        """Build (or load) the trees of the bins the rows of ``wo`` fall in."""
        self._ensure_present(bins_present(wo, *self._where(), self.n_bins))

    def preload(self) -> int:
        """Load every tree of this table that the disk cache holds (a render's preparation calls it, so that
        its timed passes do not pay ~1 ms per tree on first use); returns how many were loaded."""
        if self.cache is None:
            return 0
        present = np.zeros(self.n_bins, dtype=bool)
        for name in self.cache.names(self.key):
            if name.startswith("bin") and name[3:].isdigit() and int(name[3:]) < self.n_bins:
                present[int(name[3:])] = True
        before = len(self.bins)
        self._ensure_present(present)
        return len(self.bins) - before

    def _ensure_present(self, present: np.ndarray) -> None:
        if not np.any(present & (self.node_off < 0)):
            return
        with self.lock:  # one builder at a time; the app samples from several threads
            self._ensure_locked(present)

    def _ensure_locked(self, present: np.ndarray) -> None:
        missing = np.flatnonzero(present & (self.node_off < 0))
        if not len(missing):
            return
        to_build = []
        for b in (int(v) for v in missing):
            entry = self.cache.load(self.key, f"bin{b}") if self.cache is not None else None
            table = None
            if entry is not None:
                try:
                    table = Bin(entry)
                    self.cache_hits += 1
                except (KeyError, ValueError, TypeError):
                    table = None
            if table is None:
                to_build.append(b)
            else:
                self.bins[b] = table
        for b, table in zip(to_build, self._build(to_build), strict=True):
            if self.cache is not None:
                self.cache.save(self.key, f"bin{b}", table.arrays())
            self.bins[b] = table
        self._pack()

    def _build(self, bins: list[int]) -> Iterator[Bin]:
        """The trees of ``bins`` in order, as they are built (the caller stores each at once, so an
        interrupted batch keeps the trees already stored): the first here (it compiles or loads the model's
        construction kernels), the others on ``BUILD_THREADS`` threads (the kernels release the GIL; a tree
        does not depend on which thread builds it)."""

        def build(b: int) -> Bin:
            return build_bin(self.model, self.params, self.iso, self.bin_range(b), self.opts)

        if not bins:
            return
        yield build(bins[0])
        if len(bins) == 1 or BUILD_THREADS <= 1:
            yield from (build(b) for b in bins[1:])
            return
        with ThreadPoolExecutor(max_workers=min(BUILD_THREADS, len(bins) - 1)) as pool:
            yield from pool.map(build, bins[1:])

    def _pack(self) -> None:
        """Concatenate the bins' arrays into the tuple the kernels read (``tab``)."""
        nb = self.n_bins
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
            t_lo, t_hi, f_lo, f_hi = self.bin_range(b)
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
        self._run(lambda missing: self.kernels.pdf_rows(wo, wi, self.params, self.tab, out, missing))
        return out

    def _run(self, kernel: Any) -> Any:
        """Run a fused kernel; if it met rows whose bins are not built yet (it skips them and flags the
        bins), build those bins and run it again (the bins are located inside the kernel: no extra pass)."""
        missing = np.zeros(self.n_bins, dtype=bool)
        result = kernel(missing)
        if missing.any():
            self._ensure_present(missing)
            missing[:] = False
            result = kernel(missing)
            if missing.any():  # pragma: no cover - the bins were just built
                raise BrdfStudioError("adaptive sampler: tables missing after the build")
        return result

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
            lambda missing: run(wo, self.params, np.uint64(seed), self.tab, wi, pdf, trials, missing)
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
        bins, norm, scale = self._prepare_scaled(wo)
        safe = np.maximum(bins, 0)
        off = np.maximum(self.node_off[safe], 0)
        mass = (
            self.mass[off].astype(np.float64) * self.unit_of[safe] if len(self.mass) else np.ones(len(bins))
        )
        return np.where(bins >= 0, norm / (scale * np.where(bins >= 0, mass, 1.0)), 1.0)

    def trees(self) -> list[Bin]:
        """A snapshot of the built trees (safe while another thread adds bins)."""
        with self.lock:
            return list(self.bins.values())

    def memory_bytes(self) -> int:
        return int(sum(t.nbytes for t in self.trees()))

    def build_seconds(self) -> float:
        return float(sum(t.build_seconds for t in self.trees()))


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
