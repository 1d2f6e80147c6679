"""The selected object's placement, above the material editor: its mesh entry's transform (translation,
rotation) and smooth shading, generated from the scene schema (``core.scene.Transform``, ``Mesh.smooth``) like
the other scene pages. The groups of one file share their entry's transform (the heading says so)."""

from __future__ import annotations

from typing import Any

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QGroupBox, QVBoxLayout, QWidget

from app.document import Document
from app.editors.rows import CheckRow
from app.editors.schema_form import SchemaForm
from core.errors import BrdfStudioError
from core.scene import Transform


class ObjectEditor(QGroupBox):
    """Shown while an object is selected. Emits ``error(str)`` when the document refuses a value."""

    error = Signal(str)

    def __init__(self, document: Document, parent: QWidget | None = None):
        super().__init__("Object", parent)
        self.document = document
        self.form = SchemaForm(Transform, "")
        self.form.heading.hide()
        self.smooth = CheckRow("smooth", "Smooth shading (interpolated normals)")
        self.form.form.addRow("", self.smooth)
        self.form.edited.connect(lambda field, value: self._set(("transform", field), value))
        self.form.released.connect(document.end_merge)
        self.smooth.edited.connect(lambda field, value: self._set((field,), value))
        QVBoxLayout(self).addWidget(self.form)
        document.selection_changed.connect(self.refresh)
        document.events.meshes.connect(lambda _items: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        name = self.document.selected_object
        self.setVisible(name is not None)
        if name is None:
            return
        obj = self.document.object(name)
        shared = obj.part is not None
        self.setTitle(f"Object {name}" + (" (its file's transform, shared by its groups)" if shared else ""))
        self.form.show_values(obj.transform)
        self.smooth.set_value(obj.smooth)

    def _set(self, path: tuple[str, ...], value: Any) -> None:
        name = self.document.selected_object
        if name is None:
            return
        index = self.document.object(name).mesh_index
        try:
            label = f"Move {name}" if path[0] == "transform" else f"Smooth shading of {name}"
            self.document.set_field(("meshes", index, *path), value, label)
        except BrdfStudioError as exc:
            self.refresh()
            self.error.emit(str(exc))
