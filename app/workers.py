"""Background work for the desktop app: a generator run in a ``QThread``, its results delivered on the GUI
thread (napari's ``thread_worker`` idea, written small).

Signals are emitted from the worker thread on an object that lives in the GUI thread, so Qt queues them:
slots always run on the GUI thread and may touch widgets. Cancellation is cooperative: the worker stops
at the generator's next ``yield`` (the renderer yields once per pass), so the UI never waits on it.
"""

from __future__ import annotations

import traceback
from collections.abc import Callable, Iterator
from typing import Any

from PySide6.QtCore import QThread, Signal

from core.errors import BrdfStudioError


class GeneratorWorker(QThread):
    """Runs ``function(*args, **kwargs)`` (a generator, or a plain function) in its own thread.

    Signals: ``yielded(object)`` per item, ``returned(object)`` with a plain function's result,
    ``failed(str)`` with a user-readable message, and ``QThread.finished`` at the end in every case.
    """

    yielded = Signal(object)
    returned = Signal(object)
    failed = Signal(str)

    def __init__(self, function: Callable[..., Any], *args: Any, **kwargs: Any):
        super().__init__()
        self._function = function
        self._args = args
        self._kwargs = kwargs
        self._cancelled = False
        self.error: str | None = None

    def cancel(self) -> None:
        """Ask the worker to stop at its next ``yield`` (returns at once)."""
        self._cancelled = True

    @property
    def cancelled(self) -> bool:
        return self._cancelled

    def run(self) -> None:  # runs in the worker thread
        try:
            result = self._function(*self._args, **self._kwargs)
            if isinstance(result, Iterator):
                for item in result:
                    if self._cancelled:
                        close = getattr(result, "close", None)
                        if close is not None:
                            close()
                        break
                    self.yielded.emit(item)
            elif not self._cancelled:
                self.returned.emit(result)
        except BrdfStudioError as exc:
            self.error = str(exc)
            self.failed.emit(self.error)
        except Exception as exc:  # a bug: report it in the UI rather than kill the thread silently
            self.error = f"internal error: {type(exc).__name__}: {exc}"
            traceback.print_exc()
            self.failed.emit(self.error)


class WorkerPool:
    """Keeps running workers alive until they finish; cancels and waits for all of them on shutdown, and
    runs the shutdown hooks of other background resources (the render process)."""

    def __init__(self) -> None:
        self._workers: set[GeneratorWorker] = set()
        self._shutdown_hooks: list[Callable[[], None]] = []

    def on_shutdown(self, hook: Callable[[], None]) -> None:
        """Call ``hook()`` on :meth:`shutdown` (e.g. to end a child process; it may run more than once)."""
        self._shutdown_hooks.append(hook)

    def start(self, worker: GeneratorWorker) -> GeneratorWorker:
        self._workers.add(worker)
        worker.finished.connect(lambda w=worker: self._release(w))
        worker.start()
        return worker

    def _release(self, worker: GeneratorWorker) -> None:
        # ``finished`` is emitted just before the thread exits: wait for it, or dropping the last reference
        # here would destroy a QThread that still runs (Qt aborts the process).
        worker.wait()
        self._workers.discard(worker)

    def running(self) -> list[GeneratorWorker]:
        return [w for w in self._workers if w.isRunning()]

    def shutdown(self, timeout_ms: int = 3000) -> list[GeneratorWorker]:
        """Cancel every worker and wait for each to reach its next ``yield`` (or its end).

        A step that cannot be interrupted (a render's preparation building sampler tables can take minutes)
        may outlast ``timeout_ms``: such workers are returned and kept referenced in :data:`ABANDONED`, so
        the QThread is never destroyed while it runs (Qt aborts the process then);
        :func:`exit_if_abandoned` ends the process without waiting for them.
        """
        for w in list(self._workers):
            w.cancel()
        for hook in self._shutdown_hooks:
            hook()
        left = []
        for w in list(self._workers):
            if not w.wait(timeout_ms):
                left.append(w)
        ABANDONED.extend(left)
        self._workers.clear()
        return left


ABANDONED: list[GeneratorWorker] = []
"""Workers still running at shutdown (their results are no longer wanted)."""


def exit_if_abandoned(code: int) -> int:
    """At the very end of the app: if workers are still running, end the process now (``os._exit``), since
    the interpreter's teardown would destroy their running threads; otherwise return ``code``."""
    import os
    import sys

    if any(w.isRunning() for w in ABANDONED):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code
