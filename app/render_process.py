"""The render process seen from the GUI: :class:`RenderServer` starts :func:`app.render_session.serve` in a
separate Python process ('spawn', safe with Qt), sends it jobs and cancels, and delivers its events as a Qt
signal on the GUI thread.

Why a process: preparing a render (numba compilation, sampler tables) and parts of each pass hold the
interpreter lock; in a thread of the GUI process they froze the event loop for up to a second. The process is
started once (lazily) and kept warm, so compilation and tables are paid once per app session.

Nothing here blocks the GUI thread: a reader thread per process waits on the event pipe (waiting releases the
lock) and queues what arrives; the GUI thread drains the queue when Qt delivers the wake-up signal and emits
``events_received`` with the batch, in order.

Restart: a new job while an older one still runs cancels the older one; if it has not stopped within
``grace_ms`` (it is in a step that cannot be interrupted, e.g. a long compilation), the process is killed and
a fresh one takes the new job. A process that dies by itself produces a ``crashed`` event; the next job starts
a new one. :meth:`RenderServer.stop` (called at app quit) ends it; and the process ends by itself when the
app's end of its command pipe closes, so it never outlives the app, even one that is killed.
"""

from __future__ import annotations

import multiprocessing
import queue
import signal
import threading
import time
from collections import deque
from typing import Any

from PySide6.QtCore import QObject, Qt, QTimer, Signal

from app import child_process
from app.render_session import TERMINAL_KINDS, serve


class _Handle:
    """One render process and its pipes (replaced as a whole when the process is restarted)."""

    def __init__(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        child_commands, self.commands = ctx.Pipe(duplex=False)
        self.events, child_events = ctx.Pipe(duplex=False)
        self.process = ctx.Process(  # SIGINT ignored before serve's module is imported (app.child_process)
            target=child_process.run,
            args=(f"{serve.__module__}:{serve.__name__}", child_commands, child_events),
            name="brdf-studio-render",
            daemon=True,
        )
        self.started_at = time.monotonic()  # the clock the process's time stamps use (see Timeline)
        self.process.start()
        # Keep only our ends: the process sees end-of-file on its command pipe when the app goes away, and we
        # see it on the event pipe when the process goes away.
        child_commands.close()
        child_events.close()
        self.stopping = False  # an exit we asked for (quit or restart) is not a crash
        # Commands go through a writer thread: a job with a large reference image does not fit the pipe's
        # buffer, and the GUI thread must not wait for the process to read it.
        self._outbox: queue.Queue[tuple[Any, ...] | None] = queue.Queue()
        threading.Thread(target=self._write, name="render-commands", daemon=True).start()

    @property
    def pid(self) -> int | None:
        return self.process.pid

    def send(self, message: tuple[Any, ...]) -> None:
        """Queue a command (returns at once; lost if the process has died, which the reader reports)."""
        self._outbox.put(message)

    def _write(self) -> None:  # runs in the writer thread, which owns the command pipe
        while (message := self._outbox.get()) is not None:
            try:
                self.commands.send(message)
            except (BrokenPipeError, EOFError, OSError):
                break
        self.commands.close()

    def end(self, timeout_s: float) -> None:
        """Ask the process to quit, then terminate and kill it if it does not."""
        self.stopping = True
        self.send(("quit",))
        self._outbox.put(None)
        self.process.join(timeout_s)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(timeout_s)
        if self.process.is_alive():
            self.process.kill()
            self.process.join(timeout_s)

    def kill(self) -> None:
        """End the process now (its reader thread reaps it)."""
        self.stopping = True
        if self.process.is_alive():
            self.process.kill()
        self._outbox.put(None)


def exit_text(code: int | None) -> str:
    if code is None:
        return "no exit status"
    if code < 0:
        try:
            return f"killed by signal {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


class RenderServer(QObject):
    """Runs render jobs in a separate, long-lived process; see the module docstring.

    Signals: ``events_received(list)`` with a batch of event dicts, in order (those of
    :mod:`app.render_session`, each with ``job``, ``pid``, ``sent`` and ``received``: ``time.monotonic()``
    when the process sent it and when the app read it), plus ``{"kind": "crashed", "job": None,
    "text": ...}`` when the process died by itself.
    """

    events_received = Signal(list)
    _wake = Signal()

    def __init__(self, grace_ms: int = 1500, parent: QObject | None = None):
        super().__init__(parent)
        self.grace_ms = grace_ms
        self._handle: _Handle | None = None
        self._next_id = 1
        self._jobs: dict[int, dict[str, Any]] = {}  # sent and not ended; payloads kept to resend on restart
        self._cancelled: set[int] = set()
        self._inbox: deque[tuple[_Handle, dict[str, Any]]] = deque()
        self._lock = threading.Lock()
        self._wake_pending = False
        self._wake.connect(self._drain, Qt.ConnectionType.QueuedConnection)
        self.restarts = 0
        # the reader threads outlive this object: once Qt destroys it, they must not emit on it (a signal of a
        # destroyed QObject crashed the process, not always raising RuntimeError); the flag lives outside the
        # object and is set under the lock the readers emit under
        alive = self._alive = {"yes": True}
        lock = self._lock

        def gone(*_: object) -> None:
            with lock:
                alive["yes"] = False

        self.destroyed.connect(gone)

    # ---- process ----------------------------------------------------------------------------------------
    @property
    def pid(self) -> int | None:
        """The render process's id, or None when none runs."""
        return self._handle.pid if self._handle is not None else None

    @property
    def started_at(self) -> float | None:
        """When the running render process was started (``time.monotonic()``), or None when none runs."""
        return self._handle.started_at if self._handle is not None else None

    @property
    def busy(self) -> bool:
        """True while a job sent to the process has not ended."""
        return bool(self._jobs)

    def ensure_started(self) -> None:
        """Start the render process if none runs (returns at once: it imports and warms up on its own)."""
        if self._handle is None:
            handle = _Handle()
            self._handle = handle
            threading.Thread(target=self._read, args=(handle,), name="render-events", daemon=True).start()

    def _read(self, handle: _Handle) -> None:  # runs in the reader thread
        while True:
            try:
                message = handle.events.recv()
            except (EOFError, OSError):
                break
            self._post(handle, message)
        handle.process.join()  # reap it; it has closed its pipe, so it is ending
        handle.events.close()
        self._post(handle, {"kind": "exit", "code": handle.process.exitcode})

    def _post(self, handle: _Handle, message: dict[str, Any]) -> None:  # runs in the reader thread
        message["received"] = time.monotonic()  # beside the process's "sent": the transfer's time
        with self._lock:
            self._inbox.append((handle, message))
            wake = not self._wake_pending and self._alive["yes"]
            self._wake_pending = True
            if wake:  # under the lock: the object cannot be destroyed between the check and the emit
                try:
                    self._wake.emit()
                except RuntimeError:  # the server object is gone (its window closed): nobody listens
                    pass

    def _drain(self) -> None:  # GUI thread
        with self._lock:
            batch = list(self._inbox)
            self._inbox.clear()
            self._wake_pending = False
        out: list[dict[str, Any]] = []
        for handle, message in batch:
            if handle is not self._handle:
                continue  # a replaced process's last words
            if message["kind"] == "exit":
                self._handle = None
                if not handle.stopping:
                    self._jobs.clear()
                    out.append({
                        "kind": "crashed", "job": None, "pid": handle.pid,
                        "text": f"the render process stopped unexpectedly ({exit_text(message['code'])}); "
                        "Render again to start a new one",
                    })  # fmt: skip
                continue
            if message["kind"] in TERMINAL_KINDS:
                self._jobs.pop(message["job"], None)
                self._cancelled.discard(message["job"])
            out.append(message)
        if out:
            self.events_received.emit(out)

    # ---- jobs -------------------------------------------------------------------------------------------
    def submit(self, job: dict[str, Any]) -> int:
        """Send a job (see :func:`app.render_session.serve` for its fields) and return its id. Jobs still
        running are cancelled; if they do not stop within ``grace_ms``, the process is replaced."""
        job_id = self._next_id
        self._next_id += 1
        job = {**job, "id": job_id}
        older = list(self._jobs)
        for other in older:
            self.cancel(other)
        self._jobs[job_id] = job
        self.ensure_started()
        assert self._handle is not None
        self._handle.send(("start", job))
        if older:
            QTimer.singleShot(self.grace_ms, lambda older=older: self._check_stopped(older))
        return job_id

    def cancel(self, job_id: int) -> None:
        """Ask the process to stop the job (returns at once; its ``cancelled`` event follows)."""
        if job_id in self._jobs and job_id not in self._cancelled:
            self._cancelled.add(job_id)
            if self._handle is not None:
                self._handle.send(("cancel", job_id))

    def _check_stopped(self, older: list[int]) -> None:
        if self._handle is not None and any(j in self._jobs for j in older):
            self._replace()

    def _replace(self) -> None:
        """Kill the process (busy with a cancelled job that does not stop) and resend the live jobs to a new
        one; the cancelled jobs are reported as such."""
        if self._handle is not None:
            self._handle.kill()
            self._handle = None
        self.restarts += 1
        dropped = [j for j in self._jobs if j in self._cancelled]
        for j in dropped:
            self._jobs.pop(j)
            self._cancelled.discard(j)
        if dropped:
            self.events_received.emit([{"kind": "cancelled", "job": j, "pid": None} for j in dropped])
        if self._jobs:
            self.ensure_started()
            assert self._handle is not None
            for job in self._jobs.values():
                self._handle.send(("start", job))

    def stop(self, timeout_s: float = 2.0) -> None:
        """End the process (app quit): ask it to quit, terminate it if it does not. Safe to call twice."""
        handle, self._handle = self._handle, None
        self._jobs.clear()
        self._cancelled.clear()
        if handle is not None:
            handle.end(timeout_s)
