"""Lit-sphere preview: the material on a sphere under one directional light the user drags."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QColor, QImage, QMouseEvent, QPainter, QPaintEvent, QPen
from PySide6.QtWidgets import QSizePolicy, QWidget

from app.view_data import light_from_disk, lit_sphere, to_srgb8
from core.brdf import BRDF


class SphereView(QWidget):
    """Shows ``lit_sphere`` of a BRDF; click or drag sets the light (emits ``light_dragged(x, y, z)``)."""

    light_dragged = Signal(float, float, float)

    def __init__(self, parent: QWidget | None = None, resolution: int = 128):
        super().__init__(parent)
        self.resolution = resolution
        self.image_rgb = np.zeros((resolution, resolution, 3), dtype=np.uint8)
        self.light = (0.5, 0.5, 0.7071)
        self.exposure = 1.0
        self._qimage: QImage | None = None
        self.setMinimumSize(120, 120)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setToolTip("Drag to move the light")

    def show_material(self, brdf: BRDF, light: tuple[float, float, float]) -> None:
        self.light = light
        radiance = lit_sphere(brdf, np.asarray(light), self.resolution)
        self.image_rgb = to_srgb8(radiance, self.exposure)
        h, w, _ = self.image_rgb.shape
        self._qimage = QImage(self.image_rgb.data, w, h, 3 * w, QImage.Format.Format_RGB888).copy()
        self.update()

    def _square(self) -> tuple[float, float, float]:
        side = min(self.width(), self.height())
        return (self.width() - side) / 2.0, (self.height() - side) / 2.0, float(side)

    def paintEvent(self, event: QPaintEvent) -> None:  # noqa: N802 (Qt name)
        p = QPainter(self)
        p.fillRect(self.rect(), QColor(30, 30, 30))
        x0, y0, side = self._square()
        if self._qimage is not None:  # a square of the widget's smaller side, centred: the whole sphere
            p.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform)
            p.drawImage(QRectF(x0, y0, side, side), self._qimage)
        lx, ly, _ = self.light
        cx, cy = x0 + side / 2 * (1 + lx), y0 + side / 2 * (1 - ly)
        p.setPen(QPen(QColor(255, 200, 0), 2))
        p.drawEllipse(QPointF(cx, cy), 5, 5)
        p.end()

    def disk_point(self, pos: QPointF) -> tuple[float, float]:
        x0, y0, side = self._square()
        return (pos.x() - x0) / side * 2 - 1, 1 - (pos.y() - y0) / side * 2

    def mousePressEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        self._drag(event)

    def mouseMoveEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        if event.buttons() & Qt.MouseButton.LeftButton:
            self._drag(event)

    def _drag(self, event: QMouseEvent) -> None:
        x, y = self.disk_point(event.position())
        self.light_dragged.emit(*light_from_disk(x, y))
