"""Property pages for the scene's lights, camera and environment, generated from the scene schema
(:class:`app.editors.schema_form.SchemaForm`), and the stack that shows them in place of the material editor
while one of them is selected.

Edits go through the document (:meth:`app.document.Document.set_field`), which validates them with the schema:
a refused value shows the schema's reason under the fields, and the fields show the document again.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QComboBox,
    QDockWidget,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from app.document import Document
from app.editors.scene_tree import light_label
from app.editors.schema_form import SchemaForm
from core.errors import BrdfStudioError
from core.scene import Camera, ConstantEnvironment, MapEnvironment, PointLight, QuadLight


class EnvironmentPage(QWidget):
    """The environment's type (none, constant, map), then the generated form of that type."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.kind = QComboBox()
        self.kind.addItem("none", None)
        self.kind.addItem("constant colour", "constant")
        self.kind.addItem("HDR map (lat-long EXR)", "map")
        self.constant = SchemaForm(ConstantEnvironment, "Constant sky")
        self.map = SchemaForm(MapEnvironment, "Environment map")
        self.map_path = QLabel("")
        self.map_path.setWordWrap(True)
        self.map_button = QPushButton("Choose EXR ...")
        file_row = QHBoxLayout()
        file_row.addWidget(self.map_path, 1)
        file_row.addWidget(self.map_button)
        self.map.form.insertRow(1, "File", file_row)
        form = QFormLayout()
        form.addRow(QLabel("<b>Environment (light from infinity)</b>"))
        form.addRow("Type", self.kind)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(form)
        layout.addWidget(self.constant)
        layout.addWidget(self.map)
        self.rows = {**self.constant.rows, **self.map.rows}

    def show_values(self, env: ConstantEnvironment | MapEnvironment | None) -> None:
        self.kind.setCurrentIndex(self.kind.findData(env.type if env else None))
        self.constant.setVisible(isinstance(env, ConstantEnvironment))
        self.map.setVisible(isinstance(env, MapEnvironment))
        if isinstance(env, ConstantEnvironment):
            self.constant.show_values(env)
        elif isinstance(env, MapEnvironment):
            self.map.show_values(env)
        self.map_path.setText(Path(env.path).name if isinstance(env, MapEnvironment) else "")
        self.map_path.setToolTip(env.path if isinstance(env, MapEnvironment) else "")


class SceneItemEditor(QWidget):
    """Edits the selected light, the camera or the environment of the document. Emits ``error(str)`` with the
    schema's reason when the document refuses a value. ``view_camera()`` gives the viewport's current view
    (the camera page's *Use the view* button); ``ask_environment_map`` returns the path of an EXR file, or
    ``None`` (replaceable; the default opens a file dialog)."""

    error = Signal(str)

    def __init__(
        self, document: Document, view_camera: Callable[[], dict] | None = None, parent: QWidget | None = None
    ):
        super().__init__(parent)
        self.document = document
        self.view_camera = view_camera
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

        self.empty_page = QLabel("Select a light, the camera or the environment in the scene tree.")
        self.empty_page.setWordWrap(True)
        self.point_page = self._connect(SchemaForm(PointLight, "Point light"), self._light_setter)
        self.quad_page = self._connect(SchemaForm(QuadLight, "Quad light"), self._light_setter)
        self.quad_area = QLabel("")
        self.quad_page.form.addRow("Area", self.quad_area)
        self.camera_page = self._connect(SchemaForm(Camera, "Camera (pinhole)"), document.set_camera_field)
        self.view_button = QPushButton("Use the viewport's view")
        self.view_button.setToolTip(
            "The camera becomes the Scene tab's current view (moving the view does too)"
        )
        self.view_button.clicked.connect(self.use_view)
        self.camera_page.form.addRow(self.view_button)
        self.environment_page = EnvironmentPage()
        for form in (self.environment_page.constant, self.environment_page.map):
            self._connect(form, document.set_environment_field)
        self.environment_page.kind.activated.connect(self._environment_kind_chosen)
        self.environment_page.map_button.clicked.connect(
            lambda: self._environment_kind_chosen(self.environment_page.kind.findData("map"))
        )
        self.environment_kind = self.environment_page.kind
        self.stack = QStackedWidget()
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

        document.selection_changed.connect(self.refresh)
        for name in ("lights", "camera", "environment"):
            document.events[name].connect(lambda _items: self.refresh())
        self.refresh()

    def _connect(self, form: SchemaForm, setter: Callable[[str, Any], None]) -> SchemaForm:
        form.edited.connect(lambda field, value: self._guard(setter, field, value))
        form.released.connect(self.document.end_merge)
        return form

    def _light_setter(self, field: str, value: Any) -> None:
        item = self.document.selected_item
        if item is not None and item[0] == "light":
            self.document.set_light_field(item[1], field, value)

    # ---- document -> widgets ---------------------------------------------------------------------------
    def current_page(self) -> QWidget:
        return self.stack.currentWidget()

    def refresh(self) -> None:
        doc = self.document
        item = doc.selected_item
        self.delete_button.setEnabled(item is not None and item[0] == "light")
        page: QWidget
        if item is None:
            page = self.empty_page
        elif item[0] == "light":
            light = doc.scene.lights[item[1]]
            page = self.quad_page if isinstance(light, QuadLight) else self.point_page
            page.heading.setText(f"<b>{light_label(light, item[1]).capitalize()}</b>")
            page.show_values(light)
            if isinstance(light, QuadLight):
                e1, e2 = light.edge1, light.edge2
                cross = (
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                )
                self.quad_area.setText(f"{math.sqrt(sum(c * c for c in cross)):.4g} (|edge1 x edge2|)")
        elif item[0] == "camera":
            page = self.camera_page
            page.show_values(doc.scene.camera)
        else:
            page = self.environment_page
            page.show_values(doc.scene.environment)
        self.stack.setCurrentWidget(page)

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

    def use_view(self) -> None:
        if self.view_camera is not None:
            self._guard(self.document.set_camera, self.view_camera(), "Camera from the view", None)

    def delete_selected_light(self) -> None:
        item = self.document.selected_item
        if item is not None and item[0] == "light":
            self._guard(self.document.remove_light, item[1])

    def _environment_kind_chosen(self, index: int) -> None:
        kind = self.environment_page.kind.itemData(index)
        if kind == "map":
            path = self.ask_environment_map()
            if path:
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

    def __init__(self, document: Document, material_page: QWidget, item_editor: SceneItemEditor,
                 dock: QDockWidget | None = None, parent: QWidget | None = None):  # fmt: skip
        super().__init__(parent)
        self.document = document
        self.material_page = material_page
        self.item_editor = item_editor
        self.dock = dock
        self.addWidget(material_page)
        self.addWidget(item_editor)
        document.selection_changed.connect(self.follow_selection)
        self.follow_selection()

    def follow_selection(self) -> None:
        item = self.document.selected_item
        self.setCurrentWidget(self.material_page if item is None else self.item_editor)
        if self.dock is not None:
            self.dock.setWindowTitle("Material" if item is None else self.TITLES[item[0]])
