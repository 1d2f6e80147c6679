"""Project files: the document's scene written and read by core.scene's own loader, paths relative to the
project, without Qt or mesh files."""

from __future__ import annotations

import json

import pytest

from app.document import Document
from app.project import load_project, save_project
from core.scene import SCENE_VERSION, Camera, Material, Mesh, Scene, SceneError, load_scene

PARTS = {"cubes.obj": ["a", "b"], "one.obj": ["one"]}


def lister(path):
    return PARTS[path.name]


def _doc(tmp_path) -> Document:
    for name in PARTS:
        (tmp_path / name).write_text("o x\n")
    scene = Scene(
        materials=[
            Material(
                name="white", model="lambert", params={"kd": (0.8, 0.8, 0.8)}, notes="chalk", tags=["diffuse"]
            ),
            Material(name="gloss", model="phong"),
        ],
        camera=Camera(position=(0, 2, 5), fov_deg=35.0),
    )
    doc = Document(scene, parts=lister)
    doc.add_mesh(tmp_path / "one.obj")
    doc.add_mesh(tmp_path / "cubes.obj")
    doc.assign_material("cubes/b", "gloss")
    return doc


def test_save_writes_relative_paths_and_group_materials(tmp_path):
    doc = _doc(tmp_path)
    save_project(doc.scene, tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    assert raw["version"] == SCENE_VERSION == 2
    assert [m["path"] for m in raw["meshes"]] == ["one.obj", "cubes.obj"]  # relative to the project
    assert raw["meshes"][1]["group_materials"] == {"b": "gloss"}
    assert raw["materials"][0]["notes"] == "chalk" and raw["camera"]["fov_deg"] == 35.0
    assert doc.scene.meshes[0].path == str(tmp_path / "one.obj")  # the edited scene keeps absolute paths
    load_scene(tmp_path / "p.json")  # the renderer's loader accepts it


def test_save_and_load_round_trip(tmp_path):
    doc = _doc(tmp_path)
    save_project(doc.scene, tmp_path / "p.json")
    back = Document(load_project(tmp_path / "p.json", lister), parts=lister)
    assert [(o.name, o.part, o.material) for o in back.objects()] == [
        (o.name, o.part, o.material) for o in doc.objects()
    ]
    assert back.scene.materials[0] == doc.scene.materials[0]
    assert set(back.scene.materials[1].params) == {"ks", "kd", "n"} or back.scene.materials[1].params
    assert back.scene.camera.fov_deg == 35.0


def test_bad_parameter_in_a_project_names_the_field(tmp_path):
    doc = _doc(tmp_path)
    doc.scene.materials[0].params["kd"] = (2.0, 0.0, 0.0)  # past the document's checks, as a bug would
    with pytest.raises(SceneError, match=r"materials\[0\]\.params\.kd"):
        save_project(doc.scene, tmp_path / "p.json")
    assert not (tmp_path / "p.json").exists()


def test_unreadable_mesh_names_the_mesh(tmp_path):
    doc = _doc(tmp_path)
    save_project(doc.scene, tmp_path / "p.json")

    def broken(path):
        raise SceneError("cannot read")

    with pytest.raises(SceneError, match=r"meshes\[0\]\.path"):
        load_project(tmp_path / "p.json", broken)


def test_bundled_demo_scene_round_trips(tmp_path):
    from app.main_window import demo_scene_path

    demo = demo_scene_path()
    original = load_scene(demo)
    scene = load_project(demo)
    assert len(scene.meshes) == len(original.meshes)
    save_project(scene, tmp_path / "copy.json")
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
    doc = _doc(tmp_path)
    doc.remove_object("cubes/b")
    save_project(doc.scene, tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    assert raw["meshes"][1]["exclude_groups"] == ["b"] and raw["meshes"][1]["group_materials"] == {}
    back = Document(load_project(tmp_path / "p.json", lister), parts=lister)
    assert [o.name for o in back.objects()] == ["one", "cubes/a"]
    save_project(back.scene, tmp_path / "again.json")  # saved again: still excluded
    assert json.loads((tmp_path / "again.json").read_text())["meshes"][1]["exclude_groups"] == ["b"]
    doc.undo()  # the deletion undone: nothing excluded any more
    save_project(doc.scene, tmp_path / "p.json")
    assert "exclude_groups" not in json.loads((tmp_path / "p.json").read_text())["meshes"][1]


def test_unknown_excluded_group_is_an_error_naming_group_and_file(tmp_path):
    save_project(_doc(tmp_path).scene, tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    raw["meshes"][1]["exclude_groups"] = ["wheel"]
    (tmp_path / "p.json").write_text(json.dumps(raw))
    with pytest.raises(SceneError, match=r"p\.json: meshes\[1\]\.exclude_groups: 'cubes\.obj' has no group named "
                       r"'wheel' \(its groups: 'a', 'b'\)"):  # fmt: skip
        load_project(tmp_path / "p.json", lister)


def test_version_1_project_still_opens(tmp_path):
    save_project(_doc(tmp_path).scene, tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    raw["version"] = 1
    (tmp_path / "p.json").write_text(json.dumps(raw))
    back = Document(load_project(tmp_path / "p.json", lister), parts=lister)
    assert [o.name for o in back.objects()] == ["one", "cubes/a", "cubes/b"]


def test_lights_camera_environment_edits_are_saved(tmp_path):
    doc = _doc(tmp_path)
    doc.add_light("quad")
    doc.set_light_field(0, "radiance", (3.0, 2.0, 1.0))
    doc.add_light("point")
    doc.set_camera_field("fov_deg", 22.5)
    (tmp_path / "sky.exr").write_bytes(b"")
    doc.set_environment_kind("map", str(tmp_path / "sky.exr"))
    doc.set_environment_field("scale", 0.25)
    save_project(doc.scene, tmp_path / "p.json")
    scene = load_scene(tmp_path / "p.json")  # the renderer's loader reads the edits
    assert [light.type for light in scene.lights] == ["quad", "point"]
    assert scene.lights[0].radiance == (3.0, 2.0, 1.0)
    assert scene.camera.fov_deg == 22.5
    assert scene.environment.path == "sky.exr" and scene.environment.scale == 0.25  # relative again
    back = load_project(tmp_path / "p.json", lister)
    assert back.lights == doc.scene.lights
    assert back.environment.path == str((tmp_path / "sky.exr").resolve())


def test_a_mesh_without_a_name_gets_one(tmp_path):
    (tmp_path / "one.obj").write_text("o x\n")
    scene = Scene(
        materials=[Material(name="m", model="lambert")], meshes=[Mesh(path="one.obj", material="m")]
    )
    from core.scene import save_scene

    save_scene(scene, tmp_path / "p.json")
    assert load_project(tmp_path / "p.json", lister).meshes[0].name == "one"
