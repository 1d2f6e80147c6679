"""The one place the app runs background work: typed jobs in lanes, cancellable, latest request wins.

A :class:`Job` says what to run and what to do with its result on the GUI thread (``done``), with its failure
(``failed``: a user-readable line) and with what it yields (``progress``). A :class:`Lane` runs one job at a
time; a job submitted while another runs waits as the lane's *next* one, replacing any job waiting there
(a slider drag asks for many albedo curves, only the last one is worth computing), and a finished job whose
``key`` is no longer the lane's latest is dropped unseen. Jobs run in :class:`app.workers.GeneratorWorker`
threads; long CPU work inside them goes to processes of its own (the render and snapshot processes), so the
GUI's interpreter lock stays free.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

from app.workers import GeneratorWorker, WorkerPool

T = TypeVar("T")


@dataclass(frozen=True)
class Job(Generic[T]):
    """``run(*args, **kwargs)`` (a function returning ``T``, or a generator) and its GUI-thread callbacks."""

    run: Callable[..., T]
    args: tuple[Any, ...] = ()
    kwargs: dict[str, Any] = field(default_factory=dict)
    key: Hashable = None
    """What the result is of (a stale result, of a key no longer the lane's latest, is dropped)."""
    done: Callable[[T], None] | None = None
    failed: Callable[[str], None] | None = None
    progress: Callable[[Any], None] | None = None


class Lane:
    """One job at a time, the latest request next; see the module docstring."""

    def __init__(self, name: str, pool: WorkerPool, started: Callable[[Lane], None] | None = None):
        self.name = name
        self._pool = pool
        self._started = started
        self.worker: GeneratorWorker | None = None
        self.next: Job[Any] | None = None
        self.key: Hashable = None
        self.error: str | None = None
        """The last failure (cleared when the next job starts)."""
        self.closed = False

    @property
    def idle(self) -> bool:
        return self.worker is None and self.next is None

    def submit(self, job: Job[Any]) -> None:
        self.next = job
        self.key = job.key
        if self.worker is None:
            self._launch()

    def cancel(self) -> None:
        """Drop the waiting job and ask the running one to stop at its next ``yield``."""
        self.next = None
        self.key = object()  # whatever the running job returns is stale now
        if self.worker is not None:
            self.worker.cancel()

    def _launch(self) -> None:
        job, self.next = self.next, None
        if job is None or self.closed:
            self.worker = None
            return
        worker = GeneratorWorker(job.run, *job.args, **job.kwargs)
        worker.returned.connect(lambda result, job=job: self._returned(job, result))
        worker.failed.connect(lambda message, job=job: self._failed(job, message))
        if job.progress is not None:
            worker.yielded.connect(job.progress)
        worker.finished.connect(self._launch)
        self.worker = worker
        self.error = None
        self._pool.start(worker)
        if self._started is not None:
            self._started(self)

    def _returned(self, job: Job[Any], result: Any) -> None:
        if self.next is None and self.key == job.key and job.done is not None:
            job.done(result)

    def _failed(self, job: Job[Any], message: str) -> None:
        if self.key != job.key:
            return
        self.error = message
        if job.failed is not None:
            job.failed(message)


class JobRunner:
    """The app's lanes and the threads behind them; :meth:`shutdown` cancels everything at quit."""

    def __init__(self) -> None:
        self.pool = WorkerPool()
        self.lanes: dict[str, Lane] = {}

    def lane(self, name: str, started: Callable[[Lane], None] | None = None) -> Lane:
        """The lane called ``name`` (made on first use)."""
        if name not in self.lanes:
            self.lanes[name] = Lane(name, self.pool, started)
        return self.lanes[name]

    def submit(self, lane: str, job: Job[Any]) -> None:
        self.lane(lane).submit(job)

    def idle(self, *names: str) -> bool:
        """No job (of the named lanes, or of any) running or waiting."""
        lanes = [self.lanes[n] for n in names if n in self.lanes] if names else list(self.lanes.values())
        return all(lane.idle for lane in lanes)

    def errors(self) -> dict[str, str]:
        return {name: lane.error for name, lane in self.lanes.items() if lane.error}

    def on_shutdown(self, hook: Callable[[], None]) -> None:
        self.pool.on_shutdown(hook)

    def shutdown(self) -> None:
        for lane in self.lanes.values():
            lane.closed = True
            lane.next = None
        self.pool.shutdown()
