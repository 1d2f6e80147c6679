"""Rows for the scene's fields, used by the generated forms (:mod:`app.editors.schema_form`): three spin
boxes per vector, a colour swatch with three spin boxes and a strength slider per emitted RGB value, a check
box per flag, a *uniform* switch with one or three spin boxes for a field that is one number or three (a
mesh's ``scale``; numbers use :class:`app.editors.params.FloatRow`). Each emits ``edited(field, value)``;
``set_value`` shows a value without emitting."""

from __future__ import annotations

from typing import Any

from PySide6.QtCore import Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QCheckBox,
    QColorDialog,
    QDoubleSpinBox,
    QHBoxLayout,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from app.editors.params import FloatRow
from core.brdf import Param

COORDINATE_LIMIT = 1e6
"""Spin-box range of positions and edges (scene units); the schema itself only asks for finite numbers."""
EMISSION_LIMIT = 1e6


class _TripleSpins:
    """``value()`` / ``set_value()`` over three spin boxes ``self.spins`` (setting emits nothing)."""

    spins: list[QDoubleSpinBox]

    def value(self) -> tuple[float, float, float]:
        return tuple(float(s.value()) for s in self.spins)  # type: ignore[return-value]

    def set_value(self, value: Any) -> None:
        for s, v in zip(self.spins, value, strict=True):
            s.blockSignals(True)
            s.setValue(float(v))
            s.blockSignals(False)


class Vec3Row(_TripleSpins, QWidget):
    """Three spin boxes (x, y, z). Emits ``edited(field, (x, y, z))``."""

    edited = Signal(str, object)

    def __init__(self, field: str, unit: str = "", parent: QWidget | None = None):
        super().__init__(parent)
        self.field = field
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        self.spins: list[QDoubleSpinBox] = []
        for axis in "xyz":
            s = QDoubleSpinBox()
            s.setRange(-COORDINATE_LIMIT, COORDINATE_LIMIT)
            s.setDecimals(3)
            s.setSingleStep(0.1)
            s.setKeyboardTracking(False)
            s.setPrefix(f"{axis} ")
            if unit:
                s.setSuffix(f" {unit}")
            s.setMinimumWidth(70)
            s.valueChanged.connect(lambda _v: self.edited.emit(self.field, self.value()))
            layout.addWidget(s, 1)
            self.spins.append(s)


class EmissionRow(_TripleSpins, QWidget):
    """An emitted linear-RGB value (radiance or intensity, unbounded): a swatch showing its colour (the value
    divided by its largest channel), three spin boxes, and a log *strength* slider (the largest channel).
    Picking a colour keeps the strength; moving the strength keeps the colour. Emits
    ``edited(field, (r, g, b))`` and ``released()`` when a drag ends."""

    edited = Signal(str, object)
    released = Signal()

    def __init__(self, field: str, unit: str = "", parent: QWidget | None = None):
        super().__init__(parent)
        self.field = field
        self.swatch = QPushButton()
        self.swatch.setFixedWidth(36)
        self.swatch.setToolTip("Pick the colour (the strength is kept)")
        self.swatch.clicked.connect(self.pick)
        self.spins: list[QDoubleSpinBox] = []
        top = QHBoxLayout()
        top.setContentsMargins(0, 0, 0, 0)
        top.addWidget(self.swatch)
        for channel in ("red", "green", "blue"):
            s = QDoubleSpinBox()
            s.setRange(0.0, EMISSION_LIMIT)
            s.setDecimals(3)
            s.setSingleStep(0.1)
            s.setKeyboardTracking(False)
            s.setToolTip(f"{field}: {channel}" + (f" ({unit})" if unit else ""))
            s.setMinimumWidth(64)
            s.valueChanged.connect(self._spin_changed)
            top.addWidget(s, 1)
            self.spins.append(s)
        self.strength = FloatRow(Param("strength", 1.0, 1e-3, 1e4, unit=unit, label="strength", log=True))
        self.strength.setToolTip("The largest channel; the colour is kept")
        self.strength.edited.connect(lambda _n, v: self._scale_to(v))
        self.strength.released.connect(self.released)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(top)
        layout.addWidget(self.strength)

    def set_value(self, value: Any) -> None:
        super().set_value(value)
        self.strength.set_value(max(self.value()))
        self._paint()

    def colour(self) -> tuple[float, float, float]:
        """The value divided by its largest channel (white when it is black)."""
        top = max(self.value())
        return (1.0, 1.0, 1.0) if top <= 0.0 else tuple(v / top for v in self.value())  # type: ignore[return-value]

    def _paint(self) -> None:
        r, g, b = (c ** (1 / 2.2) for c in self.colour())
        self.swatch.setStyleSheet(
            f"background-color: {QColor.fromRgbF(r, g, b).name()}; border: 1px solid #666;"
        )

    def _emit(self, value: tuple[float, float, float]) -> None:
        self.set_value(value)
        self.edited.emit(self.field, self.value())

    def _spin_changed(self, _v: float) -> None:
        self.strength.set_value(max(self.value()))
        self._paint()
        self.edited.emit(self.field, self.value())
        self.released.emit()

    def _scale_to(self, strength: float) -> None:
        self._emit(tuple(c * strength for c in self.colour()))  # type: ignore[arg-type]

    def pick(self) -> None:
        r, g, b = (c ** (1 / 2.2) for c in self.colour())
        chosen = QColorDialog.getColor(QColor.fromRgbF(r, g, b), self, self.field)
        if chosen.isValid():
            self.set_colour(chosen)

    def set_colour(self, colour: QColor) -> None:
        """Apply a display colour (gamma 2.2) as the chromaticity, keeping the strength."""
        linear = [c**2.2 for c in (colour.redF(), colour.greenF(), colour.blueF())]
        top = max(linear)
        strength = max(max(self.value()), 0.0) or 1.0
        if top > 0.0:
            self._emit(tuple(strength * c / top for c in linear))  # type: ignore[arg-type]
        else:
            self._emit((0.0, 0.0, 0.0))
        self.released.emit()


class NumberOrVec3Row(_TripleSpins, QWidget):
    """A field that is one number or three (``scale: tuple[float, ...] | float``): a *uniform* check box and
    three spin boxes (x, y, z), of which only the first is editable while uniform. Emits ``edited(field,
    value)`` with a float while uniform, a 3-tuple otherwise. Switching *uniform* off changes nothing until a
    spin box is edited (three equal numbers mean the same as one); switching it on makes every axis the
    first one's value."""

    edited = Signal(str, object)

    def __init__(self, field: str, lo: float, hi: float, parent: QWidget | None = None):
        super().__init__(parent)
        self.field = field
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        self.uniform = QCheckBox("uniform")
        self.uniform.setToolTip("One number for every axis; untick for a different number per axis")
        self.uniform.toggled.connect(self._uniform_toggled)
        layout.addWidget(self.uniform)
        self.spins: list[QDoubleSpinBox] = []
        decimals = 4
        if lo > 0.0:  # a spin box rounds its minimum to its decimals: 1e-6 would become 0, outside the schema
            lo = max(lo, 10.0**-decimals)
        for axis in "xyz":
            s = QDoubleSpinBox()
            s.setRange(lo, hi)
            s.setDecimals(decimals)
            s.setStepType(QDoubleSpinBox.StepType.AdaptiveDecimalStepType)
            s.setKeyboardTracking(False)
            s.setPrefix(f"{axis} ")
            s.setMinimumWidth(70)
            s.valueChanged.connect(self._spin_changed)
            layout.addWidget(s, 1)
            self.spins.append(s)

    def value(self) -> float | tuple[float, float, float]:  # type: ignore[override]
        v = super().value()
        return v[0] if self.uniform.isChecked() else v

    def set_value(self, value: Any) -> None:
        uniform = isinstance(value, int | float)
        super().set_value((value,) * 3 if uniform else value)
        self.uniform.blockSignals(True)
        self.uniform.setChecked(uniform)
        self.uniform.blockSignals(False)
        self._enable()

    def _enable(self) -> None:
        for s in self.spins[1:]:
            s.setEnabled(not self.uniform.isChecked())

    def _spin_changed(self, _v: float) -> None:
        if self.uniform.isChecked():
            super().set_value((self.spins[0].value(),) * 3)  # the others show the same number
        self.edited.emit(self.field, self.value())

    def _uniform_toggled(self, on: bool) -> None:
        self._enable()
        if on:
            self._spin_changed(self.spins[0].value())


class CheckRow(QCheckBox):
    """A check box whose ``edited`` signal carries the field's name."""

    edited = Signal(str, object)

    def __init__(self, field: str, text: str):
        super().__init__(text)
        self.field = field
        self.toggled.connect(lambda on: self.edited.emit(field, bool(on)))

    def set_value(self, value: Any) -> None:
        self.blockSignals(True)
        self.setChecked(bool(value))
        self.blockSignals(False)
