"""Side-by-side progressive renders without Qt, and the render process that runs them.

:func:`render_events` prepares each strategy and renders its first pass (a small one) before the next strategy
is prepared, so the first image of the first strategy never waits for the second's tables; then it
interleaves their passes so both advance together. Each event is a plain dict the render panel draws.
:func:`serve` is the main loop of the render process (started by :mod:`app.render_process`): it takes jobs
and cancels from a pipe and sends the events of each job back through another, so that preparation (kernel
compilation, sampler tables) and passes never hold the GUI process's interpreter lock. The process stays
alive between renders: what it compiled and built is reused by the next render.

Events: ``{"kind": "status", "text"}`` while preparing; ``{"kind": "frame", "strategy", "image", "spp",
"seconds", "rays", "rmse", "relmse"}`` after every pass (errors only with a reference image);
``{"kind": "done"}`` at the end; ``{"kind": "timing", "marks"}`` after each strategy's first frame and at the
end (see :class:`Timeline`: where the seconds before the first images went). :func:`serve` adds ``"job"``,
``"pid"`` and ``"sent"`` (``time.monotonic()``) to each, and ends every job with exactly one of ``done``,
``cancelled`` or ``{"kind": "error", "text"}``.

While no job has come yet, the process loads the kernels a render calls (:func:`renderer.tracer_warmup.load_kernels`,
seconds that the first render would otherwise wait for); a job that arrives meanwhile waits at most for the
material or the tiny pass in progress.

A job with a ``cluster`` (:class:`app.settings.ClusterSetting` as a dict) renders its passes on Dask
(:mod:`renderer.distributed`: the same image as here); the process connects once and keeps the connection (a
local cluster, its workers) for the next jobs with the same setting. Its frames then carry ``"cluster"``, the
cluster's state in words (workers, tasks).
"""

from __future__ import annotations

import contextlib
import os
import queue
import sys
import threading
import time
import traceback
from collections.abc import Iterator, Sequence
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from core.errors import BrdfStudioError, ParameterError
from core.scene import Scene

IMPORTED_AT = time.monotonic()
"""When this module (and numpy) had been imported: in the render process, its first time stamp."""

RENDER_NICENESS = 5
"""The render process runs at a lower scheduling priority, so that on a busy machine the GUI gets the CPU
first (both strategies of a comparison are slowed alike: equal time stays fair)."""

TERMINAL_KINDS = ("done", "cancelled", "error")
"""Event kinds that end a job: exactly one of them is the last event of every job :func:`serve` runs."""

FIRST_PASS_SPP = 1
"""Samples per pixel of each strategy's first pass: its first image in a fraction of a second (the passes
after it trace ~2^18 paths each, :func:`renderer.render.pass_spp`: 5 spp at 256x192, ~1 s in a cold
process). The estimate is the same; only the passes' sizes differ."""

WARM_STRATEGIES = ("uniform", "adaptive_warp", "adaptive_exact")
"""Strategies whose kernels the idle render process loads before its first job (the panel's defaults and
the adaptive modes, whose table builders are the slowest to load)."""
PROGRESSIVE_STRATEGIES = frozenset({"adaptive_warp"})
"""The strategies whose render starts on a coarse table (the initial layout) and swaps in the full one. Not the
exact mode: its coarse layout's wider cells can fill their trees with bounds (the demo's brushed steel, Ward
``sx = 0.05, sy = 0.25, ks = 0.6, kd = 0.05``: 178 k leaves in 56 trees at an acceptance of 0.41, against the
full table's 62 k in 88, and the slower build of the two), and the full build that follows would compete with
the render for the cores; the exact mode's first image waits for its full tables."""


class NumbaClock:
    """Seconds numba has spent in this process: ``dispatch_s`` in its compile path (loading compiled kernels
    from its disk cache, or compiling them; with the wait for its lock) and ``compile_s`` compiling (a
    kernel missing from the disk cache), summed over threads. :meth:`install` registers it with numba's
    event API (``numba.core.event``)."""

    def __init__(self) -> None:
        self.dispatch_s = 0.0
        self.compile_s = 0.0
        self.compiles = 0
        self._open: dict[tuple[str, int], tuple[int, float]] = {}  # (kind, thread) -> (depth, start)
        self._lock = threading.Lock()
        self._listener: Any = None

    def install(self) -> NumbaClock:
        from numba.core import event

        clock = self

        class Listener(event.Listener):
            def on_start(self, ev: Any) -> None:
                clock._start(ev.kind)

            def on_end(self, ev: Any) -> None:
                clock._end(ev.kind)

        self._listener = Listener()
        for kind in ("numba:compiler_lock", "numba:compile"):
            event.register(kind, self._listener)
        return self

    def uninstall(self) -> None:
        """Stop listening (the totals stay)."""
        listener, self._listener = self._listener, None
        if listener is not None:
            from numba.core import event

            for kind in ("numba:compiler_lock", "numba:compile"):
                event.unregister(kind, listener)

    def _start(self, kind: str) -> None:
        key = (kind, threading.get_ident())
        with self._lock:
            depth, start = self._open.get(key, (0, 0.0))
            self._open[key] = (depth + 1, time.monotonic() if depth == 0 else start)

    def _end(self, kind: str) -> None:
        key = (kind, threading.get_ident())
        with self._lock:
            depth, start = self._open.pop(key, (1, time.monotonic()))
            if depth > 1:
                self._open[key] = (depth - 1, start)
                return
            seconds = time.monotonic() - start
            if kind == "numba:compile":
                self.compile_s += seconds
                self.compiles += 1
            else:
                self.dispatch_s += seconds


class Timeline:
    """Time stamps of the render process's steps, for the benchmark (``bench/app_latency.py --parts first``)
    and for anyone asking where the seconds before a first image went.

    Each mark is ``{"step", "t", "numba_s", "compile_s"}``: ``t`` is ``time.monotonic()`` (one clock for
    every process of the machine, so the app can place the marks after its own click), and the numba seconds
    are :class:`NumbaClock`'s totals at that moment (``None`` without a clock)."""

    def __init__(self, numba: NumbaClock | None = None, marks: Sequence[dict[str, Any]] = ()) -> None:
        self.numba = numba
        self.marks: list[dict[str, Any]] = list(marks)

    def mark(self, step: str) -> None:
        numba = self.numba
        self.marks.append({
            "step": step, "t": time.monotonic(),
            "numba_s": None if numba is None else round(numba.dispatch_s, 4),
            "compile_s": None if numba is None else round(numba.compile_s, 4),
        })  # fmt: skip

    def event(self) -> dict[str, Any]:
        return {"kind": "timing", "marks": [dict(m) for m in self.marks]}


class RenderCancelled(Exception):
    """Raised inside preparation (between its steps) when the render is cancelled."""


def check_request(
    mode: str, budget: float, width: int, height: int, reference: np.ndarray | None = None
) -> None:
    """Raise :class:`ParameterError` for a budget or a reference that cannot be rendered (cheap: the panel
    checks before sending a job, the render process again before preparing)."""
    if mode not in ("spp", "time"):
        raise ParameterError(f"the budget mode is 'spp' or 'time', got {mode!r}")
    if not budget > 0:
        raise ParameterError(f"the render budget must be positive, got {budget}")
    if reference is not None and reference.shape[:2] != (height, width):
        raise ParameterError(
            f"the reference image is {reference.shape[1]}x{reference.shape[0]}; render at that size "
            f"(now {width}x{height}) or load another reference"
        )


def render_events(
    scene: Scene,
    strategies: Sequence[str],
    mode: str = "spp",
    budget: float = 16,
    width: int = 256,
    height: int = 192,
    seed: int = 0,
    reference: np.ndarray | None = None,
    cancel: threading.Event | None = None,
    timeline: Timeline | None = None,
    first_spp: int | None = FIRST_PASS_SPP,
    cluster: Any = None,
    texts: dict[str, str] | None = None,
) -> Iterator[dict[str, Any]]:
    """Render ``scene`` with each strategy to the same budget: ``mode`` ``"spp"`` (samples per pixel) or
    ``"time"`` (seconds of rendering each, preparation excluded). Each strategy is prepared and renders its
    first pass (``first_spp`` samples per pixel; ``None``: a full pass) before the next one is prepared;
    then their passes alternate. Setting ``cancel`` stops the render between two preparation steps or two
    passes (the generator then ends without ``done``). With a ``timeline``, its steps are marked and it is
    yielded (a ``timing`` event) after each strategy's first frame and at the end. With a ``cluster``
    (:class:`renderer.distributed.RenderCluster`) the passes run there (``texts``: model files' texts sent in
    place of the files, :func:`renderer.distributed.prepare_distributed`)."""
    from renderer.image_io import image_errors
    from renderer.render import prepare

    check_request(mode, budget, width, height, reference)
    mark = timeline.mark if timeline is not None else lambda step: None

    def on_step(label: str, i: int, n: int, steps: list[str]) -> None:
        if cancel is not None and cancel.is_set():
            raise RenderCancelled
        steps.append(f"{label} ({i}/{n})")

    def frame_event(name: str, frame: Any) -> dict[str, Any]:
        event = {
            "kind": "frame",
            "strategy": name,
            "image": frame.image,
            "spp": frame.spp,
            "seconds": frame.elapsed,
            "rays": frame.rays,
            "rmse": float("nan"),
            "relmse": float("nan"),
        }
        state = getattr(passes_of.get(name), "state", None)  # a render on a cluster
        if state is not None:
            event["cluster"] = state.describe()
        if reference is not None:
            event.update(image_errors(frame.image, reference))
        return event

    passes: dict[str, Iterator[Any]] = {}
    passes_of: dict[str, Any] = {}  # each strategy's job
    active: list[str] = []
    for name in strategies:
        steps: list[str] = []
        yield {"kind": "status", "text": f"Preparing '{name}': geometry, kernels, sampler tables ..."}
        mark(f"prepare {name}")
        options = dict(scene.render.sampler_options) if name == scene.render.sampler else {}
        if name in PROGRESSIVE_STRATEGIES and cluster is None:
            # a coarse table at once and the full one in the background, swapped in between passes: the
            # first image comes in seconds (core.sampling.adaptive.sampler, "progressive")
            options["progressive"] = True
        try:
            if cluster is not None:
                from renderer.distributed import prepare_distributed

                job = prepare_distributed(
                    cluster, scene, sampler=name, sampler_options=options, width=width, height=height, seed=seed,
                    on_step=lambda label, i, n, steps=steps: on_step(label, i, n, steps), texts=texts,
                )  # fmt: skip
            else:
                job = prepare(
                    scene, sampler=name, sampler_options=options, width=width, height=height, seed=seed,
                    on_step=lambda label, i, n, steps=steps: on_step(label, i, n, steps),
                )  # fmt: skip
        except RenderCancelled:
            return
        passes_of[name] = job
        report = job.prepare_report
        secs = report["seconds"]
        mark(f"prepared {name}: geometry {report.get('geometry_seconds', 0):.2f} s, materials "
             f"{report.get('compile_seconds', 0):.2f} s, tables {report.get('warm_up_seconds', 0):.2f} s, "
             f"kernels {report.get('kernel_load_seconds', 0):.2f} s")  # fmt: skip
        yield {"kind": "status", "text": f"Prepared '{name}' in {secs:.1f} s ({len(steps)} steps)"}
        budget_kw = {"spp": int(budget)} if mode == "spp" else {"time_s": float(budget)}
        passes[name] = job.passes(cancel=cancel, first_spp=first_spp, **budget_kw)
        # its first image now: the next strategy's preparation does not hold it back
        frame = next(passes[name], None)
        if cancel is not None and cancel.is_set():
            return
        if frame is not None:
            active.append(name)
            mark(f"first pass {name}: {frame.spp} spp, {frame.elapsed:.2f} s")
            yield frame_event(name, frame)
            if timeline is not None:
                yield timeline.event()
    while active:
        for name in list(active):
            if cancel is not None and cancel.is_set():
                return
            frame = next(passes[name], None)
            if frame is None:
                active.remove(name)
                continue
            yield frame_event(name, frame)
    if timeline is not None:
        mark("done")
        yield timeline.event()
    yield {"kind": "done"}


# ---- the render process ---------------------------------------------------------------------------------


def serve(commands: Connection, events: Connection) -> None:
    """The render process's main loop: run the jobs that arrive on ``commands`` one after the other and send
    their events on ``events``, until ``("quit",)`` arrives or the app's end of the pipe closes.

    Commands: ``("start", job)`` with ``job`` a dict (``id``, ``scene`` as a dict, ``base_dir``, ``source``,
    ``model_texts``: the text of each model file the scene names as the app uses it, ``strategies``,
    ``mode``, ``budget``, ``width``, ``height``, ``seed``, ``reference``, ``cluster`` (optional: where the
    passes run) and, for tests, ``hold_s``: an uninterruptible pause before preparing, standing in for a long
    compilation);
    ``("cancel", job_id)``; ``("quit",)``. A listener thread reads them while the main thread renders, so a
    cancel is seen between two preparation steps or two passes. Before the first job, the main thread loads
    the renderer's kernels (:data:`WARM_STRATEGIES`) and stops as soon as a job is waiting.
    """
    numba = NumbaClock().install()
    timeline = Timeline(numba)
    timeline.marks.append({"step": "process: python started, app.render_session imported",
                           "t": IMPORTED_AT, "numba_s": 0.0, "compile_s": 0.0})  # fmt: skip
    pending: queue.Queue[dict[str, Any]] = queue.Queue()
    lock = threading.Lock()
    cancelled: set[int] = set()
    current: dict[str, Any] = {"id": None, "cancel": threading.Event()}
    pid = os.getpid()

    def listen() -> None:
        while True:
            try:
                message = commands.recv()
            except (EOFError, OSError):
                os._exit(0)  # the app is gone (even killed): never outlive it
            if message[0] == "start":
                pending.put({**message[1], "arrived": time.monotonic()})
            elif message[0] == "cancel":
                with lock:
                    cancelled.add(message[1])
                    if current["id"] == message[1]:
                        current["cancel"].set()
            elif message[0] == "quit":
                close_cluster()  # a local cluster's workers stop with it
                os._exit(0)  # nothing to save: a half-built table cache entry is written atomically

    def send(job_id: int, event: dict[str, Any]) -> None:
        try:
            events.send({**event, "job": job_id, "pid": pid, "sent": time.monotonic()})
        except (BrokenPipeError, EOFError, OSError):
            os._exit(0)

    threading.Thread(target=listen, name="render-commands", daemon=True).start()
    with contextlib.suppress(OSError, AttributeError):  # AttributeError: no os.nice on Windows
        os.nice(RENDER_NICENESS)
    import renderer.render  # noqa: F401  (import while the first job is on its way)

    timeline.mark("process: renderer imported")
    from renderer.tracer_warmup import load_kernels

    try:
        for name, _ in load_kernels(WARM_STRATEGIES, stop=lambda: not pending.empty()):
            timeline.mark(f"process: kernels of '{name}' loaded (idle)")
    except Exception:  # a bug there must not cost the renders: they load what they need themselves
        traceback.print_exc(file=sys.stderr)
        timeline.mark("process: kernel loading failed (see stderr)")
    while True:
        job = pending.get()
        job_id = int(job["id"])
        cancel = threading.Event()
        with lock:
            if job_id in cancelled:
                cancel.set()
            current["id"], current["cancel"] = job_id, cancel
        arrived = {"step": "job arrived", "t": job["arrived"], "numba_s": None, "compile_s": None}
        job_timeline = Timeline(numba, sorted([*timeline.marks, arrived], key=lambda m: m["t"]))
        job_timeline.mark("job taken")
        try:
            _run_job(job, cancel, lambda event, job_id=job_id: send(job_id, event), job_timeline)
        finally:
            with lock:
                current["id"] = None
                cancelled.discard(job_id)


def _run_job(
    job: dict[str, Any], cancel: threading.Event, send: Any, timeline: Timeline | None = None
) -> None:
    """Run one job, sending its events; its last event is ``done``, ``cancelled`` or ``error``."""
    from core.scene import scene_from_dict

    try:
        if cancel.is_set():
            send({"kind": "cancelled"})
            return
        if job.get("hold_s"):
            import time

            send({"kind": "status", "text": "Holding (test) ..."})
            time.sleep(float(job["hold_s"]))  # deaf to cancel, as a compilation is
        from core.model_files import pin_text

        for path, text in job.get("model_texts", {}).items():
            pin_text(path, text)  # the app's version in use, whatever the file holds now
        scene = scene_from_dict(
            job["scene"], source=job["source"], base_dir=job["base_dir"], check_files=False
        )
        if timeline is not None:
            timeline.mark("scene read")
        cluster = _cluster(job["cluster"], send) if job.get("cluster") else None
        finished = False
        for event in render_events(
            scene, job["strategies"], job["mode"], job["budget"], job["width"], job["height"],
            job["seed"], job["reference"], cancel=cancel, timeline=timeline, cluster=cluster,
            texts=job.get("model_texts"),
        ):  # fmt: skip
            if cancel.is_set():
                break
            finished = event["kind"] == "done"
            send(event)
        if not finished:
            send({"kind": "cancelled"})
    except BrdfStudioError as exc:
        send({"kind": "error", "text": str(exc)})
    except Exception as exc:  # a bug: report it in the panel, keep the process for the next job
        traceback.print_exc(file=sys.stderr)
        send({"kind": "error", "text": f"internal error: {type(exc).__name__}: {exc}"})


_CLUSTER: dict[str, Any] = {}
"""The render process's connection to a Dask cluster (``setting``, ``cluster``), kept from job to job."""


def _cluster(setting: dict[str, Any], send: Any) -> Any:
    """The cluster of ``setting`` (a :class:`app.settings.ClusterSetting` as a dict): the one connected for an
    earlier job with the same setting, or a new connection (a :class:`~core.errors.BrdfStudioError` when the
    scheduler does not answer)."""
    from app.settings import ClusterSetting
    from renderer.distributed import connect

    if _CLUSTER.get("setting") == setting:
        return _CLUSTER["cluster"]
    close_cluster()
    wanted = ClusterSetting(**setting)
    send({"kind": "status", "text": f"Connecting to {wanted.describe()} ..."})
    cluster = connect(
        wanted.address if wanted.kind == "address" else None,
        wanted.workers if wanted.kind == "local" else None,
    )
    _CLUSTER.update(setting=setting, cluster=cluster)
    send({"kind": "status", "text": f"Rendering on {cluster.state().describe()}"})
    return cluster


def close_cluster() -> None:
    """Close the kept cluster connection (a local cluster stops its workers)."""
    cluster = _CLUSTER.pop("cluster", None)
    _CLUSTER.pop("setting", None)
    if cluster is not None:
        with contextlib.suppress(Exception):  # on the way out: nothing left to report it to
            cluster.close()
