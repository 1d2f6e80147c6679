"""``adaptive``: the seed's adaptive quadtree sampler (Montes 2008) behind the common sampler interface.

``make_sampler("adaptive", brdf, n_max=2.0)`` samples ``wi`` with density exactly proportional to
``f_r(wo, wi) cos(theta_i)`` (luminance), so ``f cos / pdf`` is the same for every sample. Trees are built
lazily per incident-angle bin (see :mod:`core.quadtree`), kept in memory, shared by every sampler of the same
BRDF and options, and stored on disk (:mod:`core.cache`). ``sample(wo, n, seed)`` uses the seed's batch
variant; ``sample_each(wo (n,3), seed)`` draws one sample per row (sample ``i`` from its own random stream).
Sampling and the pdf run in fused numba kernels specialized to the model (:mod:`core.quadtree_kernels`);
the trees are stored compactly (:mod:`core.quadtree_table`).
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from core.cache import TableCache
from core.errors import ParameterError
from core.model import BRDF
from core.quadtree import BuildOptions
from core.quadtree_table import QuadtreeTable
from core.sampling.base import SampleBatch, Sampler, check_direction, register_sampler

_TABLES: dict[str, QuadtreeTable] = {}
"""In-memory tables by key (model, parameters, options, code version): one per material per process."""


def _check_n_max(n_max: Any) -> float:
    try:
        value = float(n_max)
    except (TypeError, ValueError):
        raise ParameterError(f"n_max must be a number greater than 1, got {n_max!r}") from None
    if not math.isfinite(value) or value <= 1.0:
        raise ParameterError(
            f"n_max must be a number greater than 1 (the mean trials per sample), got {n_max!r}"
        )
    return value


class AdaptiveSampler(Sampler):
    """The adaptive quadtree sampler.

    Parameters
    ----------
    brdf : the BRDF to sample (analytic or measured)
    n_max : mean number of rejection trials the trees aim at (> 1; the seed's knob)
    batch : ``sample(wo, n)`` uses the batch variant (True) or ``n`` independent draws (False)
    cache : True (default folder, ``$BRDF_STUDIO_CACHE`` or ``~/.cache/brdf-studio``), False, or a folder
    threads : ``sample_each`` of large batches on numba's threads (same samples; off by default: callers
        that run their own threads, like the renderer, should not nest them)
    **build : further :class:`core.quadtree.BuildOptions` (``projection``, ``theta_step``, ``phi_bins``, ...)
    """

    name = "adaptive"

    def __init__(
        self,
        brdf: BRDF,
        n_max: float = 2.0,
        batch: bool = True,
        cache: bool | str | os.PathLike[str] = True,
        threads: bool = False,
        **build: Any,
    ):
        super().__init__(brdf)
        self.n_max = _check_n_max(n_max)
        self.batch = bool(batch)
        self.threads = bool(threads)
        try:
            self.options = BuildOptions(n_max=self.n_max, **build)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"adaptive sampler: {exc}") from None
        store = None
        if cache is True:
            store = TableCache()
        elif cache not in (False, None):
            store = TableCache(cache)  # type: ignore[arg-type]
        table = QuadtreeTable(brdf.model, brdf.params, self.options, store)
        self.table = _TABLES.setdefault(table.key, table)
        if self.table.cache is None and store is not None:
            self.table.cache = store

    # the interface
    def sample(self, wo: np.ndarray, n: int, seed: int = 0) -> SampleBatch:
        if int(n) <= 0:
            raise ParameterError(f"the number of samples must be positive, got {n}")
        wo = check_direction(wo).reshape(3)
        if not self.batch:
            return self.sample_each(np.repeat(wo[None, :], int(n), axis=0), seed)
        wi, pdf, _ = self.table.sample_batch(wo, int(n), _seed(seed))
        return self._with_f(wo, wi, pdf)

    def sample_each(self, wo: np.ndarray, seed: int = 0) -> SampleBatch:
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        wi, pdf, _ = self.table.sample_each(wo, _seed(seed), self.threads)
        return self._with_f(wo, wi, pdf)

    def sample_with_trials(self, wo: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Like :meth:`sample_each`, with the number of rejection trials of every sample."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        return self.table.sample_each(wo, _seed(seed), self.threads)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        return self.table.pdf(wo, wi)

    def preload(self) -> int:
        """Load every tree of this material's table that the disk cache holds; returns how many."""
        return self.table.preload()

    # facts
    def normalizer(self, wo: np.ndarray) -> np.ndarray:
        """``I(wo)``: the integral of the luminance of ``f cos`` over the hemisphere (0 for the fallback)."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        bins, norm = self.table._prepare(wo)
        return np.where(bins >= 0, norm, 0.0)

    def acceptance(self, wo: np.ndarray) -> np.ndarray:
        """Exact per-trial acceptance probability ``I(wo) / V`` (the guarantee is ``>= 1/n_max``)."""
        return self.table.acceptance(np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64))

    @property
    def bound_violations(self) -> int:
        """Trials (since the table was made) where ``f`` exceeded its leaf bound: must be 0."""
        return self.table.violations

    def info(self) -> dict[str, Any]:
        t = self.table
        trees = t.trees()
        n_trees = len(trees)
        leaves = [b.n_leaves for b in trees]
        return {
            "sampler": self.name,
            "n_max": self.n_max,
            "memory_bytes": t.memory_bytes(),
            "build_seconds": t.build_seconds(),
            "trees": n_trees,
            "bins_total": t.n_bins,
            "bins_split": t.n_split,
            "memory_per_tree_bytes": t.memory_bytes() / n_trees if n_trees else 0.0,
            "leaves_mean": float(np.mean(leaves)) if leaves else 0.0,
            "bound_violations": t.violations,
            "mean_trials": t.trials / t.samples if t.samples else float("nan"),
            "cache_hits": t.cache_hits,
            "cache_folder": str(t.cache.folder) if t.cache is not None else None,
        }


def _seed(seed: int) -> int:
    return int(seed) % (1 << 64)


def clear_memory_cache() -> None:
    """Forget the in-memory tables (tests, benchmarks)."""
    _TABLES.clear()


register_sampler("adaptive", lambda brdf, **options: AdaptiveSampler(brdf, **options))
