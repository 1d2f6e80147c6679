"""Property pages for the scene's lights, camera and environment, and the stack that shows them in place of
the material editor while one of them is selected.

Every field of the scene format (:mod:`core.scene`) has a row: three spin boxes per vector, a slider with a
spin box per number (the rows of :mod:`app.editors.params`), a colour swatch with three spin boxes and a
strength slider per emitted RGB value. Edits go through the document, which validates them with the scene
schema: a refused value shows the schema's reason under the fields, and the fields show the document again.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from PySide6.QtCore import Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QCheckBox,
    QColorDialog,
    QComboBox,
    QDockWidget,
    QDoubleSpinBox,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from app.editors.params import FloatRow
from app.editors.scene_tree import light_label
from app.state import Document
from core.errors import BrdfStudioError
from core.model import Param

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


class _Page(QWidget):
    """A form of rows; ``edited(field, value)`` from any row, ``released()`` when a drag ends."""

    edited = Signal(str, object)
    released = Signal()

    def __init__(self, title: str, parent: QWidget | None = None):
        super().__init__(parent)
        self.form = QFormLayout(self)
        self.form.setContentsMargins(0, 0, 0, 0)
        self.heading = QLabel(f"<b>{title}</b>")
        self.form.addRow(self.heading)
        self.rows: dict[str, Any] = {}

    def add(self, field: str, label: str, row: QWidget, tip: str = "") -> None:
        row.edited.connect(self.edited)  # type: ignore[attr-defined]
        if hasattr(row, "released"):
            row.released.connect(self.released)
        text = QLabel(label)
        if tip:
            text.setToolTip(tip)
            row.setToolTip(tip)
        self.form.addRow(text, row)
        self.rows[field] = row

    def show_values(self, values: dict[str, Any]) -> None:
        for field, row in self.rows.items():
            if field in values:
                row.set_value(values[field])


class _Check(QCheckBox):
    edited = Signal(str, object)

    def __init__(self, field: str, text: str):
        super().__init__(text)
        self.field = field
        self.toggled.connect(lambda on: self.edited.emit(field, bool(on)))

    def set_value(self, value: Any) -> None:
        self.blockSignals(True)
        self.setChecked(bool(value))
        self.blockSignals(False)


def _float_row(field: str, lo: float, hi: float, unit: str = "", log: bool = False) -> FloatRow:
    """A slider + spin box whose ``edited`` signal carries the scene field's name."""
    return FloatRow(Param(field, lo, lo, hi, unit=unit, label=field, log=log))


class SceneItemEditor(QWidget):
    """Edits the selected light, the camera or the environment of the document. Emits ``error(str)`` with
    the schema's reason when the document refuses a value. ``ask_environment_map`` returns the path of an
    EXR file, or ``None`` (replaceable; the default opens a file dialog)."""

    error = Signal(str)

    def __init__(self, document: Document, parent: QWidget | None = None):
        super().__init__(parent)
        self.document = document
        self.ask_environment_map: Callable[[], str | None] = self._ask_environment_map
        self.add_point_button = QPushButton("Add point light")
        self.add_quad_button = QPushButton("Add quad light")
        self.delete_button = QPushButton("Delete light")
        self.delete_button.setToolTip("Delete the selected light (Delete)")
        self.add_point_button.clicked.connect(lambda: self._guard(document.add_light, "point"))
        self.add_quad_button.clicked.connect(lambda: self._guard(document.add_light, "quad"))
        self.delete_button.clicked.connect(self.delete_selected_light)
        buttons = QHBoxLayout()
        for b in (self.add_point_button, self.add_quad_button, self.delete_button):
            buttons.addWidget(b)

        self.message = QLabel("")
        self.message.setWordWrap(True)
        self.message.setStyleSheet("color: #c62828")
        self.stack = QStackedWidget()
        self.empty_page = QLabel("Select a light, the camera or the environment in the scene tree.")
        self.empty_page.setWordWrap(True)
        self.point_page = self._point_page()
        self.quad_page = self._quad_page()
        self.camera_page = self._camera_page()
        self.environment_page = self._environment_page()
        for page in (
            self.empty_page,
            self.point_page,
            self.quad_page,
            self.camera_page,
            self.environment_page,
        ):
            self.stack.addWidget(page)
        layout = QVBoxLayout(self)
        layout.addLayout(buttons)
        layout.addWidget(self.stack)
        layout.addWidget(self.message)
        layout.addStretch(1)

        ev = document.events
        ev.selection_changed.connect(self.refresh)
        ev.lights_changed.connect(self.refresh)
        ev.camera_changed.connect(self.refresh)
        self.refresh()

    # ---- pages -----------------------------------------------------------------------------------------
    def _connect(self, page: _Page, setter: Callable[[str, Any], None]) -> _Page:
        page.edited.connect(lambda field, value: self._guard(setter, field, value))
        page.released.connect(self.document.end_merge)
        return page

    def _light_setter(self, field: str, value: Any) -> None:
        item = self.document.selected_item
        if item is None or item[0] != "light":
            return
        self.document.set_light_field(item[1], field, value)

    def _point_page(self) -> _Page:
        page = _Page("Point light")
        page.add("position", "Position", Vec3Row("position"), "Where the light is (scene units)")
        page.add(
            "intensity",
            "Intensity",
            EmissionRow("intensity", "W/sr"),
            "Radiant intensity in W/sr, linear RGB (irradiance at distance d is intensity / d^2)",
        )
        return self._connect(page, self._light_setter)

    def _quad_page(self) -> _Page:
        page = _Page("Quad light")
        page.add("corner", "Corner", Vec3Row("corner"), "One corner of the parallelogram")
        page.add("edge1", "Edge 1", Vec3Row("edge1"), "The first edge from the corner")
        page.add(
            "edge2", "Edge 2", Vec3Row("edge2"), "The second edge; light leaves on the side of edge1 x edge2"
        )
        page.add(
            "radiance", "Radiance", EmissionRow("radiance", "W/(m^2 sr)"), "Emitted radiance, linear RGB"
        )
        page.add("two_sided", "", _Check("two_sided", "Two-sided (emits on both sides)"))
        self.quad_area = QLabel("")
        page.form.addRow("Area", self.quad_area)
        return self._connect(page, self._light_setter)

    def _camera_page(self) -> _Page:
        page = _Page("Camera (pinhole)")
        page.add("position", "Position", Vec3Row("position"), "Where the camera is")
        page.add("target", "Look at", Vec3Row("target"), "The point the camera looks at")
        page.add("up", "Up", Vec3Row("up"), "Which way is up in the image (need not be unit length)")
        page.add(
            "fov_deg",
            "Field of view",
            _float_row("fov_deg", 1.0, 179.0, "deg"),
            "Vertical field of view in degrees",
        )
        page.form.addRow(
            QLabel("Moving the view in the Scene tab moves this camera too (one undo step per move).")
        )
        return self._connect(page, self.document.set_camera_field)

    def _environment_page(self) -> _Page:
        page = _Page("Environment (light from infinity)")
        self.environment_kind = QComboBox()
        self.environment_kind.addItem("none", None)
        self.environment_kind.addItem("constant colour", "constant")
        self.environment_kind.addItem("HDR map (lat-long EXR)", "map")
        self.environment_kind.activated.connect(lambda i: self._environment_kind_chosen(i))
        page.form.addRow("Type", self.environment_kind)
        page.add(
            "radiance", "Radiance", EmissionRow("radiance", "W/(m^2 sr)"), "The sky's radiance, linear RGB"
        )
        self.map_path = QLabel("")
        self.map_path.setWordWrap(True)
        self.map_button = QPushButton("Choose EXR ...")
        self.map_button.clicked.connect(
            lambda: self._environment_kind_chosen(self.environment_kind.findData("map"))
        )
        row = QHBoxLayout()
        row.addWidget(self.map_path, 1)
        row.addWidget(self.map_button)
        page.form.addRow("File", row)
        page.add("scale", "Scale", _float_row("scale", 1e-3, 1e3, log=True), "Multiplies the map's radiance")
        page.add("rotate_deg", "Rotation", _float_row("rotate_deg", -180.0, 180.0, "deg"), "About +y")
        return self._connect(page, self.document.set_environment_field)

    # ---- document -> widgets ---------------------------------------------------------------------------
    def current_page(self) -> QWidget:
        return self.stack.currentWidget()

    def refresh(self) -> None:
        doc = self.document
        item = doc.selected_item
        self.delete_button.setEnabled(item is not None and item[0] == "light")
        if item is None:
            self.stack.setCurrentWidget(self.empty_page)
            return
        kind, index = item
        if kind == "light":
            light = doc.lights()[index]
            page = self.quad_page if light.get("type") == "quad" else self.point_page
            page.heading.setText(f"<b>{light_label(light, index).capitalize()}</b>")
            page.show_values(light)
            if page is self.quad_page:
                e1, e2 = light["edge1"], light["edge2"]
                cross = (
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                )
                self.quad_area.setText(f"{math.sqrt(sum(c * c for c in cross)):.4g} (|edge1 x edge2|)")
        elif kind == "camera":
            page = self.camera_page
            page.show_values(doc.camera())
        else:
            page = self.environment_page
            env = doc.environment()
            kind_index = self.environment_kind.findData(env.get("type") if env else None)
            self.environment_kind.setCurrentIndex(kind_index)
            if env:
                page.show_values(env)
            is_map = bool(env) and env.get("type") == "map"
            is_constant = bool(env) and env.get("type") == "constant"
            for field in ("scale", "rotate_deg"):
                self._show_row(page, page.rows[field], is_map)
            self._show_row(page, page.rows["radiance"], is_constant)
            self.map_path.setText(Path(env["path"]).name if is_map else "")
            self.map_path.setToolTip(env["path"] if is_map else "")
        self.stack.setCurrentWidget(page)

    @staticmethod
    def _show_row(page: _Page, row: QWidget, visible: bool) -> None:
        """Rows that do not apply to the environment's type are hidden."""
        page.form.setRowVisible(row, visible)

    # ---- widgets -> document ---------------------------------------------------------------------------
    def _guard(self, fn: Callable[..., Any], *args: Any) -> bool:
        """Apply an edit; a refusal shows the reason and puts the document's values back in the fields."""
        try:
            fn(*args)
        except (BrdfStudioError, KeyError) as exc:
            message = str(exc).strip("'\"")
            self.message.setText(message)
            self.refresh()
            self.error.emit(message)
            return False
        self.message.setText("")
        return True

    def delete_selected_light(self) -> None:
        item = self.document.selected_item
        if item is not None and item[0] == "light":
            self._guard(self.document.remove_light, item[1])

    def _environment_kind_chosen(self, index: int) -> None:
        kind = self.environment_kind.itemData(index)
        if kind == "map":
            path = self.ask_environment_map()
            if not path:
                self.refresh()
                return
            self._guard(self.document.set_environment_kind, "map", path)
        else:
            self._guard(self.document.set_environment_kind, kind)
        self.refresh()

    def _ask_environment_map(self) -> str | None:
        from PySide6.QtWidgets import QFileDialog

        start = str(self.document.path.parent) if self.document.path else str(Path.cwd())
        chosen, _ = QFileDialog.getOpenFileName(self, "Environment map", start, "OpenEXR (*.exr)")
        return chosen or None


class PropertiesStack(QStackedWidget):
    """The right dock's content: the material editor, or the scene-item editor while a light, the camera or
    the environment is selected (the dock's title says which)."""

    TITLES = {"light": "Light", "camera": "Camera", "environment": "Environment"}

    def __init__(
        self,
        document: Document,
        material_page: QWidget,
        item_editor: SceneItemEditor,
        dock: QDockWidget | None = None,
        parent: QWidget | None = None,
    ):
        super().__init__(parent)
        self.document = document
        self.material_page = material_page
        self.item_editor = item_editor
        self.dock = dock
        self.addWidget(material_page)
        self.addWidget(item_editor)
        document.events.selection_changed.connect(self.follow_selection)
        self.follow_selection()

    def follow_selection(self) -> None:
        item = self.document.selected_item
        self.setCurrentWidget(self.material_page if item is None else self.item_editor)
        if self.dock is not None:
            self.dock.setWindowTitle("Material" if item is None else self.TITLES[item[0]])
