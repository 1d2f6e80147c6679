"""The incident direction editor: a disk to click or drag on (the projection ``(x, y)`` of the direction)
and two spin boxes to type the angles."""

from __future__ import annotations

import math

from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QColor, QMouseEvent, QPainter, QPaintEvent, QPen
from PySide6.QtWidgets import QDoubleSpinBox, QFormLayout, QHBoxLayout, QSizePolicy, QWidget

from app.view_data import direction_from_disk


class DirectionPad(QWidget):
    """The unit disk seen from above; the dot is the direction. Emits ``direction_dragged(theta, phi)``."""

    direction_dragged = Signal(float, float)

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.theta_deg = 30.0
        self.phi_deg = 0.0
        self.setMinimumSize(90, 90)
        self.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Preferred)
        self.setToolTip("Click or drag to set the incident direction (disk projection)")

    def set_direction(self, theta_deg: float, phi_deg: float) -> None:
        self.theta_deg, self.phi_deg = theta_deg, phi_deg
        self.update()

    def _disk(self) -> tuple[float, float, float]:
        side = min(self.width(), self.height()) - 8
        return self.width() / 2.0, self.height() / 2.0, side / 2.0

    def point_for(self, theta_deg: float, phi_deg: float) -> QPointF:
        cx, cy, r = self._disk()
        s = math.sin(math.radians(theta_deg))
        return QPointF(
            cx + r * s * math.cos(math.radians(phi_deg)), cy - r * s * math.sin(math.radians(phi_deg))
        )

    def paintEvent(self, event: QPaintEvent) -> None:  # noqa: N802
        p = QPainter(self)
        p.setRenderHint(QPainter.RenderHint.Antialiasing)
        cx, cy, r = self._disk()
        p.setPen(QPen(QColor(120, 120, 120), 1))
        p.setBrush(QColor(245, 245, 245))
        p.drawEllipse(QRectF(cx - r, cy - r, 2 * r, 2 * r))
        for deg in (30, 60):
            rr = r * math.sin(math.radians(deg))
            p.setBrush(Qt.BrushStyle.NoBrush)
            p.drawEllipse(QRectF(cx - rr, cy - rr, 2 * rr, 2 * rr))
        pt = self.point_for(self.theta_deg, self.phi_deg)
        p.setPen(QPen(QColor(200, 0, 0), 2))
        p.drawLine(QPointF(cx, cy), pt)
        p.setBrush(QColor(220, 0, 0))
        p.drawEllipse(pt, 4, 4)
        p.end()

    def mousePressEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        self._drag(event)

    def mouseMoveEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        if event.buttons() & Qt.MouseButton.LeftButton:
            self._drag(event)

    def _drag(self, event: QMouseEvent) -> None:
        cx, cy, r = self._disk()
        x = (event.position().x() - cx) / r
        y = -(event.position().y() - cy) / r
        self.direction_dragged.emit(*direction_from_disk(x, y))


class DirectionEditor(QWidget):
    """Pad + spin boxes bound to a document's exploration direction."""

    def __init__(self, document, parent: QWidget | None = None):
        super().__init__(parent)
        self.document = document
        self.pad = DirectionPad(self)
        self.theta = QDoubleSpinBox()
        self.theta.setRange(0.0, 89.9)
        self.theta.setDecimals(1)
        self.theta.setSuffix(" deg")
        self.theta.setKeyboardTracking(False)
        self.phi = QDoubleSpinBox()
        self.phi.setRange(0.0, 359.9)
        self.phi.setDecimals(1)
        self.phi.setWrapping(True)
        self.phi.setSuffix(" deg")
        self.phi.setKeyboardTracking(False)
        form = QFormLayout()
        form.addRow("theta", self.theta)
        form.addRow("phi", self.phi)
        layout = QHBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addWidget(self.pad, 1)
        layout.addLayout(form)
        self.pad.direction_dragged.connect(document.set_direction)
        self.theta.valueChanged.connect(lambda v: document.set_direction(v, self.phi.value()))
        self.phi.valueChanged.connect(lambda v: document.set_direction(self.theta.value(), v))
        document.direction_changed.connect(self.sync)
        self.sync()

    def sync(self) -> None:
        d = self.document
        for box, value in ((self.theta, d.theta_deg), (self.phi, d.phi_deg)):
            box.blockSignals(True)
            box.setValue(value)
            box.blockSignals(False)
        self.pad.set_direction(d.theta_deg, d.phi_deg)
