"""The document alone (no Qt): a core.scene.Scene edited through the evented layer; edits, events, undo/redo,
merging, the dirty flag, validation by the scene schema, objects derived from meshes."""

from __future__ import annotations

import pytest

import app.evented as evented
from app.document import Document, default_scene, unique_name
from core.errors import ParameterError
from core.scene import Material, Mesh, Scene, scene_from_dict

PARTS = {"car.obj": ["wheel", "body"], "bunny.obj": ["bunny"]}


def lister(path):
    return PARTS[path.name]


def _doc() -> Document:
    scene = Scene(materials=[Material(name="white", model="lambert", params={"kd": (0.8, 0.8, 0.8)})])
    return Document(scene, parts=lister)


def test_the_document_edits_the_scene_model_itself():
    doc = _doc()
    assert type(doc.scene) is Scene  # one data model: the project file's own
    doc.set_param("kd", 0.5)
    assert doc.scene.materials[0].params["kd"] == (0.5, 0.5, 0.5)


def test_events_are_generated_from_the_schema_fields():
    doc = _doc()
    seen = []
    for name in Scene.model_fields:
        doc.events[name].connect(lambda items, name=name: seen.append((name, items)))
    doc.set_param("kd", 0.5)
    assert seen == [("materials", frozenset({0}))]  # one field, one changed item
    seen.clear()
    doc.add_material("phong")
    assert seen == [("materials", None)]  # an item added: the list's structure changed
    seen.clear()
    doc.set_camera_field("fov_deg", 20.0)
    assert seen == [("camera", None)]
    seen.clear()
    doc.undo()
    assert seen == [("camera", None)]


def test_set_param_validates_and_undoes():
    doc = _doc()
    doc.set_param("kd", 0.5)
    assert doc.dirty
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
    assert doc.undo_steps == 1  # one drag = one step
    doc.end_merge()
    doc.set_param("kd", 0.4)
    assert doc.undo_steps == 2
    monkeypatch.setattr(evented, "MERGE_SECONDS", -1.0)  # no merging across time
    doc.set_param("kd", 0.6)
    assert doc.undo_steps == 3
    doc.undo()
    doc.undo()
    assert doc.material().params["kd"] == (0.3, 0.3, 0.3)


def test_unchanged_value_is_no_step():
    doc = _doc()
    doc.set_param("kd", 0.8)
    assert not doc.can_undo and not doc.dirty


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


def test_switch_model_rename_and_assign():
    doc = _doc()
    doc.add_mesh("/x/bunny.obj")
    doc.set_model("phong")
    assert doc.material().model == "phong"
    assert set(doc.material().params) == {p.name for p in doc.brdf().model.params}
    doc.rename_material("white", "shiny")
    assert doc.object("bunny").material == "shiny" and doc.scene.meshes[0].material == "shiny"
    with pytest.raises(ParameterError, match="assigned"):
        doc.remove_material("shiny")
    other = doc.add_material("lambert")
    doc.assign_material("bunny", other)
    assert doc.object("bunny").material == other
    for _ in range(4):
        doc.undo()
    assert doc.material_names() == ["white"] and doc.material("white").model == "lambert"
    assert doc.object("bunny").material == "white"


def test_refused_rename_changes_nothing():
    doc = _doc()
    doc.add_material("phong")
    with pytest.raises(ParameterError, match="exists already"):
        doc.rename_material("phong", "white")
    assert doc.material_names() == ["white", "phong"]


def test_direction_is_view_state_and_clamped():
    doc = _doc()
    doc.set_direction(120.0, 370.0)
    assert doc.theta_deg == 89.9 and doc.phi_deg == pytest.approx(10.0)
    assert not doc.can_undo and not doc.dirty
    with pytest.raises(ParameterError):
        doc.set_direction(float("nan"), 0.0)


def test_unique_names_and_default_scene():
    assert unique_name("a", ["a", "a.1"]) == "a.2"
    doc = Document(default_scene())
    assert doc.current_material in doc.material_names()


def test_dict_round_trip_is_the_scene_file_form():
    doc = _doc()
    doc.set_notes("from the 2008 thesis")
    doc.set_tags(["glossy", " paper ", ""])
    doc.add_mesh("/x/car.obj")
    back = scene_from_dict(doc.to_dict(), check_files=False)
    assert back.model_dump(mode="json") == doc.scene.model_dump(mode="json")
    assert back.materials[0].tags == ["glossy", "paper"]


def test_the_document_imports_no_qt():
    import subprocess
    import sys

    code = (
        "import sys, app.document, app.project, app.view_data, app.sampling_data; "
        "print(any(m.startswith(('PySide6', 'vtk')) for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ---- lights, camera, environment, deleted parts ------------------------------------------------------


def test_light_edits_are_validated_undoable_and_selected():
    doc = _doc()
    changed = []
    doc.events.lights.connect(changed.append)
    i = doc.add_light("quad")
    assert i == 0 and doc.selected_item == ("light", 0) and doc.scene.lights[0].type == "quad"
    doc.set_light_field(0, "radiance", (2.0, 1.0, 0.5))
    assert doc.scene.lights[0].radiance == (2.0, 1.0, 0.5)
    assert changed == [None, frozenset({0})]
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
    assert doc.scene.lights[0].radiance == (5.0, 5.0, 5.0)
    doc.redo()
    assert doc.scene.lights[0].radiance == (2.0, 1.0, 0.5)
    doc.undo()
    doc.undo()  # the light's addition
    assert doc.scene.lights == [] and doc.selected_item is None
    assert not doc.dirty


def test_remove_light_and_undo_keep_the_order():
    doc = _doc()
    doc.add_light("point", {"position": (1, 2, 3)})
    doc.add_light("quad")
    doc.add_light("point", {"position": (4, 5, 6)})
    doc.select_item("light", 2)
    doc.remove_light(1)
    assert [x.type for x in doc.scene.lights] == ["point", "point"]
    assert doc.selected_item == ("light", 1)  # the same light, one place up
    doc.remove_light(1)
    assert doc.selected_item is None
    doc.undo()
    doc.undo()
    assert [x.type for x in doc.scene.lights] == ["point", "quad", "point"]
    assert doc.scene.lights[2].position == (4.0, 5.0, 6.0)
    with pytest.raises(KeyError):
        doc.remove_light(7)


def test_camera_edits_are_validated_and_undoable():
    doc = _doc()
    seen = []
    doc.events.camera.connect(lambda _items: seen.append(doc.scene.camera.fov_deg))
    assert doc.scene.camera.fov_deg == 40.0
    doc.set_camera_field("fov_deg", 25.0)
    doc.set_camera_field("position", (0.0, 2.0, 6.0))
    assert doc.scene.camera.position == (0.0, 2.0, 6.0) and seen == [25.0, 25.0]
    with pytest.raises(ParameterError, match=r"camera\.target: the target coincides"):
        doc.set_camera_field("target", (0.0, 2.0, 6.0))
    with pytest.raises(ParameterError, match=r"camera\.up: the up vector is zero or parallel"):
        doc.set_camera_field("up", (0.0, -2.0, -6.0))
    with pytest.raises(ParameterError, match=r"camera\.fov_deg"):
        doc.set_camera_field("fov_deg", 180.0)
    doc.undo()
    assert doc.scene.camera.position == (0.0, 1.0, 4.0)
    doc.undo()
    assert doc.scene.camera.fov_deg == 40.0 and not doc.dirty


def test_environment_kinds_and_fields(tmp_path):
    doc = _doc()
    assert doc.scene.environment is None
    with pytest.raises(ParameterError, match="has none"):
        doc.set_environment_field("scale", 2.0)
    doc.set_environment_kind("constant")
    doc.set_environment_field("radiance", (0.1, 0.2, 0.3))
    assert doc.scene.environment.model_dump() == {"type": "constant", "radiance": (0.1, 0.2, 0.3)}
    with pytest.raises(ParameterError, match=r"environment\.path: file '.*missing\.exr' not found"):
        doc.set_environment_kind("map", str(tmp_path / "missing.exr"))
    sky = tmp_path / "sky.exr"
    sky.write_bytes(b"")
    doc.set_environment_kind("map", str(sky))
    doc.set_environment_field("rotate_deg", 90.0)
    with pytest.raises(ParameterError, match=r"environment\.scale: Input should be greater than or equal"):
        doc.set_environment_field("scale", -1.0)
    env = doc.scene.environment
    assert (env.type, env.path, env.scale, env.rotate_deg) == ("map", str(sky), 1.0, 90.0)
    doc.set_environment_kind(None)
    assert doc.scene.environment is None
    for _ in range(3):
        doc.undo()
    assert doc.scene.environment.type == "constant"


def test_selection_is_one_thing_at_a_time():
    doc = _doc()
    doc.add_mesh("/x/bunny.obj")
    doc.add_light("point")
    doc.select_object("bunny")
    assert doc.selected_item is None
    doc.select_item("camera")
    assert doc.selected_object is None and doc.selected_item == ("camera", 0)
    doc.select_object(None)
    assert doc.selected_item is None
    with pytest.raises(KeyError):
        doc.select_item("light", 3)
    assert doc.undo_text() == "Add point light"  # selections are not edits


def test_groups_of_a_file_are_objects_and_deleted_groups_are_excluded():
    doc = _doc()
    names = doc.add_mesh("/x/car.obj")
    assert names == ["car/wheel", "car/body"]
    doc.assign_material("car/body", doc.add_material("phong"))
    assert doc.scene.meshes[0].group_materials == {"body": "phong"}
    doc.remove_object("car/wheel")
    assert doc.scene.meshes[0].exclude_groups == ["wheel"]
    assert [o.name for o in doc.objects()] == ["car/body"]
    doc.remove_object("car/body")  # the last group: the mesh entry goes
    assert doc.scene.meshes == []
    doc.undo()
    doc.undo()
    assert [o.name for o in doc.objects()] == ["car/wheel", "car/body"] and doc.scene.meshes[
        0
    ].exclude_groups == []


def test_join_last_makes_one_step_whatever_the_time(monkeypatch):
    doc = _doc()
    monkeypatch.setattr(evented, "MERGE_SECONDS", -1.0)
    doc.add_mesh("/x/bunny.obj", "Import bunny")
    doc.set_camera({"position": (0.0, 0.0, 9.0)}, join_last=True)
    assert doc.undo_steps == 1 and doc.undo_text() == "Import bunny"
    doc.undo()
    assert doc.scene.meshes == [] and doc.scene.camera.position == (0.0, 1.0, 4.0)
    with pytest.raises(ParameterError, match=r"camera\.fov_deg"):
        doc.set_camera({"fov_deg": -1.0})


def test_a_scene_built_by_hand_is_edited_as_is():
    scene = Scene(
        materials=[Material(name="m", model="lambert")],
        meshes=[Mesh(path="/x/bunny.obj", material="m")],
    )
    doc = Document(scene, parts=lister)
    assert [o.name for o in doc.objects()] == ["bunny"]
    doc.set_field(("meshes", 0, "smooth"), True)
    assert doc.object("bunny").smooth
