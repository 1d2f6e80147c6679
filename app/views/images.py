"""Image views for renders: zoom with the wheel, pan by dragging, and views that follow each other."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QImage, QPixmap, QTransform, QWheelEvent
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
        for bar in (self.horizontalScrollBar(), self.verticalScrollBar()):
            bar.valueChanged.connect(lambda _v: self._push())

    def set_image(self, rgb8: np.ndarray) -> None:
        self.rgb8 = np.ascontiguousarray(rgb8)
        h, w, _ = self.rgb8.shape
        img = QImage(self.rgb8.data, w, h, 3 * w, QImage.Format.Format_RGB888).copy()
        first = self._item.pixmap().isNull()
        self._item.setPixmap(QPixmap.fromImage(img))
        self.scene().setSceneRect(0, 0, w, h)
        if first:
            self.fitInView(self._item, Qt.AspectRatioMode.KeepAspectRatio)
            self._push()

    def zoom(self, factor: float) -> None:
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
        try:
            self.setTransform(transform)
            self.horizontalScrollBar().setValue(h)
            self.verticalScrollBar().setValue(v)
        finally:
            self._syncing = False
