"""A render whose passes run on a Dask cluster and whose image is, bit for bit, the one one process makes.

:func:`prepare_distributed` reads the scene's files and builds the sampler tables on the client
(:mod:`renderer.distributed.bundle`, :mod:`renderer.distributed.tables`; a client preparing the same scene
and strategy again reuses both), scatters their bytes to the cluster and returns a :class:`DistributedJob`,
whose :meth:`~DistributedJob.passes` behaves as :meth:`renderer.render.RenderJob.passes`: a
:class:`~renderer.render.Frame` as the image grows, to a sample budget or a time budget, stopped by a
``cancel`` event.

Why the image is exact, by construction:

1. The passes are one machine's: :func:`renderer.render.pass_plan` gives both paths the same pass indices,
   samples per pixel and first sample numbers. A pass's random numbers are keyed by the seed, its index and
   its sample numbers, never by a thread or a process, and every worker draws from the tables the client
   built, so a pass is the same array to the bit on any worker (or twice on one, when Dask runs a block
   again after its worker died).
2. The sum is one machine's: a task (:func:`renderer.distributed.worker.render_block`) returns each of its
   passes' mean radiance, not their sum, and the client adds them to its :class:`~renderer.film.Film` with
   ``Film.add_pass``, one pass after the other in pass order, as ``RenderJob.passes`` does. Blocks that come
   back early wait until the passes before them have come.

Every worker prepares the render (files, tables, geometry, kernels) in :func:`prepare_distributed`, before
the passes' clock starts, as one machine prepares before its passes; a worker that joins later prepares in
its first block. Blocks are consecutive passes, a few per worker thread for a sample budget (the last ones
even out the workers' loads), one pass for a time budget. A few blocks per thread are in flight at a time.
With a time budget, no block is submitted once the budget is spent; those not yet executing on a worker are
cancelled, those executing are finished and added if they follow the passes already added. A cancel
(Ctrl-C) cancels every block in flight: the film keeps the passes that had come. ``elapsed`` is the wall
time of the passes.
"""

from __future__ import annotations

import hashlib
import json
import math
import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Callable, Iterator
from typing import Any

from core.errors import BrdfStudioError, ParameterError
from core.scene import Scene
from renderer.distributed.bundle import bundle_scene
from renderer.distributed.cluster import ClusterError, ClusterState, RenderCluster
from renderer.distributed.tables import build_tables
from renderer.distributed.worker import BlockResult, RenderSpec, prepare_render, render_block
from renderer.film import Film
from renderer.render import Frame, Pass, check_budget, check_environment, pass_plan, pass_spp, versions
from renderer.world import StepCallback

BLOCKS_PER_THREAD = 4
"""A sample budget is cut into at least this many blocks per worker thread (the last ones balance the load)."""
MAX_BLOCK_PASSES = 8
"""Passes of a block at most (each pass's radiance comes back: 24 bytes a pixel)."""
TIME_BLOCK_PASSES = 1
"""Passes of a block under a time budget: what runs past the budget is, as on one machine, the pass each
worker thread is rendering."""
IN_FLIGHT_PER_THREAD = 2
"""Blocks submitted ahead per worker thread (one running, one waiting in the scheduler's queue)."""
POLL_SECONDS = 0.1
"""How often the client looks at the cancel event and the clock while it waits for blocks."""
STATE_SECONDS = 1.0
"""How often the cluster's state (workers, tasks) is asked for."""


def _blocks(plan: Iterator[Pass], size: int) -> Iterator[tuple[Pass, ...]]:
    block: list[Pass] = []
    for step in plan:
        block.append(step)
        if len(block) == size:
            yield tuple(block)
            block = []
    if block:
        yield tuple(block)


def block_passes(passes: int | None, threads: int) -> int:
    """Passes per block: for ``passes`` passes (a sample budget) on ``threads`` worker threads, at least
    :data:`BLOCKS_PER_THREAD` blocks a thread and at most :data:`MAX_BLOCK_PASSES` passes a block; under a
    time budget (``None``), :data:`TIME_BLOCK_PASSES`."""
    if passes is None:
        return TIME_BLOCK_PASSES
    return max(1, min(MAX_BLOCK_PASSES, math.ceil(passes / (BLOCKS_PER_THREAD * max(1, threads)))))


def _worker_options(options: dict[str, Any]) -> dict[str, Any]:
    """The strategy's options as workers use them: never a progressive (coarse first) table, and the table
    cache of the worker's machine (a folder named on the client may not exist there)."""
    out = {k: v for k, v in options.items() if k != "progressive"}
    if isinstance(out.get("cache"), str):
        out["cache"] = True
    return out


class DistributedJob:
    """A render prepared for a cluster (see the module docstring); made by :func:`prepare_distributed`."""

    def __init__(
        self,
        cluster: RenderCluster,
        scene: Scene,
        spec: RenderSpec,
        settings: dict[str, Any],
        contents: dict[str, Any],
        tables: dict[str, Any],
        prepare_report: dict[str, Any],
        block_size: int | None = None,
    ):
        self.cluster = cluster
        self.scene = scene
        self.spec = spec
        self.settings = settings
        self.prepare_report = prepare_report
        self.film = Film(spec.width, spec.height)
        self.elapsed = 0.0
        self.passes_done = 0
        self.batch = pass_spp(spec.width * spec.height)
        self.block_size = block_size
        self.rays = 0
        self.nonfinite = 0
        self.blocks = 0
        self.state = ClusterState(cluster.label, 0, 0)
        """The cluster as last seen: workers, threads, this render's tasks running and waiting."""
        self.workers: dict[str, dict[str, float]] = {}
        """Per worker that rendered blocks: its preparation and rendering seconds, blocks and passes."""
        self.ray_queries = ""
        self._contents = contents
        self._tables = tables
        self._session = uuid.uuid4().hex[:12]

    @property
    def size(self) -> tuple[int, int]:
        return self.spec.width, self.spec.height

    @property
    def spp(self) -> int:
        return self.film.spp

    def close(self) -> None:
        """Let the cluster forget the scene's files and tables (the workers keep their copies on disk)."""
        self._contents, self._tables = {}, {}

    # ------------------------------------------------------------------------------------------ passes
    def passes(
        self,
        spp: int | None = None,
        time_s: float | None = None,
        cancel: threading.Event | None = None,
        callback: Callable[[Frame], None] | None = None,
        first_spp: int | None = None,
    ) -> Iterator[Frame]:
        """As :meth:`renderer.render.RenderJob.passes`; a frame each time blocks of passes are added."""
        if spp is None and time_s is None:
            spp = self.settings["spp"]
        if spp is not None and spp < 1:
            raise ParameterError(f"samples per pixel must be at least 1, got {spp}")
        if time_s is not None and not time_s > 0:
            raise ParameterError(f"the time budget must be positive, got {time_s}")
        from distributed import wait

        client = self.cluster.client
        threads = max(1, sum(self.cluster.threads().values()))
        left = None if spp is None else -(-max(0, spp - self.film.spp) // self.batch)
        size = self.block_size or block_passes(left if time_s is None else None, threads)
        blocks = _blocks(pass_plan(self.batch, self.passes_done, self.film.spp, spp, first_spp), size)
        in_flight: dict[Any, tuple[Pass, ...]] = {}
        arrived: dict[int, BlockResult] = {}
        next_index = self.passes_done
        exhausted = stopping = False
        start, base, seen = time.perf_counter(), self.elapsed, 0.0
        try:
            while True:
                if cancel is not None and cancel.is_set():
                    return
                now = time.perf_counter()
                if now - seen >= STATE_SECONDS:
                    self.state = self.cluster.state({f.key for f in in_flight})
                    threads = max(1, self.state.threads)
                    seen = now
                if (not stopping and time_s is not None and self.film.spp > 0
                        and base + now - start >= time_s):  # fmt: skip
                    stopping = True
                    self._drop_waiting(in_flight)
                while not (stopping or exhausted) and len(in_flight) < IN_FLIGHT_PER_THREAD * threads + 1:
                    block = next(blocks, None)
                    if block is None:
                        exhausted = True
                        break
                    key = f"render-block-{self._session}-{block[0].index}"
                    future = client.submit(
                        render_block, self.spec, block, self._contents, self._tables, key=key
                    )
                    in_flight[future] = block
                if not in_flight:
                    return
                try:
                    with client.as_current():
                        done, _ = wait(list(in_flight), timeout=POLL_SECONDS, return_when="FIRST_COMPLETED")
                except TimeoutError:
                    continue
                for future in done:
                    block = in_flight.pop(future)
                    if future.status != "cancelled":
                        arrived[block[0].index] = self._result(future, block)
                added = False
                while next_index in arrived:
                    result = arrived.pop(next_index)
                    self._add(result)
                    next_index += len(result.passes)
                    added = True
                if added:
                    self.elapsed = base + time.perf_counter() - start
                    frame = Frame(self.film.image(), self.film.spp, self.elapsed, self.rays)
                    if callback is not None:
                        callback(frame)
                    yield frame
        finally:
            for future in in_flight:
                future.cancel()

    def run(self, spp: int | None = None, time_s: float | None = None, **kw: Any) -> Frame:
        """Render to the budget and return the last frame."""
        last = None
        for frame in self.passes(spp=spp, time_s=time_s, **kw):
            last = frame
        return last if last is not None else Frame(self.film.image(), self.film.spp, self.elapsed, self.rays)

    def _add(self, result: BlockResult) -> None:
        """A block's passes into the film, in pass order (``Film.add_pass``, as one machine adds them)."""
        for k, step in enumerate(result.passes):
            self.film.add_pass(result.radiance[k], step.spp)
        self.passes_done += len(result.passes)
        self.rays += result.rays
        self.nonfinite += result.nonfinite
        self.blocks += 1
        self.ray_queries = result.ray_queries
        w = self._worker(result.worker)
        w["prepare_seconds"] += result.prepare_seconds
        w["render_seconds"] += result.seconds
        w["blocks"] += 1
        w["passes"] += len(result.passes)

    def _worker(self, address: str) -> dict[str, float]:
        return self.workers.setdefault(address, {"prepare_seconds": 0.0, "render_seconds": 0.0,
                                                 "blocks": 0, "passes": 0})  # fmt: skip

    def _result(self, future: Any, block: tuple[Pass, ...]) -> BlockResult:
        """The block's result; a worker's error as a :class:`ClusterError` (one line)."""
        from distributed import KilledWorker

        try:
            return future.result()
        except BrdfStudioError:
            raise
        except KilledWorker:
            raise ClusterError(
                f"passes {block[0].index}-{block[-1].index} were lost with every worker that rendered them "
                "(each died while rendering: look for a worker out of memory); nothing was saved from them"
            ) from None

    def _drop_waiting(self, in_flight: dict[Any, tuple[Pass, ...]]) -> None:
        """Cancel the blocks no worker has started (the time budget is spent); the executing ones finish.
        (The scheduler counts a block a worker holds in its queue as processing: the workers are asked.)"""
        try:
            running = {k for keys in self.cluster.client.run(_executing).values() for k in keys}
        except Exception:  # noqa: BLE001  (a worker gone meanwhile: the scheduler's wider view)
            running = {str(k) for keys in self.cluster.client.processing().values() for k in keys}
        for future in [f for f in in_flight if str(f.key) not in running]:
            future.cancel()
            del in_flight[future]

    # ------------------------------------------------------------------------------------------ reports
    def info(self) -> dict[str, Any]:
        """What the sidecar JSON records, as :meth:`renderer.render.RenderJob.info`, and the cluster's part."""
        return {
            "scene": self.scene.source,
            "settings": self.settings,
            "spp": self.film.spp,
            "render_seconds": round(self.elapsed, 4),
            "rays": self.rays,
            "rays_per_second": round(self.rays / self.elapsed) if self.elapsed > 0 else None,
            "ray_queries": self.ray_queries,
            "nonfinite_contributions": self.nonfinite,
            "prepare": self.prepare_report,
            "cluster": {
                "scheduler": self.cluster.label,
                "distributed": _distributed_version(),
                "blocks": self.blocks,
                "passes": self.passes_done,
                "workers": {a: {k: round(v, 4) for k, v in w.items()} for a, w in self.workers.items()},
            },
            "versions": versions(),
        }


def _distributed_version() -> str:
    import distributed

    return str(distributed.__version__)


def _executing(dask_worker: Any) -> list[str]:
    """The keys of the tasks this worker is executing now (run on each worker by ``Client.run``)."""
    return [str(ts.key) for ts in dask_worker.state.executing]


def _prepare_workers(
    cluster: RenderCluster,
    spec: RenderSpec,
    contents: dict[str, Any],
    tables: dict[str, Any],
    session: str,
    on_step: StepCallback | None,
) -> dict[str, float]:
    """Every worker prepares ``spec`` now (:func:`~renderer.distributed.worker.prepare_render`); returns
    each worker's seconds. A worker that dies meanwhile has its preparation done by another (harmless: a
    worker keeps what it prepared). ``on_step`` sees the workers done (and may cancel by raising)."""
    from distributed import wait

    client = cluster.client
    addresses = sorted(cluster.threads())
    futures = [
        client.submit(
            prepare_render,
            spec,
            contents,
            tables,
            key=f"prepare-render-{session}-{i}",
            workers=[a],
            allow_other_workers=True,
            pure=False,
        )  # fmt: skip
        for i, a in enumerate(addresses)
    ]
    seconds: dict[str, float] = {}
    try:
        done = 0
        while done < len(futures):
            if on_step:
                on_step("workers prepare the scene", done, len(futures))
            try:
                with client.as_current():
                    wait(futures, timeout=POLL_SECONDS * 5)
            except TimeoutError:
                pass
            done = sum(f.done() for f in futures)
        for f in futures:
            address, s = f.result()  # a worker's ClusterError (one line, naming it) is raised here
            seconds[address] = seconds.get(address, 0.0) + s
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    if on_step:
        on_step("workers ready", len(futures), len(futures))
    return seconds


_CLIENT_TABLES: OrderedDict[str, tuple[dict[str, bytes], dict[str, dict[str, Any]]]] = OrderedDict()
"""The table files and reports of the last renders this client prepared, by scene and strategy."""
KEEP_CLIENT_TABLES = 2


def _client_tables(
    bundle_key: str,
    scene: Scene,
    sampler: str,
    options: dict[str, Any],
    overrides: dict[str, str],
    on_step: StepCallback | None,
) -> tuple[dict[str, bytes], dict[str, dict[str, Any]]]:
    """:func:`~renderer.distributed.tables.build_tables`, or what it gave for the same scene (its JSON and
    every file's bytes: the bundle's key), strategy and options in this process: a table is a function of
    those, so the files are the same, and a client rendering one scene again (the app's references, a study)
    does not read its measured materials and tables once more."""
    key = json.dumps([bundle_key, sampler, options, sorted(overrides.items())], sort_keys=True, default=str)
    if key in _CLIENT_TABLES:
        _CLIENT_TABLES.move_to_end(key)
        if on_step:
            on_step("tables ready", 1, 1)
        return _CLIENT_TABLES[key]
    made = build_tables(scene, sampler, options, overrides, on_step)
    _CLIENT_TABLES[key] = made
    while len(_CLIENT_TABLES) > KEEP_CLIENT_TABLES:
        _CLIENT_TABLES.popitem(last=False)
    return made


def prepare_distributed(
    cluster: RenderCluster,
    scene: Scene,
    sampler: str | None = None,
    sampler_options: dict[str, Any] | None = None,
    width: int | None = None,
    height: int | None = None,
    seed: int | None = None,
    max_depth: int | None = None,
    ris_candidates: int = 0,
    material_samplers: dict[str, str] | None = None,
    on_step: StepCallback | None = None,
    block_size: int | None = None,
    texts: dict[str, str] | None = None,
) -> DistributedJob:
    """A :class:`DistributedJob` of ``scene`` with :func:`renderer.render.prepare`'s settings: the same checks
    (budget, environment map, settings), the scene's files read, the sampler tables built (reported through
    ``on_step``) and both sent to the cluster. ``block_size``: passes per block (default
    :func:`block_passes`); ``texts``: files sent as these texts rather than as the disk holds them
    (:func:`~renderer.distributed.bundle.bundle_scene`)."""
    from core.sampling.base import check_sampler_options

    r = scene.render
    settings = {
        "width": int(r.width if width is None else width),
        "height": int(r.height if height is None else height),
        "spp": r.spp,
        "time_s": r.time_s,
        "sampler": sampler or r.sampler,
        "sampler_options": dict(r.sampler_options if sampler_options is None else sampler_options),
        "max_depth": int(r.max_depth if max_depth is None else max_depth),
        "rr_depth": r.rr_depth,
        "mis": r.mis,
        "seed": int(r.seed if seed is None else seed),
        "ris_candidates": int(ris_candidates),
    }
    check_budget(settings["width"], settings["height"], settings["ris_candidates"])
    if settings["ris_candidates"] < 0:
        raise ParameterError(
            f"the number of RIS candidates must be 0 (off) or positive, got {ris_candidates}"
        )
    if settings["width"] < 1 or settings["height"] < 1:
        raise ParameterError("the image width and height must be at least 1 pixel")
    if settings["max_depth"] < 1:
        raise ParameterError("the maximum path depth must be at least 1 bounce")
    overrides = dict(material_samplers or {})
    unknown = set(overrides) - {m.name for m in scene.materials}
    if unknown:
        raise scene.error("materials", f"no material named {', '.join(sorted(unknown))} (sampler override)")
    check_sampler_options(settings["sampler"], settings["sampler_options"])
    check_environment(scene)
    t0 = time.perf_counter()
    bundle, files = bundle_scene(scene, texts)
    table_files, materials = _client_tables(
        bundle.key,
        scene,
        settings["sampler"],
        _worker_options(settings["sampler_options"]),
        overrides,
        on_step,
    )
    spec = RenderSpec.make(
        bundle,
        sampler=settings["sampler"],
        sampler_options=_worker_options(settings["sampler_options"]),
        material_samplers=overrides,
        width=settings["width"],
        height=settings["height"],
        seed=settings["seed"],
        max_depth=settings["max_depth"],
        ris_candidates=settings["ris_candidates"],
    )
    table_digests = {rel: hashlib.sha256(raw).hexdigest() for rel, raw in table_files.items()}
    sent = cluster.scatter(
        {**{d: files[d] for d in bundle.digests}, **{table_digests[r]: raw for r, raw in table_files.items()}}
    )
    contents = {d: sent[d] for d in bundle.digests}
    tables = {rel: sent[d] for rel, d in table_digests.items()}
    report = {
        "seconds": round(time.perf_counter() - t0, 3),
        "materials": materials,
        "scene_files": len(bundle.digests),
        "scene_bytes": sum(len(files[d]) for d in bundle.digests),
        "table_bytes": sum(len(raw) for raw in table_files.values()),
    }
    job = DistributedJob(cluster, scene, spec, settings, contents, tables, report, block_size)
    t1 = time.perf_counter()
    prepared = _prepare_workers(cluster, spec, contents, tables, job._session, on_step)
    report["workers"] = {a: round(s, 3) for a, s in prepared.items()}
    report["workers_seconds"] = round(time.perf_counter() - t1, 3)
    report["seconds"] = round(time.perf_counter() - t0, 3)
    for address, s in prepared.items():
        job._worker(address)["prepare_seconds"] += s
    return job
