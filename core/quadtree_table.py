"""The adaptive sampler's tables: the trees of one BRDF (:class:`QuadtreeTable`), exact rejection sampling
and the pdf. The construction of one tree and the disk projections live in :mod:`core.quadtree`; the
sampling proof is in its docstring and in ``docs/adaptive.md``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from core.quadtree import (
    INV_PI,
    PROJECTIONS,
    TABLE_VERSION,
    TWO_PI,
    BuildOptions,
    build_tree,
    disk_to_direction,
    f_luminance,
    normalizer_values,
    target,
    theta_edges,
)
from core.rng import next_u01, stream

# ------------------------------------------------------------------------------------ trial proposals


@njit(nogil=True, cache=True)
def propose(states, rows, roots, child, vmass, leaf):
    """One trial for each listed row: a leaf chosen by mass from the root (fresh uniform per level), a point
    uniform in its clipped box, and the acceptance uniform. ``states`` (per row) advance in place.
    ``leaf[l] = (M, x0, y0, x1, y1)``; ``child[k] < 0`` marks leaf ``-child[k] - 1``."""
    n = rows.shape[0]
    X = np.empty(n)
    Y = np.empty(n)
    bound = np.empty(n)
    u3 = np.empty(n)
    for t in range(n):
        i = rows[t]
        state = states[i]
        k = roots[i]
        while child[k] >= 0:
            c = child[k]
            v0 = vmass[c]
            v1 = vmass[c + 1]
            v2 = vmass[c + 2]
            v3 = vmass[c + 3]
            state, u = next_u01(state)
            s = u * (v0 + v1 + v2 + v3)
            if s < v0:
                k = c
            elif s < v0 + v1:
                k = c + 1
            elif s < v0 + v1 + v2:
                k = c + 2
            else:
                k = c + 3
            if vmass[k] <= 0.0:  # rounding at the top end: the last child with mass
                for j in range(3, -1, -1):
                    if vmass[c + j] > 0.0:
                        k = c + j
                        break
        li = -child[k] - 1
        state, a = next_u01(state)
        state, b = next_u01(state)
        state, c3 = next_u01(state)
        X[t] = leaf[li, 1] + (leaf[li, 3] - leaf[li, 1]) * a
        Y[t] = leaf[li, 2] + (leaf[li, 4] - leaf[li, 2]) * b
        bound[t] = leaf[li, 0]
        u3[t] = c3
        states[i] = state
    return X, Y, bound, u3


@njit(nogil=True, cache=True)
def seed_states(seed, n):
    out = np.empty(n, dtype=np.uint64)
    for i in range(n):
        out[i] = stream(seed, i)
    return out


@njit(nogil=True, cache=True)
def cosine_rows(states, rows):
    """Cosine-weighted hemisphere directions for the listed rows (the fallback where ``I(wo) = 0``)."""
    n = rows.shape[0]
    out = np.empty((n, 3))
    for t in range(n):
        i = rows[t]
        state = states[i]
        state, u1 = next_u01(state)
        state, u2 = next_u01(state)
        states[i] = state
        r = math.sqrt(u1)
        ph = 2.0 * math.pi * u2
        out[t, 0] = r * math.cos(ph)
        out[t, 1] = r * math.sin(ph)
        out[t, 2] = math.sqrt(max(0.0, 1.0 - u1))
    return out


@njit(nogil=True, cache=True)
def split_batch(seed, rnd, root, count, child, vmass, leaf):
    """The seed's batch variant: ``count`` trials split from the root among children by systematic
    (stochastic) rounding of ``count V_c / V`` -- one uniform ``u`` per node and
    ``n_c = floor(k C_c + u) - floor(k C_{c-1} + u)`` with ``C`` the cumulative mass fractions, so that
    ``E[n_c] = k V_c / V`` exactly and the counts sum to ``k`` -- then uniform points in the leaves.
    Returns ``X, Y, bound, u3`` for every trial."""
    X = np.empty(count)
    Y = np.empty(count)
    bound = np.empty(count)
    u3 = np.empty(count)
    state = stream(seed, rnd)
    stack_node = np.empty(512, dtype=np.int64)
    stack_cnt = np.empty(512, dtype=np.int64)
    stack_node[0] = root
    stack_cnt[0] = count
    sp = 1
    filled = 0
    while sp > 0:
        sp -= 1
        k = stack_node[sp]
        cnt = stack_cnt[sp]
        ch = child[k]
        if ch >= 0:
            tot = vmass[ch] + vmass[ch + 1] + vmass[ch + 2] + vmass[ch + 3]
            state, u = next_u01(state)
            cum = 0.0
            prev = 0.0
            last = 3
            while vmass[ch + last] <= 0.0:
                last -= 1
            assigned = 0
            for j in range(4):
                if vmass[ch + j] <= 0.0:
                    continue
                cum += vmass[ch + j]
                if j == last:
                    nj = cnt - assigned
                else:
                    nxt = math.floor(cnt * (cum / tot) + u)
                    nj = int(nxt - prev)
                    prev = nxt
                if nj > 0:
                    stack_node[sp] = ch + j
                    stack_cnt[sp] = nj
                    sp += 1
                    assigned += nj
        else:
            li = -ch - 1
            for _ in range(cnt):
                state, a = next_u01(state)
                state, b = next_u01(state)
                state, c3 = next_u01(state)
                X[filled] = leaf[li, 1] + (leaf[li, 3] - leaf[li, 1]) * a
                Y[filled] = leaf[li, 2] + (leaf[li, 4] - leaf[li, 2]) * b
                bound[filled] = leaf[li, 0]
                u3[filled] = c3
                filled += 1
    return X[:filled], Y[:filled], bound[:filled], u3[:filled]


class Bin:
    """One incident-angle bin: its tree (indices local to the tree) and its normalizer table."""

    def __init__(self, arrays: dict[str, np.ndarray]):
        self.child = np.ascontiguousarray(arrays["child"], dtype=np.int32)
        self.vmass = np.ascontiguousarray(arrays["vmass"], dtype=np.float64)
        self.leaf = np.ascontiguousarray(arrays["leaf"], dtype=np.float64)
        self.norm = np.ascontiguousarray(arrays["norm"], dtype=np.float64)
        self.shape = np.asarray(arrays["shape"], dtype=np.int64)  # (m_theta, m_phi)
        self.build_seconds = float(arrays["build_seconds"])
        self.interp_error = float(arrays["interp_error"])
        self.projection = int(arrays["projection"])
        """Index into ``PROJECTIONS``."""
        self.scale = np.ascontiguousarray(arrays["scale"], dtype=np.float64)
        self.scale_shape = np.asarray(arrays["scale_shape"], dtype=np.int64)
        self.scale_floor = float(arrays["scale_floor"])

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "child": self.child,
            "vmass": self.vmass,
            "leaf": self.leaf,
            "norm": self.norm,
            "shape": self.shape,
            "build_seconds": np.asarray(self.build_seconds),
            "interp_error": np.asarray(self.interp_error),
            "projection": np.asarray(self.projection),
            "scale": self.scale,
            "scale_shape": self.scale_shape,
            "scale_floor": np.asarray(self.scale_floor),
        }

    @property
    def nbytes(self) -> int:
        """Memory of the tree and its normalizer table."""
        return int(
            self.child.nbytes + self.vmass.nbytes + self.leaf.nbytes + self.norm.nbytes + self.scale.nbytes
        )

    @property
    def total_mass(self) -> float:
        return float(self.vmass[0])

    @property
    def n_leaves(self) -> int:
        return int(self.leaf.shape[0])


# ------------------------------------------------------------------------------------------- the table


def build_bin(model: Any, params: np.ndarray, iso: bool, rng: tuple, opts: BuildOptions) -> Bin:
    """Build one bin's tree and normalizer; ``rng = (theta_lo, theta_hi, phi_lo, phi_hi)`` in radians."""
    return Bin(build_tree(model, params, iso, rng, opts))


def _source_hash() -> str:
    """Hash of the construction and table code (part of the on-disk cache key)."""
    import hashlib
    from pathlib import Path

    here = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for name in ("quadtree.py", "quadtree_table.py"):
        h.update((here / name).read_bytes())
    return h.hexdigest()[:16]


class QuadtreeTable:
    """The lazily built trees of one BRDF: one per incident-angle bin, built on first use, kept in memory and
    (with a :class:`core.cache.TableCache`) on disk.

    Isotropic BRDFs have bins over ``theta_o`` only and work in the frame rotated so that ``phi_o = 0``;
    anisotropic ones have bins over ``(theta_o, phi_o)``. ``sample`` and ``pdf`` use the same bin for a given
    ``wo``. Where ``cos(theta_o) < z_min`` or ``I(wo) = 0`` (``f`` vanishes) both use the cosine density.
    """

    def __init__(self, model: Any, params: np.ndarray, opts: BuildOptions, cache: Any = None):
        from core.cache import table_key

        self.model = model
        self.params = np.ascontiguousarray(params, dtype=np.float64)
        self.opts = opts
        self.iso = bool(model.isotropic)
        self.t_edges = theta_edges(opts.theta_step, opts.z_min)
        self.n_theta = len(self.t_edges) - 1
        self.n_phi = 1 if self.iso else opts.phi_bins
        self.n_bins = self.n_theta * self.n_phi
        self.cache = cache
        self.key = table_key(
            ["adaptive-quadtree", TABLE_VERSION, _source_hash(), model.name, self.params, opts.key_parts()]
        )
        self.bins: dict[int, Bin] = {}
        self.meta = np.zeros((self.n_bins, 7))
        self.roots = np.full(self.n_bins, -1, dtype=np.int64)
        self.bin_projection = np.zeros(self.n_bins, dtype=np.int64)
        self.child = np.zeros(0, dtype=np.int32)
        self.vmass = np.zeros(0)
        self.leaf = np.zeros((0, 5))
        self.vals = np.zeros(0)
        self.c_meta = np.zeros((self.n_bins, 7))
        self.c_vals = np.zeros(0)
        self.c_floor = np.zeros(self.n_bins)
        self.violations = 0
        self.trials = 0
        self.samples = 0
        self.cache_hits = 0

    # -- bins
    def bin_range(self, b: int) -> tuple[float, float, float, float]:
        it, ip = divmod(b, self.n_phi)
        if self.iso:
            return float(self.t_edges[it]), float(self.t_edges[it + 1]), 0.0, 0.0
        step = TWO_PI / self.n_phi
        return float(self.t_edges[it]), float(self.t_edges[it + 1]), ip * step, (ip + 1) * step

    def locate(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(bin, theta_o, phi_o)`` per row; bin -1 where ``cos(theta_o) < z_min`` (the cosine fallback)."""
        s = np.sqrt(wo[:, 0] ** 2 + wo[:, 1] ** 2)
        theta = np.arctan2(s, wo[:, 2])
        phi = np.mod(np.arctan2(wo[:, 1], wo[:, 0]), TWO_PI)
        it = np.clip(np.searchsorted(self.t_edges, theta, side="right") - 1, 0, self.n_theta - 1)
        if self.iso:
            b = it
        else:
            ip = np.clip((phi * (self.n_phi / TWO_PI)).astype(np.int64), 0, self.n_phi - 1)
            b = it * self.n_phi + ip
        ok = (wo[:, 2] >= self.opts.z_min) & np.isfinite(theta)
        return np.where(ok, b, -1).astype(np.int64), theta, phi

    def ensure(self, bins: np.ndarray) -> None:
        """Build (or load) the trees of every listed bin that is not in memory yet."""
        missing = [int(b) for b in np.unique(bins) if b >= 0 and int(b) not in self.bins]
        if not missing:
            return
        for b in missing:
            entry = self.cache.load(self.key, f"bin{b}") if self.cache is not None else None
            table = None
            if entry is not None:
                try:
                    table = Bin(entry)
                    self.cache_hits += 1
                except (KeyError, ValueError, TypeError):
                    table = None
            if table is None:
                table = build_bin(self.model, self.params, self.iso, self.bin_range(b), self.opts)
                if self.cache is not None:
                    self.cache.save(self.key, f"bin{b}", table.arrays())
            self.bins[b] = table
        self._pack()

    def _pack(self) -> None:
        child, vmass, leaf, vals, cvals = [], [], [], [], []
        n_nodes = n_leaves = n_vals = n_c = 0
        for b, t in sorted(self.bins.items()):
            c = t.child.astype(np.int64)
            c = np.where(c >= 0, c + n_nodes, c - n_leaves)
            child.append(c)
            vmass.append(t.vmass)
            leaf.append(t.leaf)
            vals.append(t.norm)
            self.roots[b] = n_nodes
            self.bin_projection[b] = t.projection
            t_lo, t_hi, f_lo, f_hi = self.bin_range(b)
            self.meta[b] = (n_vals, t.shape[0], t.shape[1], t_lo, t_hi, f_lo, f_hi)
            self.c_meta[b] = (n_c, t.scale_shape[0], t.scale_shape[1], t_lo, t_hi, f_lo, f_hi)
            self.c_floor[b] = t.scale_floor
            cvals.append(t.scale)
            n_c += len(t.scale)
            n_nodes += len(t.child)
            n_leaves += t.n_leaves
            n_vals += len(t.norm)
        self.child = np.ascontiguousarray(np.concatenate(child), dtype=np.int64)
        self.vmass = np.ascontiguousarray(np.concatenate(vmass))
        self.leaf = np.ascontiguousarray(np.concatenate(leaf))
        self.vals = np.ascontiguousarray(np.concatenate(vals))
        self.c_vals = np.ascontiguousarray(np.concatenate(cvals))

    # -- densities
    def normalizer(self, bins: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        return normalizer_values(self.meta, self.vals, bins, theta, phi)

    def _prepare(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bins and normalizers of the rows, with the fallback (-1) where ``I(wo)`` is not positive."""
        bins, norm, _ = self._prepare_scaled(wo)
        return bins, norm

    def _prepare_scaled(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        bins, theta, phi = self.locate(wo)
        self.ensure(bins)
        norm = self.normalizer(bins, theta, phi)
        bins = np.where(norm > 0.0, bins, -1)
        return bins, norm, self.scales(bins, theta, phi)

    def scales(self, bins: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """The per-``wo`` scale ``c(wo) > 0`` of each row's bin: the leaf bounds hold for ``g(wo, X) / c(wo)``
        over the whole bin, and sampling accepts with probability ``g / (c M_L)``. Any positive ``c`` keeps
        the sampler exact (for one ``wo`` it is a constant); ``c`` is a smooth estimate of ``I(wo)``, so the
        bounds need not follow the overall change of ``f`` across the bin."""
        v = normalizer_values(self.c_meta, self.c_vals, bins, theta, phi)
        return np.where(bins >= 0, np.maximum(v, self.c_floor[np.maximum(bins, 0)]), 1.0)

    def _pdf(self, wo: np.ndarray, wi: np.ndarray, bins: np.ndarray, norm: np.ndarray) -> np.ndarray:
        up = wi[:, 2] > 0.0
        f = f_luminance(self.model, self.params, wo, wi)
        safe = np.where(bins >= 0, norm, 1.0)
        adaptive = np.where(up, f * wi[:, 2] / safe, 0.0)
        cosine = np.where(up, wi[:, 2] * INV_PI, 0.0)
        return np.where(bins >= 0, adaptive, cosine)

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        bins, norm = self._prepare(wo)
        return self._pdf(wo, wi, bins, norm)

    def _frames(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Canonical ``wo`` (rotated to ``phi_o = 0`` when isotropic) and the rotation's cos, sin."""
        if not self.iso:
            n = len(wo)
            return wo, np.ones(n), np.zeros(n)
        s = np.sqrt(wo[:, 0] ** 2 + wo[:, 1] ** 2)
        safe = np.where(s > 0.0, s, 1.0)
        c = np.where(s > 0.0, wo[:, 0] / safe, 1.0)
        sn = np.where(s > 0.0, wo[:, 1] / safe, 0.0)
        return np.stack([s, np.zeros_like(s), wo[:, 2]], axis=1), c, sn

    def _to_world(self, X, Y, proj, c, sn) -> np.ndarray:
        wi = np.empty((len(X), 3))
        for k, name in enumerate(PROJECTIONS):
            sel = proj == k
            if np.any(sel):
                wi[sel] = disk_to_direction(X[sel], Y[sel], name)[0]
        x, y = wi[:, 0].copy(), wi[:, 1].copy()
        wi[:, 0] = c * x - sn * y
        wi[:, 1] = sn * x + c * y
        return wi

    def _g(self, wo_c, X, Y, proj) -> np.ndarray:
        out = np.empty(len(X))
        for k, name in enumerate(PROJECTIONS):
            sel = proj == k
            if np.any(sel):
                out[sel] = target(self.model, self.params, wo_c[sel], X[sel], Y[sel], name)
        return out

    # -- sampling
    def sample_each(self, wo: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One sample per row: ``(wi (n,3), pdf (n,), trials (n,))``; sample ``i`` uses stream ``(seed, i)``."""
        n = len(wo)
        bins, norm, scale = self._prepare_scaled(wo)
        states = seed_states(np.uint64(seed), n)
        wi = np.empty((n, 3))
        trials = np.zeros(n, dtype=np.int64)
        fallback = np.flatnonzero(bins < 0)
        if len(fallback):
            wi[fallback] = cosine_rows(states, fallback)
            trials[fallback] = 1
        wo_c, c, sn = self._frames(wo)
        roots = np.where(bins >= 0, self.roots[np.maximum(bins, 0)], 0)
        proj_rows = self.bin_projection[np.maximum(bins, 0)]
        pending = np.flatnonzero(bins >= 0)
        rounds = 0
        while len(pending):
            X, Y, bound, u3 = propose(states, pending, roots, self.child, self.vmass, self.leaf)
            g = self._g(wo_c[pending], X, Y, proj_rows[pending])
            bound = bound * scale[pending]
            self.violations += int(np.count_nonzero(g > bound))
            trials[pending] += 1
            acc = u3 * bound < g
            rounds += 1
            if rounds >= 100_000:  # never seen; counted as a violation rather than looping forever
                self.violations += int(np.count_nonzero(~acc))
                acc[:] = True
            rows = pending[acc]
            wi[rows] = self._to_world(X[acc], Y[acc], proj_rows[rows], c[rows], sn[rows])
            pending = pending[~acc]
        self.trials += int(trials.sum())
        self.samples += n
        return wi, self._pdf(wo, wi, bins, norm), trials

    def sample_batch(self, wo: np.ndarray, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, int]:
        """``n`` samples for one direction ``wo (3,)`` by the batch variant; ``(wi, pdf, trials)``."""
        wo1 = wo.reshape(1, 3)
        bins, norm, scale = self._prepare_scaled(wo1)
        b = int(bins[0])
        if b < 0:
            wi, pdf, trials = self.sample_each(np.repeat(wo1, n, axis=0), seed)
            return wi, pdf, int(trials.sum())
        wo_c, c, sn = self._frames(wo1)
        proj = self.bin_projection[b]
        root = int(self.roots[b])
        out = []
        remaining = n
        total = 0
        rnd = 0
        while remaining > 0:
            X, Y, bound, u3 = split_batch(
                np.uint64(seed), rnd, root, remaining, self.child, self.vmass, self.leaf
            )
            rnd += 1
            g = self._g(np.repeat(wo_c, len(X), axis=0), X, Y, np.full(len(X), proj))
            bound = bound * scale[0]
            self.violations += int(np.count_nonzero(g > bound))
            total += len(X)
            acc = u3 * bound < g
            out.append(self._to_world(X[acc], Y[acc], np.full(int(acc.sum()), proj), c[0], sn[0]))
            remaining -= int(acc.sum())
        wi = np.concatenate(out)
        wi = wi[np.random.default_rng([int(seed), 0x5EED]).permutation(n)]
        self.trials += total
        self.samples += n
        wos = np.repeat(wo1, n, axis=0)
        return wi, self._pdf(wos, wi, np.full(n, b), np.full(n, norm[0])), total

    # -- facts
    def acceptance(self, wo: np.ndarray) -> np.ndarray:
        """Exact per-trial acceptance ``I(wo) / V`` per row (1 for the cosine fallback)."""
        bins, norm, scale = self._prepare_scaled(wo)
        mass = np.where(bins >= 0, self.vmass[self.roots[np.maximum(bins, 0)]], 1.0)
        return np.where(bins >= 0, norm / (scale * mass), 1.0)

    def memory_bytes(self) -> int:
        return int(sum(t.nbytes for t in self.bins.values()))

    def build_seconds(self) -> float:
        return float(sum(t.build_seconds for t in self.bins.values()))
