"""Matplotlib views embedded in Qt (polar slice, albedo curve, error-vs-time): a shared base class."""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
from matplotlib.figure import Figure
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from core.errors import OutputError


class FigureView(QWidget):
    """A matplotlib figure in a widget, with a status line and export to PNG/SVG."""

    def __init__(self, parent: QWidget | None = None, polar: bool = False, size=(4.0, 3.0), margins=None):
        super().__init__(parent)
        # Fixed margins: a layout engine ("tight") re-measures every text on every draw, which made a redraw
        # during a slider drag cost hundreds of milliseconds.
        self.figure = Figure(figsize=size, dpi=90)
        self.figure.subplots_adjust(**(margins or {"left": 0.16, "right": 0.96, "bottom": 0.15, "top": 0.9}))
        self.canvas = FigureCanvasQTAgg(self.figure)
        self.axes = self.figure.add_subplot(111, projection="polar" if polar else None)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.canvas, 1)
        layout.addWidget(self.status)

    def redraw(self) -> None:
        self.canvas.draw_idle()

    def export(self, path: str | Path) -> Path:
        """Save the figure; the format follows the suffix (``.png`` or ``.svg``)."""
        path = Path(path)
        if path.suffix.lower() not in (".png", ".svg"):
            raise OutputError(f"cannot export a plot as '{path.suffix}': use .png or .svg")
        if not path.parent.is_dir():
            raise OutputError(f"cannot write '{path}': folder '{path.parent}' does not exist")
        try:
            self.figure.savefig(path, dpi=150)
        except OSError as exc:
            raise OutputError(f"cannot write '{path}': {exc.strerror or exc}") from None
        return path
