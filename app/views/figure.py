"""Matplotlib views embedded in Qt (polar slice, albedo curve, error-vs-time): a shared base class."""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from matplotlib.artist import Artist
from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
from matplotlib.figure import Figure
from PySide6.QtCore import QSize, Qt
from PySide6.QtGui import QPainter, QStaticText
from PySide6.QtWidgets import QSizePolicy, QVBoxLayout, QWidget

from core.errors import OutputError

FIT_PASSES = 3
"""At most this many layout passes fit the margins to the texts (two, when new ticks come with the new size)."""


class StatusLine(QWidget):
    """A status text of ``lines`` lines (rich text allowed; wrapped, clipped beyond its height) that never
    moves the layout around it. A ``QLabel`` asks its layout to lay out again on every new text, and the request
    climbs to the window: an edit's new status under the polar slice laid out and repainted the whole tab
    twice, two more window flushes (each composes the window in software GL: tens of ms). This one only
    repaints itself."""

    def __init__(self, lines: int = 1, parent: QWidget | None = None):
        super().__init__(parent)
        self._text = ""
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.setFixedHeight(lines * self.fontMetrics().lineSpacing() + 2)

    def text(self) -> str:
        return self._text

    def setText(self, text: str) -> None:  # noqa: N802 (QLabel's name)
        if text != self._text:
            self._text = text
            self.update()

    def sizeHint(self) -> QSize:  # noqa: N802
        return QSize(80, self.height())

    def paintEvent(self, event) -> None:  # noqa: N802
        text = QStaticText(self._text)
        text.setTextFormat(Qt.TextFormat.AutoText)
        text.setTextWidth(self.width())
        QPainter(self).drawStaticText(0, 1, text)


class FigureView(QWidget):
    """A matplotlib figure in a widget, with a status line (``status_lines`` high) and export to PNG/SVG.

    Two ways to show a change: :meth:`redraw` draws the whole figure (axes, ticks, text: tens of ms), and
    :meth:`update_artists` redraws only the artists declared with :meth:`set_animated` over a saved copy of
    the rest (blitting: a few ms; shown with the window's next paint), falling back to a full draw when the
    saved copy is missing or stale. Artists that change now and then but cost too much to draw on every
    update (titles: text is slow to draw) can be declared as *overlay*: they are drawn into the saved copy
    when they change (:meth:`update_overlay`), not on every update and without a full draw.

    With ``fit_texts`` the margins are fitted to the texts (:meth:`fit_texts`) whenever the canvas is resized,
    so that titles, tick labels and legends stay inside a figure of any size.
    """

    def __init__(self, parent: QWidget | None = None, polar: bool = False, size=(4.0, 3.0), margins=None,
                 status_lines: int = 2, fit_texts: bool = False):  # fmt: skip
        super().__init__(parent)
        # Fixed margins between layouts: a layout engine ("tight") re-measures every text on every draw, which
        # made a redraw during a slider drag cost hundreds of milliseconds. Fitted once per resize instead.
        self.figure = Figure(figsize=size, dpi=90)
        self.figure.subplots_adjust(**(margins or {"left": 0.16, "right": 0.96, "bottom": 0.15, "top": 0.9}))
        self.canvas = FigureCanvasQTAgg(self.figure)
        self.axes = self.figure.add_subplot(111, projection="polar" if polar else None)
        self.status = StatusLine(status_lines)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.canvas, 1)
        layout.addWidget(self.status)
        self._animated: list[Artist] = []
        self._overlay: list[Artist] = []
        self._background = None
        self._composed = None
        """The saved background with the overlay drawn on it (what updates restore)."""
        self._background_bounds: tuple[float, ...] | None = None
        self.full_draws = 0
        """Full figure draws so far (tests check that data updates avoid them)."""
        if fit_texts:
            self.canvas.mpl_connect("resize_event", lambda _event: self.fit_texts())

    def fit_texts(self) -> None:
        """Margins that keep every text (titles wrapped to the figure's width, tick labels, legends) inside the
        figure at its current size: one layout pass (a text measurement), for a resize or a new title."""
        if min(self.figure.bbox.width, self.figure.bbox.height) < 40:
            return  # not laid out yet
        pars = self.figure.subplotpars
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "not applied": a figure too small for its texts
            for _ in range(FIT_PASSES):
                # Again while the margins move: axes of another size get other ticks ("0.25" where there
                # was "0.5"), whose labels may need other margins.
                before = (pars.left, pars.right, pars.bottom, pars.top)
                self.figure.tight_layout(pad=0.3)
                if np.allclose(before, (pars.left, pars.right, pars.bottom, pars.top), atol=1e-3):
                    break
        self._background = None

    def set_animated(self, artists: Iterable[Artist], overlay: Iterable[Artist] = ()) -> None:
        """Declare the artists whose data changes: full draws leave them out of the saved background and
        :meth:`update_artists` redraws only them (in z-order, so give them the layering they need). The
        ``overlay`` artists are drawn over the saved background once per change (:meth:`update_overlay`);
        they must not overlap the animated ones (they are drawn below them)."""
        self._animated = sorted(artists, key=lambda a: a.get_zorder())
        self._overlay = list(overlay)
        for a in (*self._animated, *self._overlay):
            a.set_animated(True)
        if not hasattr(self, "_draw_cid"):
            self._draw_cid = self.canvas.mpl_connect("draw_event", self._on_full_draw)
        self._background = None

    def _on_full_draw(self, event) -> None:
        self.full_draws += 1
        if self.canvas.is_saving():  # an export draws at another size: the saved copy would not match
            self._background = None  # (an axes draws its animated artists too when saving)
            return
        self._background = self.canvas.copy_from_bbox(self.figure.bbox)
        self._background_bounds = tuple(self.figure.bbox.bounds)
        self._compose()
        self._draw_animated()

    def _compose(self) -> None:
        """Draw the overlay over the saved background and keep the result."""
        if not self._overlay:
            self._composed = self._background
            return
        self.canvas.restore_region(self._background)
        for a in self._overlay:
            self.figure.draw_artist(a)
        self._composed = self.canvas.copy_from_bbox(self.figure.bbox)

    def _draw_animated(self) -> None:
        for a in self._animated:
            self.figure.draw_artist(a)

    def redraw(self) -> None:
        """Draw the whole figure at the next event-loop turn (after limits, ticks or titles change)."""
        self.canvas.draw_idle()
        # A paint runs a pending idle draw too: this one also recovers a request whose idle timer was lost
        # (seen after an export: the canvas then kept "a draw is pending" and ignored further requests).
        self.canvas.update()

    def _usable(self) -> bool:
        """The saved background matches the canvas (else a full draw is needed)."""
        renderer = getattr(self.canvas, "renderer", None)
        return (
            self._background is not None
            and renderer is not None
            and self._background_bounds == tuple(self.figure.bbox.bounds)
            and (renderer.width, renderer.height)
            == (int(self.figure.bbox.width), int(self.figure.bbox.height))
        )

    def update_artists(self) -> None:
        """Show new data of the animated artists now, by blitting over the saved background; a full draw
        (at the next event-loop turn) when there is no usable background."""
        if not self._usable():
            self.redraw()
            return
        self.canvas.restore_region(self._composed)
        self._draw_animated()
        # Shown at the next paint, not now: ``canvas.blit`` repaints at once, and a synchronous repaint of a
        # widget in a window composed through OpenGL (the lobe view's) flushes the whole window, 20-40 ms
        # under a software renderer, on top of the flush that the lobe's own redraw makes a moment later.
        self.canvas.update()

    def update_overlay(self) -> None:
        """Show changed overlay artists (and the animated ones): the overlay is drawn again over the saved
        background, which costs the overlay's own drawing instead of a full draw."""
        if self._usable():
            self._compose()
        self.update_artists()

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
        finally:
            self._background = None  # the canvas renderer may have been replaced by the export's
        return path
