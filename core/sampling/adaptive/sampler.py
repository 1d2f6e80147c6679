"""``adaptive_exact`` and ``adaptive_warp``: the adaptive quadtree sampler behind the common sampler interface.

``make_sampler("adaptive_exact", brdf, n_max=2.0)`` is the seed's exact mode: the density of its samples is
exactly ``f cos / I(wo)`` (luminance), so ``f cos / pdf`` is the same for every sample.
``make_sampler("adaptive_warp", brdf)`` is the rejection-free mode of the same trees: one evaluation of ``f``
per sample, a density that approximates ``f cos / I`` and is exact for its own samples. Both draw in one
compiled loop per batch (:mod:`core.sampling.adaptive.draw`) and return ``(wi, pdf, f)``. Each name takes the
same options (no ``mode``: the name is the mode). ``adaptive``, the former name of ``adaptive_exact``, is
accepted with a notice, and with ``mode="warp"`` means ``adaptive_warp`` (:func:`~core.sampling.base.current_sampler`).

A material's table (every node's tree) is built once, on first use, in well under a second for the
isotropic models (:mod:`core.sampling.adaptive.table`), shared by every sampler of the same BRDF and options
in the process, and stored on disk (:mod:`core.cache`).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import CancelledError, Future, ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from concurrent.futures import wait as futures_wait
from dataclasses import asdict, replace
from typing import Any

import numpy as np

from core.brdf import BRDF
from core.cache import TableCache
from core.dispatch import MERL
from core.errors import ParameterError
from core.kernels import eval_into
from core.sampling.adaptive.draw import (
    EXACT,
    MODES,
    NO_MODEL,
    WARP,
    acceptance_rows,
    normalizer_rows,
    pdf_rows,
    sample_rows,
)
from core.sampling.adaptive.records import (
    FLOAT_OPTIONS,
    INT_OPTIONS,
    AdaptiveTable,
    BuildCancelled,
    TableOptions,
    TableReport,
    table_options,
)
from core.sampling.adaptive.store import load_table, memory_bytes, save_table, table_cache_key
from core.sampling.adaptive.survey import is_lambertian
from core.sampling.adaptive.table import build_table
from core.sampling.base import (
    SampleBatch,
    Sampler,
    SamplerOption,
    check_buffers,
    check_direction,
    check_points,
    register_former_name,
    register_sampler,
)
from core.threads import thread_budget

_TABLES: dict[str, tuple[AdaptiveTable, TableReport]] = {}
"""Tables in memory by key (model, parameters, options, sources): one per material per process."""
_BUILDING: dict[str, Future] = {}
"""Full tables queued or being built in the background for progressive samplers, by key."""
_CANCEL: dict[str, threading.Event] = {}
"""Per key in ``_BUILDING``: set to stop that build (:func:`drop_builds`)."""
_FAILED: set[str] = set()
"""Keys whose background build failed (not queued again: the coarse table stays)."""
_BUILDER: ThreadPoolExecutor | None = None
"""The one background thread that builds full tables, one at a time in the order asked (each build runs its
nodes on numba's threads already)."""
_BUILDER_NICENESS = 0
"""The background builds' niceness (:func:`lower_build_priority`)."""
_LOCK = threading.Lock()

PARALLEL_MIN = 1 << 14
"""With ``threads=True``, batches at least this large are drawn in two chunks on two threads (the compiled
loop releases the GIL; a ``prange`` loop takes 40 s more to compile, for the same draws)."""

_POOL: ThreadPoolExecutor | None = None

_EVERY_ROW = np.zeros(0, dtype=np.bool_)
"""``pdf_rows``'s mask for every row."""
_NO_POINTS = np.zeros((0, 2))
"""``sample_rows``'s ``points`` when the caller places none: every uniform from the rows' streams."""


def _store(cache: Any) -> TableCache | None:
    if cache is True:
        return TableCache()
    if cache in (False, None):
        return None
    return TableCache(cache)


def wait_for_build(key: str, timeout: float | None = None) -> bool:
    """Wait for a background build of the full table ``key`` if one is queued or running (so that a caller
    about to make the same table does not make it a second time), at most ``timeout`` seconds; True when
    none is queued or running any more. A failed build's error is raised."""
    future = _BUILDING.get(key)
    if future is not None:
        try:
            future.result(timeout)
        except CancelledError:
            pass
        except FutureTimeout:
            return False
    return True


def drop_builds(keep: str = "") -> int:
    """Cancel every background build of a full table but ``keep``'s: the queued ones at once, the running one
    at its next tree (:class:`~core.sampling.adaptive.table.BuildCancelled`); returns how many. For a caller
    that wants only its latest material (the sampler view during a slider drag, whose previous value's build
    would otherwise hold the cores the next value's coarse table needs): a renderer wants every material's. A
    dropped table is queued again by a later :meth:`AdaptiveSampler.refresh`."""
    dropped = 0
    with _LOCK:
        for key, future in list(_BUILDING.items()):
            if key == keep:
                continue
            _CANCEL.pop(key).set()
            future.cancel()
            del _BUILDING[key]  # a later refresh queues a new build (behind the stopping one)
            dropped += 1
    return dropped


def lower_build_priority(niceness: int) -> None:
    """Run the background builds at this niceness (Linux: per thread, inherited by the threads a build
    starts), so that a process's foreground work (the sampler view's coarse table of a new value) gets the
    cores first. For a process whose foreground is interactive; a renderer keeps the default."""
    global _BUILDER_NICENESS
    _BUILDER_NICENESS = int(niceness)


class AdaptiveSampler(Sampler):
    """The adaptive quadtree sampler (both modes; see the module docstring).

    Parameters
    ----------
    brdf : the BRDF to sample (analytic or measured)
    n_max : mean number of rejection trials the exact mode's envelope allows (> 1; the seed's knob)
    mode : ``"exact"`` (rejection against the bounds: density exactly proportional to ``f cos``) or
        ``"warp"`` (rejection-free: one evaluation of ``f`` per sample)
    cache : True (default folder, ``$BRDF_STUDIO_CACHE`` or ``~/.cache/brdf-studio``), False, or a folder
    threads : draw large batches on numba's threads (same samples); off by default, as callers that run their
        own threads (the renderer) should not nest them
    progressive : when the material's full table is neither in memory nor on disk, start with a coarse one
        (the initial layout only: a fraction of the time, exact all the same) and build the full one on a
        background thread; :meth:`refresh` swaps it in. A renderer calls ``refresh`` between passes, so
        that a first image comes quickly (every density within a pass stays that of one table).
    **options : further :class:`~core.sampling.adaptive.table.TableOptions`
    """

    name = "adaptive_exact"

    def __init__(self, brdf: BRDF, n_max: Any = 2.0, mode: str = "exact", cache: Any = True,
                 threads: bool = False, progressive: bool = False, **options: Any):  # fmt: skip
        super().__init__(brdf)
        if mode not in MODES:
            raise ParameterError(
                f"the adaptive sampler's mode must be one of {', '.join(MODES)}, got {mode!r}"
            )
        self.mode = mode
        self.name = "adaptive_exact" if mode == "exact" else "adaptive_warp"
        self.options = table_options(n_max, **options)
        if mode == "warp":  # its own tables, without the exact mode's bounds (see TableOptions.bounds)
            self.options = replace(self.options, bounds=False)
        self.n_max = self.options.n_max
        self.threads = bool(threads)
        self.cache = _store(cache)
        self.key = table_cache_key(brdf, self.options)
        self.progressive = bool(progressive)
        self._current: tuple[AdaptiveTable, TableReport] | None = None
        self.violations = 0
        self.trials = 0
        self.samples = 0
        self._lambertian: bool | None = None
        self._counts_lock = threading.Lock()  # a renderer draws slices of one material on several threads

    # ------------------------------------------------------------------------------------------ the table
    @property
    def table(self) -> AdaptiveTable:
        return self._entry()[0]

    @property
    def report(self) -> TableReport:
        return self._entry()[1]

    def _entry(self) -> tuple[AdaptiveTable, TableReport]:
        if self._current is not None:
            return self._current
        entry = _TABLES[self.key] if self._stored() else None
        if entry is None and self.progressive:
            entry = self._coarse()
        if entry is None:
            with _LOCK:
                entry = _TABLES.get(self.key)
                if entry is None:
                    entry = self._build_full()
        self._current = entry
        return entry

    def _build_full(self) -> tuple[AdaptiveTable, TableReport]:
        entry = build_table(self.brdf, self.options)
        if self.cache is not None:
            save_table(self.cache, self.key, *entry)
        _TABLES[self.key] = entry
        return entry

    def _coarse(self) -> tuple[AdaptiveTable, TableReport]:
        """The initial layout's table now; the full one is queued at the first :meth:`refresh`."""
        coarse_key = self.key + ":coarse"
        with _LOCK:
            entry = _TABLES.get(coarse_key)
            if entry is None:
                entry = build_table(self.brdf, replace(self.options, rounds=1))
                _TABLES[coarse_key] = entry
        return entry

    def _queue_full(self) -> Future | None:
        """The background build of the full table (queued now if it is not there, queued or running)."""
        global _BUILDER
        with _LOCK:
            if self.key in _TABLES or self.key in _FAILED:
                return None
            future = _BUILDING.get(self.key)
            if future is None:
                if _BUILDER is None:
                    _BUILDER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="adaptive-table")
                cancel = _CANCEL[self.key] = threading.Event()
                future = _BUILDING[self.key] = _BUILDER.submit(self._build_in_background, cancel)
        return future

    def _build_in_background(self, cancel: threading.Event) -> None:
        _apply_niceness()
        try:
            entry = build_table(self.brdf, self.options, cancel=cancel)
            if self.cache is not None:
                save_table(self.cache, self.key, *entry)
            _TABLES[self.key] = entry
        except BuildCancelled:
            pass  # dropped (drop_builds): not a failure, a later refresh queues it again
        except BaseException:
            _FAILED.add(self.key)
            raise
        finally:
            with _LOCK:
                if _CANCEL.get(self.key) is cancel:  # not dropped and queued again meanwhile
                    del _BUILDING[self.key]
                    del _CANCEL[self.key]

    def refresh(self, wait: bool = False, timeout: float | None = None) -> bool:
        """Swap in the full table if it is ready (``wait``: block until it is, or ``timeout`` seconds); True
        when the table changed. Call it between batches whose densities must agree (a renderer's passes).

        The full table of a progressive sampler is queued at the first call, not when the coarse one is made:
        a renderer prepares every material (coarse tables) and renders a first pass before the full builds
        take a core from it, and the builds run one at a time on one background thread."""
        if self._current is not None and self._current is not _TABLES.get(self.key):
            future = self._queue_full()
            if wait and future is not None:
                try:
                    future.result(timeout)
                except (FutureTimeout, CancelledError):
                    pass
        full = _TABLES.get(self.key)
        if full is not None and self._current is not full:
            self._current = full
            return True
        return False

    @property
    def full_pending(self) -> bool:
        """Whether a progressive sampler on its coarse table will find the full one at a later
        :meth:`refresh` (it is queued, being built or ready; not when its build failed)."""
        return not self.complete and (self.key in _BUILDING or self.key in _TABLES)

    @property
    def build_failed(self) -> bool:
        """Whether the background build of the full table failed (it is not queued again)."""
        return self.key in _FAILED

    @property
    def complete(self) -> bool:
        """Whether the sampler draws from the material's full table (not a progressive coarse one)."""
        return self._entry() is _TABLES.get(self.key)

    def preload(self) -> int:
        """Make (or load) the material's table now; returns the number of trees."""
        return len(self.table.root)

    def _stored(self) -> bool:
        """Whether the full table is in memory, or on disk (then loaded into memory now)."""
        if self.key in _TABLES:
            return True
        if self.cache is None:
            return False
        with _LOCK:
            if self.key not in _TABLES:
                entry = load_table(self.cache, self.key)
                if entry is None:
                    return False
                _TABLES[self.key] = entry
        return True

    def available(self) -> bool:
        """Whether a table can be had without building one: the full table in memory or on disk, or a
        progressive sampler's coarse table in memory."""
        return (
            self._current is not None
            or self._stored()
            or (self.progressive and self.key + ":coarse" in _TABLES)
        )

    def queue_build(self) -> bool:
        """Put the full table on its way without waiting: True when it is ready (in memory, or loaded from
        disk now), else its build is queued on the background thread (unless queued or running already)
        and False. A table whose background build failed is left to the caller (True: :meth:`preload`
        builds it here, raising the error)."""
        if self._stored() or self.key in _FAILED:
            return True
        self._queue_full()
        return False

    # ------------------------------------------------------------------------------------------ the interface
    def sample(self, wo: np.ndarray, n: int, seed: int = 0) -> SampleBatch:
        if int(n) <= 0:
            raise ParameterError(f"the number of samples must be positive, got {n}")
        wo = check_direction(wo).reshape(1, 3)
        return self.sample_each(np.repeat(wo, int(n), axis=0), seed)

    def sample_each(self, wo: np.ndarray, seed: int = 0) -> SampleBatch:
        batch, _ = self._draw(wo, seed)
        return batch

    def sample_with_trials(self, wo: np.ndarray, seed: int = 0) -> tuple[SampleBatch, np.ndarray]:
        """Like :meth:`sample_each`, with the number of rejection trials of every sample."""
        return self._draw(wo, seed)

    def sample_into(self, wo: np.ndarray, seed: int, wi: np.ndarray, pdf: np.ndarray, f: np.ndarray,
                    points: np.ndarray | None = None) -> None:  # fmt: skip
        """:meth:`sample_each` written into the caller's C-contiguous float64 arrays (a renderer's buffers:
        no copies), the same draws; ``points (n, 2)``: the caller's uniforms for each row's first proposal
        (:meth:`core.sampling.base.Sampler.sample_into`; the leaf and the point in it, ``draw.sample_rows``)."""
        check_buffers(len(wo), wo=wo, wi=wi, pdf=pdf, f=f)
        self._draw_into(wo, seed, wi, pdf, f, np.empty(wo.shape[0], dtype=np.int64), points)

    def eval_pdf_where(self, wo: np.ndarray, wi: np.ndarray, mask: np.ndarray, f: np.ndarray,
                       pdf: np.ndarray) -> None:  # fmt: skip
        """:meth:`eval_pdf` at the rows where ``mask`` holds, written into ``f`` and ``pdf`` in place (the
        other rows are left as they are); all arrays C-contiguous, rows of one length."""
        check_buffers(len(wo), wo=wo, wi=wi, mask=mask, f=f, pdf=pdf)
        mode = EXACT if self.mode == "exact" else WARP
        apart = self._f_apart()
        pdf_rows(self.table, NO_MODEL if apart else self.brdf.model.id, self.brdf.params, mode, wo, wi, mask, pdf,
                 f)  # fmt: skip
        if apart:
            eval_into(self.brdf.model.id, wi, wo, self.brdf.params, f, mask if len(mask) else None)

    def _f_apart(self) -> bool:
        """True when the draws and densities leave ``f`` to :func:`core.kernels.eval_into`: a measured table
        in the rejection-free mode (where no density is made of ``f``), whose lookups a batch overlaps
        (:func:`core.merl.eval_merl_rows`; the same values as the per-row lookups it replaces)."""
        return self.mode != "exact" and self.brdf.model.id == MERL

    def compiled_equivalent(self) -> str | None:
        """``"cosine"`` for a Lambertian BRDF, whose table is flat: both modes draw the cosine density then,
        and report its pdf (:class:`~core.sampling.adaptive.records.AdaptiveTable` ``flat``)."""
        if self._lambertian is None:
            self._lambertian = is_lambertian(self.brdf)
        return "cosine" if self._lambertian else None

    def _draw(self, wo: np.ndarray, seed: int) -> tuple[SampleBatch, np.ndarray]:
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        n = wo.shape[0]
        wi = np.empty((n, 3))
        pdf = np.empty(n)
        f = np.empty((n, 3))
        trials = np.empty(n, dtype=np.int64)
        self._draw_into(wo, seed, wi, pdf, f, trials)
        return SampleBatch(wi, pdf, f), trials

    def _draw_into(self, wo: np.ndarray, seed: int, wi: np.ndarray, pdf: np.ndarray, f: np.ndarray,
                   trials: np.ndarray, points: np.ndarray | None = None) -> None:  # fmt: skip
        n = wo.shape[0]
        points = _NO_POINTS if points is None else check_points(points, n)
        mode = EXACT if self.mode == "exact" else WARP
        apart = self._f_apart()
        table, mid, p, seed = self.table, self.brdf.model.id, self.brdf.params, int(seed) % (1 << 63)
        if apart:
            mid = NO_MODEL
        chunks = thread_budget() if self.threads and n >= PARALLEL_MIN else 1
        if chunks == 1:
            v = sample_rows(table, mid, p, mode, wo, seed, 0, wi, pdf, f, trials, points)
        else:
            bounds = np.linspace(0, n, chunks + 1).astype(np.int64)
            pool = _pool()
            jobs = [
                pool.submit(
                    sample_rows,
                    table,
                    mid,
                    p,
                    mode,
                    wo[a:b],
                    seed,
                    int(a),
                    wi[a:b],
                    pdf[a:b],
                    f[a:b],
                    trials[a:b],
                    points[a:b] if len(points) else points,
                )  # fmt: skip
                for a, b in zip(bounds[:-1], bounds[1:], strict=True)
            ]
            v = sum(job.result() for job in jobs)
        if apart:
            eval_into(self.brdf.model.id, wi, wo, p, f)
        with self._counts_lock:
            self.violations += int(v)
            self.trials += int(trials.sum())
            self.samples += n

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        return self.eval_pdf(wo, wi)[1]

    def eval_pdf(self, wo: np.ndarray, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(f (n, 3), pdf (n,))`` at the pairs ``(wo, wi)``: the BRDF and the density in one pass (MIS
        needs both, and the exact mode's density is made of ``f``)."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        wi = np.ascontiguousarray(np.atleast_2d(wi), dtype=np.float64)
        wo, wi = np.broadcast_arrays(wo, wi)
        wo, wi = np.ascontiguousarray(wo), np.ascontiguousarray(wi)
        pdf = np.empty(wo.shape[0])
        f = np.empty((wo.shape[0], 3))
        mode = EXACT if self.mode == "exact" else WARP
        pdf_rows(self.table, self.brdf.model.id, self.brdf.params, mode, wo, wi, _EVERY_ROW, pdf, f)
        return f, pdf

    # ------------------------------------------------------------------------------------------ facts
    def normalizer(self, wo: np.ndarray) -> np.ndarray:
        """``I(wo)``, the integral of the luminance of ``f cos`` (0 where the cosine density is drawn)."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        out = np.empty(wo.shape[0])
        normalizer_rows(self.table, wo, out)
        return out

    def acceptance(self, wo: np.ndarray) -> np.ndarray:
        """The exact mode's acceptance per trial at ``wo`` (the guarantee is ``>= 1 / n_max``)."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        out = np.empty(wo.shape[0])
        acceptance_rows(self.table, wo, out)
        return out

    @property
    def bound_violations(self) -> int:
        """Trials (of this sampler) where ``f`` exceeded its leaf bound: must be 0."""
        return self.violations

    def info(self) -> dict[str, Any]:
        table, report = self._entry()
        leaves = len(table.corners)
        return {
            "sampler": self.name,
            "mode": self.mode,
            "n_max": self.n_max,
            "memory_bytes": memory_bytes(table),
            "build_seconds": report.seconds,
            "from_cache": report.from_cache,
            "trees": len(table.root),
            "theta_nodes": len(table.thetas),
            "phi_nodes": len(table.phis),
            "leaves": leaves,
            "leaves_mean": leaves / max(len(table.root), 1),
            "acceptance_min": report.acceptance_min,
            "chi2_max_edge": report.chi2_max_edge,
            "chi2_max_phi_edge": report.chi2_max_phi_edge,
            "normalizer_error": report.norm_error_max,
            "evaluations": report.evaluations,
            "bound_violations": self.violations,
            "mean_trials": self.trials / self.samples if self.samples else float("nan"),
            "options": asdict(self.options),
            "cache_folder": str(self.cache.folder) if self.cache is not None else None,
        }


def clear_memory_cache() -> None:
    """Forget the in-memory tables (tests, benchmarks); background builds are waited for first."""
    futures_wait(list(_BUILDING.values()))
    _TABLES.clear()


def _apply_niceness() -> None:
    """Lower this (the builder) thread's priority to ``_BUILDER_NICENESS`` if it is higher (raising it back
    would need privileges)."""
    if _BUILDER_NICENESS <= 0 or not hasattr(os, "setpriority"):
        return
    tid = threading.get_native_id()
    try:
        if os.getpriority(os.PRIO_PROCESS, tid) < _BUILDER_NICENESS:
            os.setpriority(os.PRIO_PROCESS, tid, _BUILDER_NICENESS)
    except OSError:
        pass  # not permitted here: the builds run at the process's priority


def _pool() -> ThreadPoolExecutor:
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=thread_budget(), thread_name_prefix="adaptive-draw")
    return _POOL


def _exact(brdf: BRDF, **options: Any) -> AdaptiveSampler:
    return AdaptiveSampler(brdf, mode="exact", **options)


def _warp(brdf: BRDF, **options: Any) -> AdaptiveSampler:
    return AdaptiveSampler(brdf, mode="warp", **options)


_MODE_NAMES = {"exact": "adaptive_exact", "warp": "adaptive_warp"}


def _former_mode(options: dict[str, Any], default: str) -> tuple[str, dict[str, Any]]:
    """The current name and options for the former option ``mode`` (``default`` when it is not given)."""
    rest = {k: v for k, v in options.items() if k != "mode"}
    mode = options.get("mode", default)
    if mode not in _MODE_NAMES:
        raise ParameterError(
            f"option 'mode' of the sampler 'adaptive' must be one of {', '.join(MODES)}, got {mode!r}"
        )
    return _MODE_NAMES[mode], rest


def _former_adaptive(options: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """``adaptive``: ``adaptive_exact``, or ``adaptive_warp`` with ``mode="warp"``."""
    return _former_mode(options, "exact")


def _former_warp(options: dict[str, Any]) -> tuple[str, dict[str, Any]] | None:
    """``adaptive_warp`` with ``mode="warp"``: ``adaptive_warp`` without it (current without ``mode``)."""
    if "mode" not in options:
        return None
    if options["mode"] != "warp":
        raise ParameterError(
            f"the sampler 'adaptive_warp' takes no mode, got mode={options['mode']!r}; the exact mode is "
            "the sampler 'adaptive_exact'"
        )
    return _former_mode(options, "warp")


def _declared_options() -> tuple[SamplerOption, ...]:
    """The options both modes take (``make_sampler`` checks them against this declaration first)."""
    return (
        SamplerOption(
            "n_max", "float", 1.0, 1000.0, lo_open=True, doc="mean trials per sample of the envelope"
        ),
        SamplerOption("cache", "cache", doc="the table cache: true (default folder), false, or a folder"),
        SamplerOption("threads", "bool", doc="draw large batches on two threads"),
        SamplerOption(
            "progressive", "bool", doc="a coarse table first, the full one built in the background"
        ),
        SamplerOption("parameterization", "choice", choices=("auto", "wi", "half"), doc="the trees' disk"),
        *(SamplerOption(k, "int", lo, hi) for k, (lo, hi) in INT_OPTIONS.items()),
        *(SamplerOption(k, "float", lo, hi) for k, (lo, hi) in FLOAT_OPTIONS.items()),
    )


def _table_bytes(brdf: BRDF, options: dict[str, Any]) -> float:
    """An upper bound of a table's memory from its options: the trees being built at once (each node's
    statistics over up to nine views, ~800 B) and every tree at its node capacity (~64 B a node); an
    anisotropic material's exact table may have up to twice ``phi_count`` azimuth nodes (``azimuth_count``)."""
    defaults = TableOptions()
    capacity = options.get("capacity", defaults.capacity)
    trees = options.get("max_thetas", defaults.max_thetas)
    if not brdf.model.isotropic:
        trees *= 2 * options.get("phi_count", defaults.phi_count)
    return thread_budget() * capacity * 800.0 + trees * capacity * 64.0


register_sampler("adaptive_exact", _exact, _declared_options(), _table_bytes)
register_sampler("adaptive_warp", _warp, _declared_options(), _table_bytes)
register_former_name("adaptive", _former_adaptive)
register_former_name("adaptive_warp", _former_warp)
