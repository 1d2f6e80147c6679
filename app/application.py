"""Starting the desktop app: the ``QApplication``, the first project, and the event loop."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from core.errors import BrdfStudioError

if TYPE_CHECKING:
    from app.main_window import MainWindow


def run_app(
    path: Path | None = None,
    empty: bool = False,
    quit_after: float | None = None,
    restore: str | None = None,
    shown: Callable[[MainWindow], None] | None = None,
) -> int:
    """Open the main window on ``path`` (or the demo scene, or an empty project) and run until closed
    (or ``quit_after`` seconds, for smoke tests), or until SIGINT or SIGTERM ends the process with 130 or
    143, the unsaved edits autosaved (:mod:`app.signal_watcher`). ``restore``: what to do with the unsaved
    edits of a session that crashed, ``"ask"`` (the default), ``"yes"`` or ``"no"`` (the default with
    ``quit_after``).
    ``shown(window)`` is called once the window is shown, before the project is opened (tests drive the app
    through it)."""
    import os

    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app.main_window import APP_NAME, MainWindow
    from app.signal_watcher import SignalWatcher

    if path is not None and not Path(path).is_file():
        raise BrdfStudioError(f"project file '{path}' not found")
    if (
        not os.environ.get("DISPLAY")
        and not os.environ.get("WAYLAND_DISPLAY")
        and sys.platform.startswith("linux")
    ):
        raise BrdfStudioError(
            "no display: the desktop app needs a screen (on a headless machine run it under Xvfb, "
            "e.g. 'xvfb-run -a brdf-studio')"
        )
    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setApplicationName(APP_NAME)
    app.setOrganizationName("brdf-studio")
    watcher = SignalWatcher(app)  # from here on Ctrl-C and SIGTERM end the app with its edits autosaved
    watcher.install()
    try:
        window = MainWindow()
        watcher.window = window
        window.show()
        if shown is not None:
            shown(window)
        if restore is None:
            restore = "no" if quit_after is not None else "ask"
        window.start(path, empty=empty, restore=restore)
        if quit_after is not None:
            window.ask_unsaved = lambda: "discard"
            QTimer.singleShot(int(quit_after * 1000), window.close)
        code = int(app.exec())
    finally:
        watcher.uninstall()
    from app.workers import exit_if_abandoned

    return exit_if_abandoned(code)
