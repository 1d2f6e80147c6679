"""Document <-> project file (core.scene), without Qt or mesh files."""

from __future__ import annotations

import json

import pytest

from app.project import document_to_scene, load_project, objects_from_mesh, save_project, scene_to_document
from app.state import DocumentData, Material, SceneObject
from core.scene import SCENE_VERSION, SceneError, load_scene

PARTS = {"cubes.obj": ["a", "b"], "one.obj": ["one"]}


def lister(path):
    return PARTS[path.name]


def _data(tmp_path):
    return DocumentData(
        [
            Material("white", "lambert", {"kd": (0.8, 0.8, 0.8)}, notes="chalk", tags=["diffuse"]),
            Material("gloss", "phong", {}),
        ],
        [
            SceneObject("one", str(tmp_path / "one.obj"), None, "white"),
            SceneObject("cubes/a", str(tmp_path / "cubes.obj"), "a", "white"),
            SceneObject("cubes/b", str(tmp_path / "cubes.obj"), "b", "gloss"),
        ],
        {"camera": {"position": [0, 2, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 35.0}},
    )


def test_multi_part_meshes_become_group_materials(tmp_path):
    scene = document_to_scene(_data(tmp_path), tmp_path / "p.json")
    assert [m.path for m in scene.meshes] == ["one.obj", "cubes.obj"]  # relative to the project
    assert scene.meshes[1].group_materials == {"a": "white", "b": "gloss"}
    assert scene.materials[0].notes == "chalk" and scene.materials[0].tags == ["diffuse"]
    assert scene.camera.fov_deg == 35.0


def test_save_and_load_round_trip(tmp_path):
    data = _data(tmp_path)
    for name in PARTS:
        (tmp_path / name).write_text("o x\n")
    save_project(data, tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    assert raw["version"] == SCENE_VERSION == 2
    load_scene(tmp_path / "p.json")  # the renderer's loader accepts it
    back = load_project(tmp_path / "p.json", lister)
    assert [(o.name, o.part, o.material) for o in back.objects] == [
        (o.name, o.part, o.material) for o in data.objects
    ]
    assert back.materials[0] == data.materials[0]
    assert back.materials[1].params == dict(back.materials[1].params)  # phong defaults were resolved
    assert back.extras["camera"]["fov_deg"] == 35.0


def test_objects_from_mesh_splits_parts(tmp_path):
    objs = objects_from_mesh(tmp_path / "cubes.obj", "white", lister)
    assert [(o.name, o.part) for o in objs] == [("cubes/a", "a"), ("cubes/b", "b")]
    assert [o.part for o in objects_from_mesh(tmp_path / "one.obj", "white", lister)] == [None]
    with pytest.raises(SceneError, match="not a mesh file"):
        objects_from_mesh(tmp_path / "notes.txt", "white", lister)


def test_bad_parameter_in_a_project_names_the_field(tmp_path):
    data = _data(tmp_path)
    data.materials[0].params["kd"] = (2.0, 0.0, 0.0)
    with pytest.raises(SceneError, match=r"materials\[0\]\.params\.kd"):
        document_to_scene(data, tmp_path / "p.json")


def test_scene_to_document_reports_unreadable_meshes(tmp_path):
    def broken(path):
        raise SceneError("cannot read")

    scene = document_to_scene(_data(tmp_path), tmp_path / "p.json")
    with pytest.raises(SceneError, match=r"meshes\[0\]\.path"):
        scene_to_document(scene, broken)


def test_bundled_demo_scene_round_trips(tmp_path):
    from app.main_window import demo_scene_path

    demo = demo_scene_path()
    if demo is None:
        pytest.skip("no bundled demo scene in this build")
    original = load_scene(demo)
    data = load_project(demo)
    assert len(data.objects) == len(original.meshes)
    save_project(data, tmp_path / "copy.json")
    again = load_scene(tmp_path / "copy.json")  # paths rewritten relative to the new place
    assert [m.name for m in again.materials] == [m.name for m in original.materials]
    for a, b in zip(again.meshes, original.meshes, strict=True):
        assert again.resolve(a.path).resolve() == original.resolve(b.path).resolve()
        assert a.transform == b.transform and a.smooth == b.smooth and a.material == b.material
    assert again.camera == original.camera and again.lights == original.lights
    assert again.environment.type == original.environment.type
    assert (
        again.resolve(again.environment.path).resolve()
        == original.resolve(original.environment.path).resolve()
    )


def test_deleted_part_is_saved_as_excluded_and_stays_deleted(tmp_path):
    from app.state import Document

    for name in PARTS:
        (tmp_path / name).write_text("o x\n")
    doc = Document(_data(tmp_path))
    doc.remove_object("cubes/b")
    save_project(doc.data, tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    assert raw["meshes"][1]["exclude_groups"] == ["b"] and raw["meshes"][1]["group_materials"] == {
        "a": "white"
    }
    back = load_project(tmp_path / "p.json", lister)
    assert [o.name for o in back.objects] == ["one", "cubes/a"]
    assert [(o.name, o.part) for o in back.excluded_parts] == [("cubes/b", "b")]
    save_project(back, tmp_path / "again.json")  # saved again: still excluded
    assert json.loads((tmp_path / "again.json").read_text())["meshes"][1]["exclude_groups"] == ["b"]
    doc.undo()  # the deletion undone: nothing excluded any more
    save_project(doc.data, tmp_path / "p.json")
    assert "exclude_groups" not in json.loads((tmp_path / "p.json").read_text())["meshes"][1]


def test_unknown_excluded_group_is_an_error_naming_group_and_file(tmp_path):
    for name in PARTS:
        (tmp_path / name).write_text("o x\n")
    save_project(_data(tmp_path), tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    raw["meshes"][1]["exclude_groups"] = ["wheel"]
    (tmp_path / "p.json").write_text(json.dumps(raw))
    with pytest.raises(SceneError, match=r"p\.json: meshes\[1\]\.exclude_groups: 'cubes\.obj' has no group named "
                       r"'wheel' \(its groups: 'a', 'b'\)"):  # fmt: skip
        load_project(tmp_path / "p.json", lister)


def test_version_1_project_still_opens(tmp_path):
    for name in PARTS:
        (tmp_path / name).write_text("o x\n")
    save_project(_data(tmp_path), tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    raw["version"] = 1
    (tmp_path / "p.json").write_text(json.dumps(raw))
    back = load_project(tmp_path / "p.json", lister)
    assert [o.name for o in back.objects] == ["one", "cubes/a", "cubes/b"] and back.excluded_parts == []


def test_lights_camera_environment_edits_are_saved(tmp_path):
    from app.state import Document

    for name in PARTS:
        (tmp_path / name).write_text("o x\n")
    doc = Document(_data(tmp_path))
    doc.add_light("quad")
    doc.set_light_field(0, "radiance", (3.0, 2.0, 1.0))
    doc.add_light("point")
    doc.set_camera_field("fov_deg", 22.5)
    (tmp_path / "sky.exr").write_bytes(b"")
    doc.set_environment_kind("map", str(tmp_path / "sky.exr"))
    doc.set_environment_field("scale", 0.25)
    save_project(doc.data, tmp_path / "p.json")
    scene = load_scene(tmp_path / "p.json")  # the renderer's loader reads the edits
    assert [light.type for light in scene.lights] == ["quad", "point"]
    assert scene.lights[0].radiance == (3.0, 2.0, 1.0)
    assert scene.camera.fov_deg == 22.5
    assert scene.environment.path == "sky.exr" and scene.environment.scale == 0.25  # relative again
    back = load_project(tmp_path / "p.json", lister)
    assert Document(back).lights() == doc.lights()
    assert back.extras["environment"]["path"] == str((tmp_path / "sky.exr").resolve())
