"""Image views for renders: the image fills its pane (kept fitted as the pane resizes) until the user zooms
with the wheel or pans by dragging; key 1 shows it at its actual size (one image pixel on one screen pixel),
key F or 0 or a double click fits it again; linked views follow each other."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QImage, QKeyEvent, QPixmap, QTransform, QWheelEvent
from PySide6.QtWidgets import QGraphicsPixmapItem, QGraphicsScene, QGraphicsView


class ImageView(QGraphicsView):
    """Shows an 8-bit RGB image; ``view_changed`` fires when the user zooms or pans."""

    view_changed = Signal()

    def __init__(self, parent=None):
        super().__init__(parent)
        self.setScene(QGraphicsScene(self))
        self._item = QGraphicsPixmapItem()
        self.scene().addItem(self._item)
        self.setDragMode(QGraphicsView.DragMode.ScrollHandDrag)
        self.setTransformationAnchor(QGraphicsView.ViewportAnchor.AnchorUnderMouse)
        self.setBackgroundBrush(Qt.GlobalColor.darkGray)
        self.rgb8: np.ndarray | None = None
        self._linked: list[ImageView] = []
        self._syncing = False
        self.fitted = True
        """The image fills the pane (until the user zooms or pans)."""
        self.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAsNeeded)
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)  # a click gives it the keys
        self.setToolTip("Wheel: zoom; drag: pan; 1: actual size (1:1); F, 0 or double click: fit to the pane")
        for bar in (self.horizontalScrollBar(), self.verticalScrollBar()):
            bar.valueChanged.connect(lambda _v: self._push())

    def set_image(self, rgb8: np.ndarray) -> None:
        self.rgb8 = np.ascontiguousarray(rgb8)
        h, w, _ = self.rgb8.shape
        img = QImage(self.rgb8.data, w, h, 3 * w, QImage.Format.Format_RGB888).copy()
        size_changed = self._item.pixmap().size().toTuple() != (w, h)
        self._item.setPixmap(QPixmap.fromImage(img))
        if size_changed:
            self.scene().setSceneRect(0, 0, w, h)
        if self.fitted and size_changed:
            self.fit()

    def fit(self) -> None:
        """Fill the pane with the whole image (and let the linked views do the same)."""
        self.fitted = True
        if not self._item.pixmap().isNull():
            self._syncing = True  # each view fits itself: nothing to push
            try:
                # Not fitInView: it keeps a margin of 2 px on every side. A hair under the exact scale, so
                # that rounding shows no scroll bar.
                port, rect = self.viewport().rect(), self._item.boundingRect()
                scale = min(port.width() / rect.width(), port.height() / rect.height()) * (1.0 - 1e-6)
                self.setTransform(QTransform.fromScale(scale, scale))
                self.centerOn(rect.center())
            finally:
                self._syncing = False
        for other in self._linked:
            if not other.fitted:
                other.fit()

    def actual_size(self) -> None:
        """One image pixel on one screen pixel, around the point in the pane's centre (the linked views
        follow)."""
        centre = self.mapToScene(self.viewport().rect().center())
        self.fitted = False
        scale = 1.0 / self.devicePixelRatioF()
        self._syncing = True  # pushed once, below, with the scroll position that goes with it
        try:
            self.setTransform(QTransform.fromScale(scale, scale))
            self.centerOn(centre)
        finally:
            self._syncing = False
        self._push()

    def keyPressEvent(self, event: QKeyEvent) -> None:  # noqa: N802
        key = event.key()
        if key == Qt.Key.Key_1:
            self.actual_size()
        elif key in (Qt.Key.Key_F, Qt.Key.Key_0):
            self.fit()
        else:
            super().keyPressEvent(event)

    def resizeEvent(self, event) -> None:  # noqa: N802
        super().resizeEvent(event)
        if self.fitted:
            self.fit()

    def mouseDoubleClickEvent(self, event) -> None:  # noqa: N802
        self.fit()

    def mousePressEvent(self, event) -> None:  # noqa: N802
        self.fitted = False  # a pan: the user chooses the view from here on
        super().mousePressEvent(event)

    def zoom(self, factor: float) -> None:
        self.fitted = False
        self.scale(factor, factor)
        self._push()

    def wheelEvent(self, event: QWheelEvent) -> None:  # noqa: N802
        self.zoom(1.25 if event.angleDelta().y() > 0 else 0.8)

    def link(self, other: ImageView) -> None:
        """Follow each other's zoom and pan."""
        self._linked.append(other)
        other._linked.append(self)

    def _push(self) -> None:
        if self._syncing:
            return
        self.view_changed.emit()
        for other in self._linked:
            other._follow(
                self.transform(), self.horizontalScrollBar().value(), self.verticalScrollBar().value()
            )

    def _follow(self, transform: QTransform, h: int, v: int) -> None:
        self._syncing = True
        self.fitted = False
        try:
            self.setTransform(transform)
            self.horizontalScrollBar().setValue(h)
            self.verticalScrollBar().setValue(v)
        finally:
            self._syncing = False
