"""Side-by-side progressive renders without Qt, and the render process that runs them.

:func:`render_events` prepares each strategy, then interleaves their passes so both advance together; each
event is a plain dict the render panel draws. :func:`serve` is the main loop of the render process
(started by :mod:`app.render_process`): it takes jobs and cancels from a pipe and sends the events of each
job back through another, so that preparation (kernel compilation, sampler tables) and passes never hold the
GUI process's interpreter lock. The process stays alive between renders: what it compiled and built is
reused by the next render.

Events: ``{"kind": "status", "text"}`` while preparing; ``{"kind": "frame", "strategy", "image", "spp",
"seconds", "rays", "rmse", "relmse"}`` after every pass (errors only with a reference image);
``{"kind": "done"}`` at the end. :func:`serve` adds ``"job"`` and ``"pid"`` to each, and ends every job with
exactly one of ``done``, ``cancelled`` or ``{"kind": "error", "text"}``.
"""

from __future__ import annotations

import contextlib
import os
import queue
import sys
import threading
import traceback
from collections.abc import Iterator, Sequence
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from core.errors import BrdfStudioError, ParameterError
from core.scene import Scene

RENDER_NICENESS = 5
"""The render process runs at a lower scheduling priority, so that on a busy machine the GUI gets the CPU
first (both strategies of a comparison are slowed alike: equal time stays fair)."""

TERMINAL_KINDS = ("done", "cancelled", "error")
"""Event kinds that end a job: exactly one of them is the last event of every job :func:`serve` runs."""


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
) -> Iterator[dict[str, Any]]:
    """Render ``scene`` with each strategy to the same budget: ``mode`` ``"spp"`` (samples per pixel) or
    ``"time"`` (seconds of rendering each, preparation excluded). Setting ``cancel`` stops the render between
    two preparation steps or two passes (the generator then ends without ``done``)."""
    from renderer.image_io import image_errors
    from renderer.render import prepare

    check_request(mode, budget, width, height, reference)

    def on_step(label: str, i: int, n: int, steps: list[str]) -> None:
        if cancel is not None and cancel.is_set():
            raise RenderCancelled
        steps.append(f"{label} ({i}/{n})")

    jobs = {}
    try:
        for name in strategies:
            steps: list[str] = []
            yield {"kind": "status", "text": f"Preparing '{name}': geometry, kernels, sampler tables ..."}
            options = dict(scene.render.sampler_options) if name == scene.render.sampler else {}
            if name.startswith("adaptive"):
                # a coarse table at once and the full one in the background, swapped in between passes: the
                # first image comes in seconds (core.sampling.adaptive.sampler, "progressive")
                options["progressive"] = True
            jobs[name] = prepare(
                scene, sampler=name, sampler_options=options, width=width, height=height, seed=seed,
                on_step=lambda label, i, n, steps=steps: on_step(label, i, n, steps),
            )  # fmt: skip
            report = jobs[name].prepare_report
            secs = sum(v for k, v in report.items() if k.endswith("seconds") and isinstance(v, int | float))
            yield {"kind": "status", "text": f"Prepared '{name}' in {secs:.1f} s ({len(steps)} steps)"}
    except RenderCancelled:
        return
    passes = {
        name: job.passes(spp=int(budget), cancel=cancel)
        if mode == "spp"
        else job.passes(time_s=float(budget), cancel=cancel)
        for name, job in jobs.items()
    }
    active = list(passes)
    while active:
        for name in list(active):
            if cancel is not None and cancel.is_set():
                return
            try:
                frame = next(passes[name])
            except StopIteration:
                active.remove(name)
                continue
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
            if reference is not None:
                event.update(image_errors(frame.image, reference))
            yield event
    yield {"kind": "done"}


# ---- the render process ---------------------------------------------------------------------------------


def serve(commands: Connection, events: Connection) -> None:
    """The render process's main loop: run the jobs that arrive on ``commands`` one after the other and send
    their events on ``events``, until ``("quit",)`` arrives or the app's end of the pipe closes.

    Commands: ``("start", job)`` with ``job`` a dict (``id``, ``scene`` as a dict, ``base_dir``, ``source``,
    ``strategies``, ``mode``, ``budget``, ``width``, ``height``, ``seed``, ``reference`` and, for tests,
    ``hold_s``: an uninterruptible pause before preparing, standing in for a long compilation);
    ``("cancel", job_id)``; ``("quit",)``. A listener thread reads them while the main thread renders, so a
    cancel is seen between two preparation steps or two passes.
    """
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
                pending.put(message[1])
            elif message[0] == "cancel":
                with lock:
                    cancelled.add(message[1])
                    if current["id"] == message[1]:
                        current["cancel"].set()
            elif message[0] == "quit":
                os._exit(0)  # nothing to save: a half-built table cache entry is written atomically

    def send(job_id: int, event: dict[str, Any]) -> None:
        try:
            events.send({**event, "job": job_id, "pid": pid})
        except (BrokenPipeError, EOFError, OSError):
            os._exit(0)

    threading.Thread(target=listen, name="render-commands", daemon=True).start()
    with contextlib.suppress(OSError, AttributeError):  # AttributeError: no os.nice on Windows
        os.nice(RENDER_NICENESS)
    import renderer.render  # noqa: F401  (import while the first job is on its way)

    while True:
        job = pending.get()
        job_id = int(job["id"])
        cancel = threading.Event()
        with lock:
            if job_id in cancelled:
                cancel.set()
            current["id"], current["cancel"] = job_id, cancel
        try:
            _run_job(job, cancel, lambda event, job_id=job_id: send(job_id, event))
        finally:
            with lock:
                current["id"] = None
                cancelled.discard(job_id)


def _run_job(job: dict[str, Any], cancel: threading.Event, send: Any) -> None:
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
        scene = scene_from_dict(
            job["scene"], source=job["source"], base_dir=job["base_dir"], check_files=False
        )
        finished = False
        for event in render_events(
            scene, job["strategies"], job["mode"], job["budget"], job["width"], job["height"],
            job["seed"], job["reference"], cancel=cancel,
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
