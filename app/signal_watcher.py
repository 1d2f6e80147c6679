"""Ctrl-C (SIGINT) and SIGTERM while the desktop app runs: the app ends at once, its unsaved edits kept.

Python runs a signal handler only in the main thread, between two bytecodes: never while Qt's event loop
waits in C++, and late while the GUI thread is busy (compiling a kernel for a first draw). A handler that
raises (the default ``KeyboardInterrupt``) lands in whatever Python code Qt calls next (pyvistaqt's render
timer), where Qt prints the traceback and carries on. So the Python handlers here do nothing; the C-level
handler writes the signal's number to a socket (:func:`signal.set_wakeup_fd`), which a thread of this module
reads at once, whatever the GUI thread is doing.

Ending the app: the thread asks the GUI thread (a queued Qt signal) to autosave the unsaved edits
(:meth:`app.file_manager.FileManager.autosave`; the file is left in place, so the next launch offers them as
after a crash) and save the window's layout; if the GUI thread has not done so within :data:`GRACE_S` (it is
busy), the thread writes the autosave itself (the document is only read). Then one line goes to stderr and
the process exits with 128 + the signal's number (130, 143), without the interpreter's teardown, which would
wait for a background compile or a render's preparation (they cannot be interrupted; the render and snapshot
processes end by themselves when the app has gone). A second signal exits at once. A GUI thread that holds
the interpreter lock in native code (VTK drawing a frame) delays all of this until it lets go.

A native library may put its own SIGINT handler in place of Python's (LLVM, which numba loads): the handlers
are installed again every :data:`REINSTALL_MS`.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import sys
import threading
from types import FrameType
from typing import TYPE_CHECKING

from PySide6.QtCore import QObject, QTimer, Signal

if TYPE_CHECKING:
    from app.main_window import MainWindow

SIGNALS = (signal.SIGINT, signal.SIGTERM)
GRACE_S = 0.5
"""How long the GUI thread has to write the autosave before the watching thread writes it."""
REINSTALL_MS = 500


def _ignore(signum: int, frame: FrameType | None) -> None:
    """The Python-level handler: nothing (the watching thread acts on the wake-up byte)."""


class SignalWatcher(QObject):
    """Ends the app on SIGINT or SIGTERM (see the module docstring) from :meth:`install` to :meth:`uninstall`.

    ``window``: the main window whose edits are autosaved (None before it exists: the app then just exits).
    """

    end_requested = Signal()
    """Emitted by the watching thread; delivered on the GUI thread."""

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.window: MainWindow | None = None
        self.signum = 0
        self._previous: dict[int, object] = {}
        self._previous_fd = -1
        self._read, self._write = socket.socketpair()
        self._write.setblocking(False)  # set_wakeup_fd needs it: a signal handler must never block
        self._ending = threading.Lock()
        self.end_requested.connect(self._end_on_gui_thread)
        self._reinstall = QTimer(self)
        self._reinstall.setInterval(REINSTALL_MS)
        self._reinstall.timeout.connect(self._install_handlers)

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    def install(self) -> None:
        """Take SIGINT and SIGTERM (main thread only; the previous handlers are kept for :meth:`uninstall`)."""
        self._previous = {s: signal.getsignal(s) for s in SIGNALS}
        self._previous_fd = signal.set_wakeup_fd(self._write.fileno(), warn_on_full_buffer=False)
        self._install_handlers()
        self._reinstall.start()
        threading.Thread(target=self._watch, name="signal-watcher", daemon=True).start()

    def uninstall(self) -> None:
        self._reinstall.stop()
        signal.set_wakeup_fd(self._previous_fd)
        for s, handler in self._previous.items():
            signal.signal(s, handler)  # type: ignore[arg-type]
        self._write.close()  # the watching thread sees the end of its socket and returns

    def _install_handlers(self) -> None:
        for s in SIGNALS:
            signal.signal(s, _ignore)

    def _watch(self) -> None:
        """The watching thread: one byte per signal (its number)."""
        while True:
            try:
                data = self._read.recv(1)
            except OSError:
                return
            if not data:
                self._read.close()
                return
            if data[0] not in SIGNALS:  # another signal with a Python handler (any writes this byte)
                continue
            if self.signum:  # a second signal while the app ends: now
                self._exit(128 + data[0])
            self.signum = data[0]
            self.end_requested.emit()  # queued to the GUI thread
            threading.Timer(GRACE_S, self._end_on_this_thread).start()

    def _end_on_gui_thread(self) -> None:
        with self._ending:
            window = self.window
            if window is not None:
                with contextlib.suppress(Exception):  # nothing may stop the exit the user asked for
                    window.files.autosave()
                with contextlib.suppress(Exception):
                    window.save_layout()
            self._say_and_exit()

    def _end_on_this_thread(self) -> None:
        """The GUI thread is busy: write the autosave from here (Qt objects are left alone)."""
        with self._ending:
            window = self.window
            if window is not None:
                from app import settings

                with contextlib.suppress(Exception):
                    doc = window.document
                    if doc.dirty:
                        settings.write_autosave(doc.to_dict(), doc.path)
            self._say_and_exit()

    def _say_and_exit(self) -> None:
        kept = False
        with contextlib.suppress(Exception):
            kept = self.window is not None and self.window.document.dirty
        name = signal.Signals(self.signum).name
        note = "; the unsaved edits are kept and offered at the next start" if kept else ""
        print(f"brdf-studio: {name}: closed{note}", file=sys.stderr)
        self._exit(self.exit_code)

    @staticmethod
    def _exit(code: int) -> None:
        with contextlib.suppress(Exception):
            # The semaphores of the snapshot process's queues, unlinked and struck off multiprocessing's
            # resource tracker as at a normal exit (the tracker would otherwise warn of "leaked semaphore
            # objects" once this process has gone); nothing else of the normal exit's teardown runs.
            from multiprocessing import util

            util._run_finalizers(0)
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)
