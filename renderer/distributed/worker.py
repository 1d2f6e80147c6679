"""What a Dask worker runs: a block of passes of a render, returned pass by pass.

:func:`render_block` is a pure function of its arguments: the render (:class:`RenderSpec`), the passes (the
indices, samples per pixel and first sample numbers of :func:`renderer.render.pass_plan`, as one machine
would render them), and the bytes of the scene's files and of the client's sampler tables. It returns each
pass's mean radiance as :meth:`renderer.integrator.PathTracer.render_pass` made it, not their sum: the client
adds them to its film in pass order (:mod:`renderer.distributed.job`), as one machine does. A block that runs
twice (its worker died, Dask ran it again elsewhere) returns the same arrays to the bit.

A worker prepares a render once (the scene's files written by content, the tables installed, geometry,
kernels and samplers made, :func:`renderer.render.prepare`) and keeps it for the render's later blocks, by the
spec's key; a few renders are kept. The client has every worker prepare before the passes start
(:func:`prepare_render`); a worker that joins later prepares in its first block. Blocks of one render on
one worker run one at a time (one tracer renders one pass at a time); the tracer has as many threads as the
worker.

An error a user can cause (a file that did not arrive, a scene the worker cannot read) is a
:class:`~renderer.distributed.cluster.ClusterError` naming the worker and the scene's field and file.
"""

from __future__ import annotations

import hashlib
import json
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from core.errors import BrdfStudioError
from renderer.distributed.bundle import SceneBundle, materialize
from renderer.distributed.cluster import ClusterError
from renderer.distributed.tables import install_tables
from renderer.render import Pass, RenderJob, prepare

KEEP_RENDERS = 2
"""Prepared renders a worker keeps (the newest); an older one is closed when another arrives."""


@dataclass(frozen=True)
class RenderSpec:
    """A render as every worker prepares it: the scene (files by digest), the strategy and its options,
    the image size, seed, path length and RIS candidates. ``key`` names it (same key, same passes)."""

    bundle: SceneBundle
    sampler: str
    sampler_options: dict[str, Any]
    material_samplers: dict[str, str]
    width: int
    height: int
    seed: int
    max_depth: int
    ris_candidates: int
    key: str = field(default="", compare=False)

    @staticmethod
    def make(bundle: SceneBundle, **settings: Any) -> RenderSpec:
        text = json.dumps([bundle.key, settings], sort_keys=True, default=str)
        return RenderSpec(bundle, **settings, key=hashlib.sha256(text.encode()).hexdigest()[:32])


@dataclass
class BlockResult:
    """What a block returns: each pass's mean radiance ``radiance (passes, height * width, 3)`` float64 in
    the block's order, and what it cost."""

    passes: tuple[Pass, ...]
    radiance: np.ndarray
    rays: int
    nonfinite: int
    seconds: float
    """Rendering the passes (the preparation not included)."""
    prepare_seconds: float
    """Preparing the render on this worker, when this block did (else 0)."""
    worker: str
    ray_queries: str


@dataclass
class _Prepared:
    job: RenderJob
    lock: threading.Lock


_RENDERS: OrderedDict[str, _Prepared] = OrderedDict()
_RENDERS_LOCK = threading.Lock()
_PREPARING: dict[str, threading.Lock] = {}


def _worker() -> tuple[str, int]:
    """This worker's address and threads (outside Dask: this process, one thread)."""
    try:
        from distributed import get_worker

        w = get_worker()
        return str(w.address), max(1, int(w.state.nthreads))
    except (ImportError, ValueError):
        return "this process", 1


def _prepare(
    spec: RenderSpec, contents: dict[str, bytes], tables: dict[str, bytes]
) -> tuple[_Prepared, float]:
    """The prepared render of ``spec`` (made now, or kept from an earlier block) and the seconds preparing
    it took here (0 when kept)."""
    with _RENDERS_LOCK:
        kept = _RENDERS.get(spec.key)
        if kept is not None:
            _RENDERS.move_to_end(spec.key)
            return kept, 0.0
        gate = _PREPARING.setdefault(spec.key, threading.Lock())
    with gate:  # two blocks of one render arriving together: one prepares, the other waits for it
        with _RENDERS_LOCK:
            kept = _RENDERS.get(spec.key)
        if kept is not None:
            return kept, 0.0
        t0 = time.perf_counter()
        install_tables(tables)
        scene = materialize(spec.bundle, contents)
        _, threads = _worker()
        job = prepare(
            scene,
            sampler=spec.sampler,
            sampler_options=spec.sampler_options,
            width=spec.width,
            height=spec.height,
            seed=spec.seed,
            max_depth=spec.max_depth,
            threads=threads,
            ris_candidates=spec.ris_candidates,
            material_samplers=spec.material_samplers,
        )
        prepared = _Prepared(job, threading.Lock())
        with _RENDERS_LOCK:
            _RENDERS[spec.key] = prepared
            _PREPARING.pop(spec.key, None)
            while len(_RENDERS) > KEEP_RENDERS:
                _, old = _RENDERS.popitem(last=False)
                with old.lock:  # not while one of its blocks renders
                    old.job.close()
        return prepared, time.perf_counter() - t0


def _prepared(
    spec: RenderSpec, contents: dict[str, bytes], tables: dict[str, bytes]
) -> tuple[str, _Prepared, float]:
    """This worker's address, the prepared render of ``spec`` and the seconds preparing it took here; a
    user's mistake (a file, the scene) as a :class:`ClusterError` naming the worker."""
    address, _ = _worker()
    try:
        prepared, seconds = _prepare(spec, contents, tables)
    except BrdfStudioError as exc:
        raise ClusterError(f"worker {address} cannot prepare the render: {exc}") from None
    return address, prepared, seconds


def prepare_render(
    spec: RenderSpec, contents: dict[str, bytes], tables: dict[str, bytes]
) -> tuple[str, float]:
    """Prepare ``spec`` on this worker ahead of its blocks (:func:`renderer.distributed.prepare_distributed`
    runs one on each worker, so that the passes' clock starts after the preparation, as on one machine);
    returns the worker's address and the seconds it took (0 when the render was prepared already)."""
    address, _, seconds = _prepared(spec, contents, tables)
    return address, seconds


def render_block(
    spec: RenderSpec, passes: tuple[Pass, ...], contents: dict[str, bytes], tables: dict[str, bytes]
) -> BlockResult:
    """Render ``passes`` of ``spec`` (see the module docstring); ``contents``: the scene's files by digest,
    ``tables``: the client's table-cache files."""
    address, prepared, prepare_seconds = _prepared(spec, contents, tables)
    job = prepared.job
    n_pix = spec.width * spec.height
    out = np.empty((len(passes), n_pix, 3))
    with prepared.lock:
        stats = job.tracer.stats
        rays, nonfinite = stats.rays, stats.nonfinite
        t0 = time.perf_counter()
        for k, step in enumerate(passes):
            job.world.refresh_samplers()  # as RenderJob.passes does (a no-op for complete tables)
            out[k] = job.tracer.render_pass(step.index, step.spp, first_sample=step.first_sample, borrow=True)
        seconds = time.perf_counter() - t0
        rays, nonfinite = stats.rays - rays, stats.nonfinite - nonfinite
    return BlockResult(
        tuple(passes), out, rays, nonfinite, seconds, prepare_seconds, address, job.world.accel.backend
    )
