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


# ---- lights, camera, environment, deleted parts ------------------------------------------------------


def test_light_edits_are_validated_undoable_and_selected():
    doc = _doc()
    changed = []
    doc.events.lights_changed.connect(lambda: changed.append(1))
    i = doc.add_light("quad")
    assert i == 0 and doc.selected_item == ("light", 0) and doc.lights()[0]["type"] == "quad"
    doc.set_light_field(0, "radiance", (2.0, 1.0, 0.5))
    assert doc.lights()[0]["radiance"] == [2.0, 1.0, 0.5]
    assert changed
    before = doc.to_dict()
    with pytest.raises(ParameterError, match=r"lights\[0\]: edge1 and edge2 span no area"):
        doc.set_light_field(0, "edge2", (3.0, 0.0, 0.0))  # parallel to edge1
    with pytest.raises(ParameterError, match=r"lights\[0\]\.radiance\[1\]: Input should be greater"):
        doc.set_light_field(0, "radiance", (1.0, -1.0, 1.0))
    with pytest.raises(ParameterError, match=r"lights\[0\]\.colour: unknown field"):
        doc.set_light_field(0, "colour", 1.0)
    with pytest.raises(ParameterError, match="type cannot change"):
        doc.set_light_field(0, "type", "point")
    assert doc.to_dict() == before  # refused edits change nothing
    doc.undo()
    assert doc.lights()[0]["radiance"] == [5.0, 5.0, 5.0]
    doc.redo()
    assert doc.lights()[0]["radiance"] == [2.0, 1.0, 0.5]
    doc.undo()
    doc.undo()  # the light's addition
    assert doc.lights() == [] and doc.selected_item is None
    assert not doc.dirty


def test_remove_light_and_undo_keep_the_order():
    doc = _doc()
    doc.add_light("point", {"position": [1, 2, 3]})
    doc.add_light("quad")
    doc.add_light("point", {"position": [4, 5, 6]})
    doc.select_item("light", 2)
    doc.remove_light(1)
    assert [x["type"] for x in doc.lights()] == ["point", "point"]
    assert doc.selected_item == ("light", 1)  # the same light, one place up
    doc.remove_light(1)
    assert doc.selected_item is None
    doc.undo()
    doc.undo()
    assert [x["type"] for x in doc.lights()] == ["point", "quad", "point"]
    assert doc.lights()[2]["position"] == [4.0, 5.0, 6.0]
    with pytest.raises(KeyError):
        doc.remove_light(7)


def test_camera_edits_are_validated_and_undoable():
    doc = _doc()
    seen = []
    doc.events.camera_changed.connect(lambda: seen.append(doc.camera()["fov_deg"]))
    assert doc.camera()["fov_deg"] == 40.0  # the schema's default when the project has none
    doc.set_camera_field("fov_deg", 25.0)
    doc.set_camera_field("position", (0.0, 2.0, 6.0))
    assert doc.camera()["position"] == [0.0, 2.0, 6.0] and seen == [25.0, 25.0]
    with pytest.raises(ParameterError, match=r"camera\.target: the target coincides"):
        doc.set_camera_field("target", (0.0, 2.0, 6.0))
    with pytest.raises(ParameterError, match=r"camera\.up: the up vector is zero or parallel"):
        doc.set_camera_field("up", (0.0, -2.0, -6.0))
    with pytest.raises(ParameterError, match=r"camera\.fov_deg"):
        doc.set_camera_field("fov_deg", 180.0)
    doc.undo()
    assert doc.camera()["position"] == [0.0, 1.0, 4.0]
    doc.undo()
    assert "camera" not in doc.data.extras and not doc.dirty


def test_environment_kinds_and_fields(tmp_path):
    doc = _doc()
    assert doc.environment() is None
    doc.set_environment_kind("constant")
    doc.set_environment_field("radiance", (0.1, 0.2, 0.3))
    assert doc.environment() == {"type": "constant", "radiance": [0.1, 0.2, 0.3]}
    with pytest.raises(ParameterError, match=r"environment\.path: file '.*missing\.exr' not found"):
        doc.set_environment_kind("map", str(tmp_path / "missing.exr"))
    sky = tmp_path / "sky.exr"
    sky.write_bytes(b"")
    doc.set_environment_kind("map", str(sky))
    doc.set_environment_field("rotate_deg", 90.0)
    with pytest.raises(ParameterError, match=r"environment\.scale: Input should be greater than or equal"):
        doc.set_environment_field("scale", -1.0)
    assert doc.environment() == {"type": "map", "path": str(sky), "scale": 1.0, "rotate_deg": 90.0}
    doc.set_environment_kind(None)
    assert doc.environment() is None
    for _ in range(3):
        doc.undo()
    assert doc.environment()["type"] == "constant"


def test_selection_is_one_thing_at_a_time():
    doc = _doc()
    doc.add_objects([SceneObject("bunny", "/x/bunny.obj", None, "white")])
    doc.add_light("point")
    doc.select_object("bunny")
    assert doc.selected_item is None
    doc.select_item("camera")
    assert doc.selected_object is None and doc.selected_item == ("camera", 0)
    doc.select_object(None)  # a click on nothing clears any selection
    assert doc.selected_item is None
    with pytest.raises(KeyError):
        doc.select_item("light", 3)
    assert doc.undo_text() == "Add point light"  # selections are not edits


def test_deleted_parts_are_remembered_and_restored():
    doc = _doc()
    doc.add_objects([SceneObject("car/wheel", "/x/car.obj", "wheel", "white"),
                     SceneObject("car/body", "/x/car.obj", "body", "white")])  # fmt: skip
    doc.remove_object("car/wheel")
    assert [o.part for o in doc.data.excluded_parts] == ["wheel"]
    back = Document.data_from_dict(doc.to_dict())  # autosave keeps them
    assert back == doc.data
    doc.undo()
    assert doc.data.excluded_parts == [] and doc.object("car/wheel").part == "wheel"
