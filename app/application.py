"""Starting the desktop app: the ``QApplication``, the first project, and the event loop."""

from __future__ import annotations

import sys
from pathlib import Path

from core.errors import BrdfStudioError


def run_app(path: Path | None = None, empty: bool = False) -> int:
    """Open the main window on ``path`` (or the demo scene, or an empty project) and run until closed."""
    from PySide6.QtWidgets import QApplication

    from app.main_window import APP_NAME, MainWindow

    if path is not None and not Path(path).is_file():
        raise BrdfStudioError(f"project file '{path}' not found")
    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setApplicationName(APP_NAME)
    app.setOrganizationName("brdf-studio")
    window = MainWindow()
    window.show()
    window.start(path, empty=empty)
    return int(app.exec())
