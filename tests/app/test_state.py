"""The document model alone (no Qt): edits, undo/redo, merging, dirty flag, validation."""

from __future__ import annotations

import pytest

import app.state as state
from app.state import Document, DocumentData, Material, SceneObject, default_document, unique_name
from core.errors import ParameterError


def _doc() -> Document:
    return Document(DocumentData([Material("white", "lambert", {"kd": (0.8, 0.8, 0.8)})]))


def test_set_param_validates_and_undoes():
    doc = _doc()
    seen = []
    doc.events.material_changed.connect(seen.append)
    doc.set_param("kd", 0.5)
    assert doc.material("white").params["kd"] == (0.5, 0.5, 0.5)
    assert seen == ["white"] and doc.dirty
    with pytest.raises(ParameterError, match="outside its allowed range"):
        doc.set_param("kd", 2.0)
    with pytest.raises(ParameterError, match="no parameter"):
        doc.set_param("nope", 0.1)
    doc.undo()
    assert doc.material("white").params["kd"] == (0.8, 0.8, 0.8)
    assert not doc.dirty
    doc.redo()
    assert doc.material("white").params["kd"] == (0.5, 0.5, 0.5)


def test_edits_of_one_value_merge_until_end_merge(monkeypatch):
    doc = _doc()
    for v in (0.1, 0.2, 0.3):
        doc.set_param("kd", v)
    assert len(doc._undo) == 1  # one drag = one step
    doc.end_merge()
    doc.set_param("kd", 0.4)
    assert len(doc._undo) == 2
    monkeypatch.setattr(state, "MERGE_SECONDS", -1.0)  # no merging across time
    doc.set_param("kd", 0.6)
    assert len(doc._undo) == 3
    doc.undo()
    doc.undo()
    assert doc.material().params["kd"] == (0.3, 0.3, 0.3)


def test_saved_state_tracks_undo_and_redo():
    doc = _doc()
    doc.set_param("kd", 0.5)
    doc.mark_clean()
    assert not doc.dirty
    doc.undo()
    assert doc.dirty
    doc.redo()
    assert not doc.dirty
    doc.undo()
    doc.set_param("kd", 0.9)  # the saved state is now unreachable
    assert doc.dirty
    doc.undo()
    assert doc.dirty


def test_switch_model_and_rename_and_assign():
    doc = _doc()
    doc.add_objects([SceneObject("bunny", "/x/bunny.obj", None, "white")])
    doc.set_model("phong")
    assert doc.material().model == "phong"
    assert set(doc.material().params) == {p.name for p in doc.brdf().model.params}
    doc.rename_material("white", "shiny")
    assert doc.object("bunny").material == "shiny"
    with pytest.raises(ParameterError, match="assigned"):
        doc.remove_material("shiny")
    other = doc.add_material("lambert")
    doc.assign_material("bunny", other)
    assert doc.object("bunny").material == other
    for _ in range(4):
        doc.undo()
    assert doc.material_names() == ["white"] and doc.material("white").model == "lambert"
    assert doc.object("bunny").material == "white"


def test_direction_is_view_state_and_clamped():
    doc = _doc()
    doc.set_direction(120.0, 370.0)
    assert doc.theta_deg == 89.9 and doc.phi_deg == pytest.approx(10.0)
    assert not doc.can_undo and not doc.dirty
    with pytest.raises(ParameterError):
        doc.set_direction(float("nan"), 0.0)


def test_unique_names_and_default_document():
    assert unique_name("a", ["a", "a.1"]) == "a.2"
    doc = default_document()
    assert doc.current_material in doc.material_names()


def test_dict_round_trip():
    doc = _doc()
    doc.set_notes("from the 2008 thesis")
    doc.set_tags(["glossy", " paper ", ""])
    doc.add_objects([SceneObject("floor", "/x/floor.obj", "part0", "white")])
    back = Document.data_from_dict(doc.to_dict())
    assert back == doc.data
    assert back.materials[0].tags == ["glossy", "paper"]


def test_the_document_model_imports_no_qt():
    import subprocess
    import sys

    code = "import sys, app.state, app.view_data; print(any(m.startswith(('PySide6', 'vtk')) for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
