"""Watching the model files the app has opened: a file saved in any editor is read again, as BRDF Explorer
reloads its shaders.

Editors save in different ways: in place (one or several writes), or by writing a new file and renaming it
over the old one, after which the watcher no longer watches the path. So every change is read once the
writes pause for :data:`RELOAD_DELAY_MS`, the path is watched again each time, and the file's folder is
watched too: a file that was missing for a moment (between the remove and the rename) is read again when it
appears.

A new text is compiled in a worker thread (a Python file's kernels take numba seconds), one lane per file:
a save made while the previous one compiles waits, and only the latest text's result is kept.
"""

from __future__ import annotations

import os

from PySide6.QtCore import QFileSystemWatcher, QObject, QTimer

from app.jobs import Job, JobRunner
from app.model_library import ModelLibrary, compile_version

RELOAD_DELAY_MS = 100
"""Quiet time after a change of a file before it is read (an editor's burst of writes is read once)."""


def _stamp(path: str) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


class ModelFileWatcher(QObject):
    """Reloads each opened file of ``library`` that changed on disk (see the module); compiles in ``jobs``'
    lanes, or here when ``jobs`` is None."""

    def __init__(
        self,
        library: ModelLibrary,
        jobs: JobRunner | None = None,
        parent: QObject | None = None,
        delay_ms: int = RELOAD_DELAY_MS,
    ):
        super().__init__(parent)
        self.library = library
        self.jobs = jobs
        self.watcher = QFileSystemWatcher(self)
        self.watcher.fileChanged.connect(self._file_changed)
        self.watcher.directoryChanged.connect(self._folder_changed)
        self._due: set[str] = set()
        self._stamps: dict[str, tuple[int, int] | None] = {}
        self.timer = QTimer(self)
        self.timer.setSingleShot(True)
        self.timer.setInterval(delay_ms)
        self.timer.timeout.connect(self.reload_due)
        library.changed.connect(self.watch)
        for path in library.files:
            self.watch(path)

    def watch(self, path: str) -> None:
        """Watch ``path`` (an opened file) and its folder, if not watched yet."""
        if path not in self._stamps:
            self._stamps[path] = _stamp(path)
        self._rewatch(path)

    def _rewatch(self, path: str) -> None:
        folder = os.path.dirname(path)
        if os.path.isdir(folder) and folder not in self.watcher.directories():
            self.watcher.addPath(folder)
        if os.path.exists(path) and path not in self.watcher.files():
            self.watcher.addPath(path)

    def _file_changed(self, path: str) -> None:
        if path in self.library.files:
            self._due.add(path)
            self.timer.start()  # restarted: read once the writes pause

    def _folder_changed(self, folder: str) -> None:
        """Something in ``folder`` changed: a watched file there that was replaced (renamed over, removed and
        written again) is due; other files of the folder are none of ours."""
        for path in self.library.files:
            if os.path.dirname(path) == folder and (
                path not in self.watcher.files() or _stamp(path) != self._stamps.get(path)
            ):
                self._due.add(path)
                self.timer.start()

    def reload_due(self) -> None:
        """Read the files that changed (now; the timer calls it once the writes pause)."""
        self.timer.stop()
        due, self._due = self._due, set()
        for path in sorted(due):
            self._rewatch(path)
            self._stamps[path] = _stamp(path)
            if self.jobs is None:
                self.library.reload(path)
                continue
            text = self.library.new_text(path)
            lane = self.jobs.lane(f"model file {path}")
            if text is None:  # back to the version in use: a text still compiling is not wanted
                lane.cancel()
            else:
                lane.submit(Job(
                    compile_version, (path, text), key=text,
                    done=lambda model, path=path: self.library.adopt(path, model),
                    failed=lambda problem, path=path: self.library.refuse(path, problem),
                ))  # fmt: skip

    def idle(self) -> bool:
        """No change waiting to be read, no text being compiled."""
        if self._due or self.jobs is None:
            return not self._due
        return self.jobs.idle(*(f"model file {p}" for p in self.library.files))
