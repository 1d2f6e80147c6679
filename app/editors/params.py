"""The property editor generated from a model's parameter list: sliders with spin boxes (log-scaled where
the parameter says so), colour pickers with per-channel spin boxes, check boxes for flags."""

from __future__ import annotations

import math
from collections.abc import Mapping

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QCheckBox,
    QColorDialog,
    QDoubleSpinBox,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSlider,
    QWidget,
)

from core.brdf import Model, Param, ParamValue

SLIDER_STEPS = 1000


class SliderMapping:
    """Maps a parameter value to a slider position in ``[0, SLIDER_STEPS]`` (logarithmic when declared)."""

    def __init__(self, param: Param):
        self.lo, self.hi = float(param.lo), float(param.hi)
        self.log = bool(param.log) and self.lo > 0.0

    def to_slider(self, value: float) -> int:
        if self.hi <= self.lo or not math.isfinite(value):
            return 0
        value = min(max(value, self.lo), self.hi)
        if self.log:
            t = (math.log(value) - math.log(self.lo)) / (math.log(self.hi) - math.log(self.lo))
        else:
            t = (value - self.lo) / (self.hi - self.lo)
        return int(round(min(max(t, 0.0), 1.0) * SLIDER_STEPS))

    def from_slider(self, pos: int) -> float:
        t = pos / SLIDER_STEPS
        if self.log:
            v = math.exp(math.log(self.lo) + t * (math.log(self.hi) - math.log(self.lo)))
        else:
            v = self.lo + t * (self.hi - self.lo)
        return min(max(v, self.lo), self.hi)


def _decimals(param: Param) -> int:
    span = max(abs(param.hi), abs(param.lo), 1e-12)
    small = param.lo if param.log and param.lo > 0 else span / 1000.0
    return int(min(6, max(2, math.ceil(-math.log10(small)) + 2)))


class FloatRow(QWidget):
    """Slider + spin box for one float parameter."""

    edited = Signal(str, object)
    released = Signal()

    def __init__(self, param: Param, parent: QWidget | None = None):
        super().__init__(parent)
        self.param = param
        self.mapping = SliderMapping(param)
        self.slider = QSlider(Qt.Orientation.Horizontal)
        self.slider.setRange(0, SLIDER_STEPS)
        self.spin = QDoubleSpinBox()
        self.spin.setRange(param.lo, param.hi)
        self.spin.setDecimals(_decimals(param))
        self.spin.setStepType(QDoubleSpinBox.StepType.AdaptiveDecimalStepType)
        self.spin.setKeyboardTracking(False)
        self.spin.setMinimumWidth(90)
        if param.unit:
            self.spin.setSuffix(f" {param.unit}")
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.slider, 1)
        layout.addWidget(self.spin)
        self.slider.valueChanged.connect(self._slider_moved)
        self.slider.sliderReleased.connect(self.released)
        self.spin.valueChanged.connect(self._spin_changed)

    def set_value(self, value: float) -> None:
        for w, v in ((self.spin, value), (self.slider, self.mapping.to_slider(value))):
            w.blockSignals(True)
            w.setValue(v)
            w.blockSignals(False)

    def value(self) -> float:
        return float(self.spin.value())

    def _slider_moved(self, pos: int) -> None:
        v = self.mapping.from_slider(pos)
        self.spin.blockSignals(True)
        self.spin.setValue(v)
        self.spin.blockSignals(False)
        self.edited.emit(self.param.name, float(self.spin.value()))

    def _spin_changed(self, v: float) -> None:
        self.slider.blockSignals(True)
        self.slider.setValue(self.mapping.to_slider(v))
        self.slider.blockSignals(False)
        self.edited.emit(self.param.name, float(v))
        self.released.emit()


class ColorRow(QWidget):
    """A swatch that opens a colour dialog (when the channels live in [0, 1]) and three spin boxes."""

    edited = Signal(str, object)
    released = Signal()

    def __init__(self, param: Param, parent: QWidget | None = None):
        super().__init__(parent)
        self.param = param
        self.swatch = QPushButton()
        self.swatch.setFixedWidth(36)
        self.swatch.setToolTip("Pick a colour (linear RGB)")
        self.spins = []
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.swatch)
        for channel in "RGB":
            s = QDoubleSpinBox()
            s.setRange(param.lo, param.hi)
            s.setDecimals(3)
            s.setSingleStep(0.01)
            s.setKeyboardTracking(False)
            s.setToolTip(f"{param.label or param.name}: {'red green blue'.split()['RGB'.index(channel)]}")
            s.setMinimumWidth(56)
            s.valueChanged.connect(self._spin_changed)
            self.spins.append(s)
            layout.addWidget(s, 1)
        self.pickable = param.lo <= 0.0 and param.hi >= 1.0
        self.swatch.setEnabled(self.pickable)
        self.swatch.clicked.connect(self.pick)

    def value(self) -> tuple[float, float, float]:
        return tuple(float(s.value()) for s in self.spins)  # type: ignore[return-value]

    def set_value(self, value: ParamValue) -> None:
        vals = value if isinstance(value, tuple) else (value, value, value)
        for s, v in zip(self.spins, vals, strict=True):
            s.blockSignals(True)
            s.setValue(float(v))
            s.blockSignals(False)
        self._paint_swatch()

    def _paint_swatch(self) -> None:
        r, g, b = (min(max(v, 0.0), 1.0) ** (1 / 2.2) for v in self.value())
        c = QColor.fromRgbF(r, g, b)
        self.swatch.setStyleSheet(f"background-color: {c.name()}; border: 1px solid #666;")

    def _spin_changed(self, _v: float) -> None:
        self._paint_swatch()
        self.edited.emit(self.param.name, self.value())
        self.released.emit()

    def pick(self) -> None:
        r, g, b = (min(max(v, 0.0), 1.0) ** (1 / 2.2) for v in self.value())
        chosen = QColorDialog.getColor(
            QColor.fromRgbF(r, g, b), self, f"{self.param.label or self.param.name}"
        )
        if chosen.isValid():
            self.set_color(chosen)

    def set_color(self, colour: QColor) -> None:
        """Apply a display (sRGB-ish, gamma 2.2) colour as linear RGB."""
        linear = tuple(c**2.2 for c in (colour.redF(), colour.greenF(), colour.blueF()))
        self.set_value(linear)  # type: ignore[arg-type]
        self.edited.emit(self.param.name, self.value())
        self.released.emit()


class BoolRow(QCheckBox):
    edited = Signal(str, object)
    released = Signal()

    def __init__(self, param: Param, parent: QWidget | None = None):
        super().__init__(parent)
        self.param = param
        self.toggled.connect(
            lambda on: (self.edited.emit(param.name, 1.0 if on else 0.0), self.released.emit())
        )

    def set_value(self, value: ParamValue) -> None:
        self.blockSignals(True)
        self.setChecked(bool(value))
        self.blockSignals(False)

    def value(self) -> float:
        return 1.0 if self.isChecked() else 0.0


class ParamEditor(QWidget):
    """Rows for every parameter of ``model``. Emits ``value_edited(name, value)`` on user edits and
    ``edit_finished()`` when a drag ends (one undo step per drag)."""

    value_edited = Signal(str, object)
    edit_finished = Signal()

    def __init__(self, model: Model, parent: QWidget | None = None):
        super().__init__(parent)
        self.model = model
        self.rows: dict[str, FloatRow | ColorRow | BoolRow] = {}
        form = QFormLayout(self)
        form.setContentsMargins(0, 0, 0, 0)
        if not model.params:
            form.addRow(QLabel("This model has no parameters."))
        for p in model.params:
            row: FloatRow | ColorRow | BoolRow
            if p.kind == "color":
                row = ColorRow(p)
            elif p.kind == "bool":
                row = BoolRow(p)
            else:
                row = FloatRow(p)
            row.edited.connect(self.value_edited)
            row.released.connect(self.edit_finished)
            label = QLabel(p.label or p.name)
            tip = (
                f"{p.name}: {p.range_text()}"
                + (" (log scale)" if p.log else "")
                + (f"\n{p.doc}" if p.doc else "")
            )
            label.setToolTip(tip)
            row.setToolTip(tip)
            form.addRow(label, row)
            self.rows[p.name] = row
        self.set_values(model.defaults())

    def set_values(self, values: Mapping[str, ParamValue]) -> None:
        """Show ``values`` without emitting edits."""
        for name, row in self.rows.items():
            if name in values:
                row.set_value(values[name])  # type: ignore[arg-type]
