"""The material editor: which material, which model (a built-in, a model file, or a MERL file), the
generated parameter editor, notes and tags, and computed facts beside the parameters (traits, albedo at a
few angles, adaptive table). A model file's panel shows its path, its error and its notices."""

from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QComboBox,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPlainTextEdit,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from app.document import Document
from app.editors.combo import ElidedComboBox
from app.editors.model_file import ModelFilePanel
from app.editors.params import ParamEditor
from app.editors.rows import EmissionRow
from app.model_library import ModelLibrary
from core.brdf import Model, all_models, get_model
from core.errors import BrdfStudioError
from core.model_files import is_model_file

INFO_THETAS_DEG = (0.0, 30.0, 60.0, 80.0)
MEASURED = "(measured)"
"""The model chooser's item for a measured material."""


def trait_badges(model: Model) -> str:
    """Rich text: one badge per trait (green when the model promises it, grey when not)."""

    def badge(text: str, on: bool) -> str:
        colour = "#2e7d32" if on else "#9e9e9e"
        mark = "&#10003;" if on else "&#10007;"
        return f'<span style="color:{colour}; font-weight:bold">{mark} {text}</span>'

    return " &nbsp; ".join(
        [
            badge("reciprocal", model.reciprocal),
            badge("energy-conserving", model.energy_conserving),
            badge("isotropic", model.isotropic),
        ]
    )


class MaterialEditor(QWidget):
    """Edits the document's current material. Emits ``load_measured_requested`` and ``error(str)``; the main
    window owns file dialogs and error reporting. The model chooser lists the built-in models, then the
    files of ``library`` (the model files the app has opened)."""

    load_measured_requested = Signal()
    error = Signal(str)

    def __init__(
        self, document: Document, parent: QWidget | None = None, library: ModelLibrary | None = None
    ):
        super().__init__(parent)
        self.document = document
        self.library = library if library is not None else ModelLibrary()
        self.material_box = QComboBox()
        self.material_box.setToolTip("The material being edited")
        self.new_button = QPushButton("New")
        self.new_button.setToolTip("New material (Ctrl+M)")
        self.delete_button = QPushButton("Delete")
        self.model_box = ElidedComboBox(min_chars=14)  # a long model name elides: the dock stays narrow
        self._fill_models()
        self.merl_button = QPushButton("Load MERL ...")
        self.merl_button.setToolTip("Use a measured BRDF (MERL .binary file) for this material")
        self.citation = QLabel()
        self.citation.setWordWrap(True)
        self.citation.setStyleSheet("color: #555; font-size: 9pt")
        self.badges = QLabel()
        self.model_file = ModelFilePanel()
        self.params_box = QGroupBox("Parameters")
        self.params_layout = QVBoxLayout(self.params_box)
        self.param_editor: ParamEditor | None = None
        self.measured_label = QLabel()
        self.measured_label.setWordWrap(True)
        self.params_layout.addWidget(self.measured_label)
        self._info_lines: dict[str, str] = {}
        self.info = QLabel("")
        self.info.setWordWrap(True)
        self.info.setTextFormat(self.info.textFormat().RichText)
        self.notes = QPlainTextEdit()
        self.notes.setPlaceholderText("Notes about this material")
        self.notes.setMaximumHeight(80)
        self.emission = EmissionRow("emission", "W/(m^2 sr)")
        self.emission.setToolTip("Emitted radiance: every object of this material becomes an area light")
        self.emission.edited.connect(lambda _f, value: self._guard(self._set_emission, value))
        self.emission.released.connect(document.end_merge)
        self.tags = QLineEdit()
        self.tags.setPlaceholderText("tags, comma separated")

        row = QHBoxLayout()
        row.addWidget(self.material_box, 1)
        row.addWidget(self.new_button)
        row.addWidget(self.delete_button)
        model_row = QHBoxLayout()
        model_row.addWidget(self.model_box, 1)
        model_row.addWidget(self.merl_button)
        form = QFormLayout()
        form.addRow("Material", row)
        form.addRow("Model", model_row)
        layout = QVBoxLayout(self)
        layout.addLayout(form)
        layout.addWidget(self.citation)
        layout.addWidget(self.badges)
        layout.addWidget(self.model_file)
        layout.addWidget(self.params_box)
        info_box = QGroupBox("Computed")
        QVBoxLayout(info_box).addWidget(self.info)
        layout.addWidget(info_box)
        meta = QFormLayout()
        meta.addRow("Emission", self.emission)
        meta.addRow("Notes", self.notes)
        meta.addRow("Tags", self.tags)
        layout.addLayout(meta)
        layout.addStretch(1)

        self.material_box.activated.connect(lambda i: document.select_material(self.material_box.itemText(i)))
        self.model_box.activated.connect(self._model_chosen)
        self.new_button.clicked.connect(self.new_material)
        self.delete_button.clicked.connect(self.delete_material)
        self.merl_button.clicked.connect(self.load_measured_requested)
        self.notes.textChanged.connect(lambda: self._guard(document.set_notes, self.notes.toPlainText()))
        self.tags.editingFinished.connect(lambda: self._guard(document.set_tags, self.tags.text().split(",")))
        document.events.materials.connect(self._materials_changed)
        document.selection_changed.connect(self.refresh)
        self.library.changed.connect(self._model_file_changed)
        self.refresh_names()
        self.refresh()

    def _fill_models(self) -> None:
        """The built-in models, then the opened model files (the measured item, when shown, stays last)."""
        self.model_box.blockSignals(True)
        self.model_box.clear()
        for m in [*all_models(), *self.library.models()]:
            self.model_box.addItem(m.label, m.name)
        self.model_box.fit_list()
        self.model_box.blockSignals(False)

    def _model_file_changed(self, path: str) -> None:
        """A model file was opened, reloaded, or its problem changed: list it, show it if it is the
        current material's."""
        listed = self.model_box.findData(path) >= 0
        if listed:  # a new version may have a new label
            self.model_box.setItemText(self.model_box.findData(path), self.library.files[path].model.label)
        else:
            self._fill_models()
        doc = self.document
        if not listed or doc.current_material is None or doc.material().model == path:
            self.refresh()  # (the list refilled, or the material of that file: its panel)

    def _materials_changed(self, items) -> None:
        names = self.document.material_names()
        if items is None or names != [
            self.material_box.itemText(i) for i in range(self.material_box.count())
        ]:
            self.refresh_names()
        self.refresh()

    def _guard(self, fn, *args) -> None:
        try:
            fn(*args)
        except (BrdfStudioError, KeyError) as exc:
            self.error.emit(str(exc))

    def _model_chosen(self, index: int) -> None:
        name = self.model_box.itemData(index)
        if name and name != MEASURED:
            self._guard(self.document.set_model, name)

    def new_material(self) -> None:
        current = self.document.material().model if self.document.current_material else None
        current = current or "lambert"  # a measured material's copy starts as Lambert
        self._guard(self.document.add_material, current)

    def delete_material(self) -> None:
        if self.document.current_material:
            self._guard(self.document.remove_material, self.document.current_material)

    def refresh_names(self) -> None:
        self.material_box.blockSignals(True)
        self.material_box.clear()
        self.material_box.addItems(self.document.material_names())
        if self.document.current_material:
            self.material_box.setCurrentText(self.document.current_material)
        self.material_box.blockSignals(False)

    def refresh(self) -> None:
        """Show the current material (rebuilding the parameter rows only when the model changed)."""
        doc = self.document
        self.material_box.blockSignals(True)
        if doc.current_material:
            self.material_box.setCurrentText(doc.current_material)
        self.material_box.blockSignals(False)
        if doc.current_material is None:
            self.setEnabled(False)
            return
        self.setEnabled(True)
        mat = doc.material()
        measured = mat.measured is not None
        if measured:
            model = doc.brdf().model
            self.model_box.blockSignals(True)
            if self.model_box.findData(MEASURED) < 0:
                self.model_box.addItem(model.label, MEASURED)
            self.model_box.setCurrentIndex(self.model_box.findData(MEASURED))
            self.model_box.blockSignals(False)
        else:
            model = get_model(mat.model or "")
            self.model_box.blockSignals(True)
            if self.model_box.findData(mat.model) < 0:  # a model file set without the library (the API)
                self.model_box.addItem(model.label, mat.model)
            self.model_box.setCurrentIndex(self.model_box.findData(mat.model))
            self.model_box.blockSignals(False)
        from_file = not measured and is_model_file(mat.model or "")
        if from_file:
            self.model_file.show_file(self.library.get(mat.model or ""), mat.model or "")
        self.model_file.setVisible(from_file)
        self.citation.setText(model.citation)
        self.badges.setText(trait_badges(model))
        if self.param_editor is None or self.param_editor.model is not model:
            if self.param_editor is not None:
                old = self.param_editor
                self.params_layout.removeWidget(old)
                old.hide()
                old.setParent(None)  # gone now, not at the next turn of the event loop
                old.deleteLater()
            self.param_editor = ParamEditor(model)
            self.param_editor.value_edited.connect(lambda n, v: self._guard(doc.set_param, n, v))
            self.param_editor.edit_finished.connect(doc.end_merge)
            self.params_layout.addWidget(self.param_editor)
        self.param_editor.set_values(mat.params)
        self.param_editor.setVisible(not measured)
        self.measured_label.setVisible(measured)
        self.measured_label.setText(f"Measured data from {mat.measured}" if measured else "")
        if self.notes.toPlainText() != mat.notes:
            self.notes.blockSignals(True)
            self.notes.setPlainText(mat.notes)
            self.notes.blockSignals(False)
        if not self.tags.hasFocus():
            self.tags.setText(", ".join(mat.tags))
        self.emission.set_value(mat.emission)

    def _set_emission(self, value: tuple[float, float, float]) -> None:
        index = self.document.material_names().index(self.document.current_material or "")
        self.document.set_field(("materials", index, "emission"), value, "Set emission")

    def set_info(self, key: str, line: str) -> None:
        """Show one computed fact (``albedo``, ``adaptive``), replacing the previous line of that key."""
        self._info_lines[key] = line
        self.info.setText("<br>".join(self._info_lines[k] for k in sorted(self._info_lines)))
