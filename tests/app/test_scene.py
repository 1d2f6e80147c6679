"""Scene editing in the real window: import, assign, pick, save/load, undo, prompts, autosave, drops, errors."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from PySide6.QtCore import QMimeData, QPointF, Qt, QUrl
from PySide6.QtGui import QColor, QDropEvent

from app import settings
from core.scene import Camera, ConstantEnvironment, Scene
from tests.app.meshes import write_obj

pytestmark = pytest.mark.gui


@pytest.fixture
def fresh(window):
    """The shared window on a new, clean project (and no error left from earlier tests)."""
    window.ask_unsaved = lambda: "discard"
    window.new_project()
    window.errors.clear()
    window.tabs.setCurrentWidget(window.scene_panel)
    yield window
    window.ask_unsaved = lambda: "discard"


def test_import_multi_part_mesh_assign_and_undo(fresh, tmp_path):
    w = fresh
    path = write_obj(tmp_path / "cubes.obj", {"left": (0, 0, 0), "right": (2, 0, 0)})
    names = w.import_mesh(path)
    assert sorted(names) == ["cubes/left", "cubes/right"]
    assert set(w.viewport.actors) == set(names)
    assert w.viewport.meshes["cubes/right"].bounds[0] == pytest.approx(2.0)
    assert set(w.scene_tree.combos) == set(names)
    # assign another material through the tree's chooser
    other = w.document.add_material("lambert", name="red", params={"kd": (0.9, 0.05, 0.05)})
    combo = w.scene_tree.combos["cubes/right"]
    combo.setCurrentText(other)
    combo.activated.emit(combo.currentIndex())
    assert w.document.object("cubes/right").material == "red"
    colour = w.viewport.actors["cubes/right"].GetProperty().GetColor()
    assert colour[0] > 0.8 and colour[1] < 0.4
    # delete the selected object with the Delete action, then undo it
    w.document.select_object("cubes/left")
    w.delete_action.trigger()
    assert "cubes/left" not in w.viewport.actors and w.document.selected_object is None
    w.document.undo()
    assert "cubes/left" in w.viewport.actors
    w.document.undo()  # assignment
    assert w.document.object("cubes/right").material != "red"
    w.document.undo()  # new material
    w.document.undo()  # import
    assert w.viewport.actors == {} and w.document.objects() == []
    w.document.redo()
    assert set(w.viewport.actors) == set(names)


def test_click_in_viewport_selects_and_tree_follows(fresh, tmp_path, qtbot):
    w = fresh
    w.import_mesh(write_obj(tmp_path / "one.obj", {"cube": (0, 0, 0)}))
    name = w.document.objects()[0].name
    w.viewport.plotter.reset_camera()
    w.viewport.plotter.render()
    x, y = w.viewport.display_point(np.array([0.5, 0.5, 0.5]))
    assert w.viewport.pick_at(x, y) == name
    w.viewport.object_picked.emit(w.viewport.pick_at(x, y))
    assert w.document.selected_object == name
    assert w.scene_tree.selectedItems()[0].text(0) == name
    assert w.viewport.actors[name].GetProperty().GetEdgeVisibility()
    # selecting a material in the tree selects it in the editor
    item = w.scene_tree.item_for("material", w.document.material_names()[-1])
    w.scene_tree.setCurrentItem(item)  # what a click does
    assert w.document.current_material == item.text(0)
    assert w.document.selected_object is None
    assert w.material_editor.material_box.currentText() == item.text(0)


def test_save_load_round_trip_and_recent_files(fresh, tmp_path):
    w = fresh
    w.import_mesh(write_obj(tmp_path / "cubes.obj", {"a": (0, 0, 0), "b": (0, 2, 0)}))
    w.document.set_notes("measured in 2008")
    w.document.set_tags(["paper", "glossy"])
    assert w.document.dirty and w.isWindowModified()
    project = tmp_path / "proj.json"
    assert w.save_project_as(project)
    assert not w.document.dirty and not w.isWindowModified()
    assert project.resolve() in settings.recent_files()
    saved_objects = [(o.name, o.part, o.material) for o in w.document.objects()]
    saved_material = w.document.material()
    w.new_project()
    assert w.document.objects() == []
    assert w.open_project(project)
    assert [(o.name, o.part, o.material) for o in w.document.objects()] == saved_objects
    m = w.document.material(saved_material.name)
    assert (m.notes, m.tags, m.params) == (saved_material.notes, saved_material.tags, saved_material.params)
    assert not w.document.dirty and w.document.path == project.resolve()
    assert set(w.viewport.actors) == {o[0] for o in saved_objects}


def test_unsaved_changes_prompt(fresh):
    w = fresh
    w.document.add_material("lambert", name="keep-me")
    w.ask_unsaved = lambda: "cancel"
    w.new_project()
    assert "keep-me" in w.document.material_names()  # cancelled: nothing lost
    w.close()
    assert w.isVisible()  # closing was cancelled too
    w.ask_unsaved = lambda: "discard"
    w.new_project()
    assert "keep-me" not in w.document.material_names()


def test_errors_show_a_dialog_and_lose_nothing(fresh, tmp_path):
    w = fresh
    w.document.add_material("lambert", name="edited")
    before = w.document.to_dict()
    bad_mesh = tmp_path / "bad.obj"
    bad_mesh.write_text("v 0 0 0\nv nan 1 0\nv 1 1 0\nf 1 2 3\n")
    w.import_mesh(bad_mesh)
    broken = tmp_path / "broken.json"
    broken.write_text('{"version": 1, "materials": [')
    assert not w.open_project(broken)
    corrupt = tmp_path / "corrupt.binary"
    corrupt.write_bytes(
        np.array([90, 90, 180], dtype="<i4").tobytes() + b"\x00" * 100
    )  # right header, no table
    assert not w.load_measured(corrupt)
    assert len(w.errors) == 3
    assert "NaN" in w.errors[0] or "nan" in w.errors[0].lower()
    assert "broken.json" in w.errors[1] and "line 1" in w.errors[1]
    assert "truncated" in w.errors[2]
    assert w.document.to_dict() == before
    assert w.last_error_box.isVisible()
    w.last_error_box.close()


def test_drop_files_imports_and_loads(fresh, tmp_path):
    w = fresh
    mesh = write_obj(tmp_path / "dropped.obj", {"cube": (0, 0, 0)})
    mime = QMimeData()
    mime.setUrls([QUrl.fromLocalFile(str(mesh))])
    event = QDropEvent(
        QPointF(10, 10),
        Qt.DropAction.CopyAction,
        mime,
        Qt.MouseButton.LeftButton,
        Qt.KeyboardModifier.NoModifier,
    )
    w.dropEvent(event)
    assert [o.name for o in w.document.objects()] == ["dropped"]


def test_autosave_restores_edits_after_a_crash(fresh):
    w = fresh
    w.document.add_material("lambert", name="unsaved-work")
    w.document.set_param("kd", 0.123)
    w.autosave()
    mine = settings.autosave_path()
    assert mine.exists()
    dead = settings.autosave_path(pid=2**22 + 777)  # as if this session had crashed
    os.replace(mine, dead)
    w.document.replace(Scene(), None)  # the next session starts empty
    assert w.restore_autosave(ask=False)
    assert w.document.material("unsaved-work").params["kd"] == (0.123, 0.123, 0.123)
    assert w.document.dirty
    assert not dead.exists()


# ---- lights, camera, environment: the property pages -------------------------------------------------


def _floor_with_light(w, tmp_path):
    """A floor (one part of a two-part file) lit by one quad light, selected."""
    w.import_mesh(write_obj(tmp_path / "floor.obj", {"slab": (0, -1, 0)}))
    w.document.add_light("quad", {"corner": (0.0, 2.0, 0.0), "radiance": (2.0, 2.0, 2.0)})
    w.scene_tree.setCurrentItem(w.scene_tree.item_for("light", 0))  # what a click does
    return w.item_editor.quad_page


def test_light_page_edits_radiance_through_the_document(fresh, tmp_path):
    w = fresh
    page = _floor_with_light(w, tmp_path)
    assert w.document.selected_item == ("light", 0)
    assert w.item_editor.current_page() is page and w.material_dock.windowTitle() == "Light"
    assert w.item_editor.isVisible()
    page.rows["radiance"].spins[1].setValue(7.0)  # a user edit of the green channel
    assert w.document.scene.lights[0].radiance == (2.0, 7.0, 2.0)
    # an edge parallel to the other is refused with the schema's reason; nothing changes
    page.rows["edge2"].spins[0].setValue(1.0)  # (1, 0, 1): still spans an area
    assert w.document.scene.lights[0].edge2 == (1.0, 0.0, 1.0)
    before = w.document.to_dict()
    page.rows["edge2"].spins[2].setValue(0.0)  # (1, 0, 0) = edge1
    assert w.document.to_dict() == before
    assert "lights[0]: edge1 and edge2 span no area" in w.errors[-1]
    assert "span no area" in w.item_editor.message.text()
    assert page.rows["edge2"].value() == (1.0, 0.0, 1.0)  # the fields show the document again
    w.last_error_box.close()
    w.document.undo()  # edge2
    w.document.undo()
    assert w.document.scene.lights[0].radiance == (2.0, 2.0, 2.0)
    assert page.rows["radiance"].value() == (2.0, 2.0, 2.0)  # the page follows undo
    w.document.redo()
    assert page.rows["radiance"].value() == (2.0, 7.0, 2.0)
    page.rows["radiance"].set_colour(QColor.fromRgbF(1.0, 0.0, 0.0))  # the picker: strength 7 kept
    assert w.document.scene.lights[0].radiance == (7.0, 0.0, 0.0)
    assert w.scene_tree.selectedItems()[0] is w.scene_tree.item_for("light", 0)  # still selected


def test_light_edit_reaches_the_saved_file_and_the_render(fresh, tmp_path):
    from renderer.render import render

    w = fresh
    page = _floor_with_light(w, tmp_path)
    w.document.assign_material("floor", "lambert")
    w.document.set_camera({"position": (0.5, 3.0, 3.0), "target": (0.5, 0.0, 0.5), "fov_deg": 50.0})

    def small_render():
        scene = w.render_scene()  # what the render panel renders
        return render(
            scene, spp=1, width=32, height=24, sampler="cosine", max_depth=1, threads=1
        ).film.image()

    first = small_render()
    assert first.mean() > 0.0
    page.rows["radiance"].strength.spin.setValue(4.0)  # the strength slider's spin box: colour kept
    assert w.document.scene.lights[0].radiance == (4.0, 4.0, 4.0)
    assert w.render_scene().lights[0].radiance == (4.0, 4.0, 4.0)
    # the same seed and paths: direct light scales exactly with the emitted radiance
    np.testing.assert_allclose(small_render(), 2.0 * first, rtol=1e-5, atol=1e-7)
    project = tmp_path / "lit.json"
    assert w.save_project_as(project)
    saved = json.loads(project.read_text())
    assert saved["lights"][0]["radiance"] == [4.0, 4.0, 4.0]
    assert saved["camera"]["fov_deg"] == pytest.approx(50.0)


def test_camera_page_moves_the_viewport_and_the_view_records_the_camera(fresh, tmp_path, qtbot):
    w = fresh
    w.import_mesh(write_obj(tmp_path / "cube.obj", {"cube": (0, 0, 0)}))
    framed = w.document.scene.camera
    assert framed != Camera() and w.document.undo_text().startswith("Import")  # framing is part of the import
    w.scene_tree.setCurrentItem(w.scene_tree.item_for("camera"))
    page = w.item_editor.camera_page
    assert w.item_editor.current_page() is page and w.material_dock.windowTitle() == "Camera"
    page.rows["fov_deg"].spin.setValue(35.0)
    page.rows["position"].spins[2].setValue(9.0)
    cam = w.viewport.plotter.camera
    assert cam.view_angle == pytest.approx(35.0) and cam.position[2] == pytest.approx(9.0)
    assert w.render_scene().camera.fov_deg == pytest.approx(35.0)
    assert w.render_scene().camera.position[2] == pytest.approx(9.0)
    before = w.document.scene.camera
    page.rows["target"].set_value((before.position[0] + 1.0, *before.position[1:]))
    page.rows["target"].spins[0].setValue(before.position[0])  # target = position
    assert w.document.scene.camera == before and "camera.target: the target coincides" in w.errors[-1]
    w.last_error_box.close()
    # moving the view records the camera (one undo step), and undo moves the view back
    cam.azimuth = 0.0
    w.viewport.plotter.camera.Azimuth(40.0)
    w.viewport.view_moved()
    assert w.document.undo_text() == "Move camera"
    assert w.document.scene.camera.position == pytest.approx(cam.position)
    assert page.rows["position"].value() == pytest.approx(tuple(cam.position), abs=1e-3)
    # the same through the interactor: a left drag (press, the style moves the camera, release) is recorded
    iren = w.viewport.plotter.iren.interactor
    w.document.end_merge()  # its own undo step (not merged with the move above, however fast the machine)
    iren.SetEventPosition(100, 100)
    w.viewport._on_press(iren, "LeftButtonPressEvent")
    cam.Elevation(10.0)
    iren.SetEventPosition(130, 110)
    w.viewport._on_release(iren, "LeftButtonReleaseEvent")
    qtbot.waitUntil(lambda: w.document.scene.camera.position == pytest.approx(cam.position), timeout=5000)
    assert w.document.undo_text() == "Move camera"
    w.document.undo()
    w.document.undo()
    assert w.viewport.plotter.camera.position == pytest.approx((before.position[0], before.position[1], 9.0))
    w.document.undo()
    w.document.undo()
    assert w.document.scene.camera == framed  # the view that framed the imported cube
    assert w.viewport.plotter.camera.position == pytest.approx(framed.position)
    w.document.undo()  # the import (with its framing)
    assert w.document.scene.camera == Camera()


def test_add_and_delete_lights_with_the_delete_key(fresh, tmp_path):
    w = fresh
    w.import_mesh(write_obj(tmp_path / "cube.obj", {"cube": (0, 0, 0)}))
    w.item_editor.add_point_button.click()
    w.item_editor.add_quad_button.click()
    assert [x.type for x in w.document.scene.lights] == ["point", "quad"]
    assert w.scene_tree.selectedItems()[0] is w.scene_tree.item_for("light", 1)  # the new light is selected
    assert len(w.viewport.light_actors) == 2
    w.document.set_light_field(0, "position", (0.5, 0.5, 3.0))
    w.viewport.plotter.reset_camera()
    w.viewport.plotter.render()
    x, y = w.viewport.display_point(np.array([0.5, 0.5, 3.0]))
    assert w.viewport.light_at(x, y) == 0  # the point light's marker is under its position
    w.viewport._press = (x, y)  # a click there selects the light
    w.viewport.plotter.iren.interactor.SetEventPosition(x, y)
    w.viewport._on_release(w.viewport.plotter.iren.interactor, "LeftButtonReleaseEvent")
    assert w.document.selected_item == ("light", 0)
    marker = w.viewport.light_actors[0][0].GetProperty().GetColor()
    assert marker[0] > 0.9 and marker[2] < 0.1  # drawn in the selection colour
    w.delete_action.trigger()
    assert [x.type for x in w.document.scene.lights] == ["quad"] and len(w.viewport.light_actors) == 1
    assert w.document.selected_item is None and w.document.objects()  # the object was not touched
    w.document.undo()
    assert [x.type for x in w.document.scene.lights] == ["point", "quad"]
    assert w.document.scene.lights[0].position == (0.5, 0.5, 3.0)


def test_environment_page(fresh, tmp_path):
    from app.main_window import demo_scene_path

    w = fresh
    w.import_mesh(write_obj(tmp_path / "cube.obj", {"cube": (0, 0, 0)}))
    w.scene_tree.setCurrentItem(w.scene_tree.item_for("environment"))
    editor = w.item_editor
    assert editor.current_page() is editor.environment_page
    box = editor.environment_kind
    box.setCurrentIndex(box.findData("constant"))
    box.activated.emit(box.currentIndex())
    editor.environment_page.rows["radiance"].spins[0].setValue(0.9)
    assert w.document.scene.environment == ConstantEnvironment(type="constant", radiance=(0.9, 0.5, 0.5))
    assert w.render_scene().environment.radiance == (0.9, 0.5, 0.5)
    demo = demo_scene_path()
    if demo is None:
        return
    editor.ask_environment_map = lambda: str(tmp_path / "missing.exr")
    box.setCurrentIndex(box.findData("map"))
    box.activated.emit(box.currentIndex())
    assert "not found" in w.errors[-1] and w.document.scene.environment.type == "constant"
    assert box.currentData() == "constant"  # the chooser shows the document again
    w.last_error_box.close()
    editor.ask_environment_map = lambda: str(demo.parent / "sky.exr")
    box.setCurrentIndex(box.findData("map"))
    box.activated.emit(box.currentIndex())
    editor.environment_page.rows["rotate_deg"].spin.setValue(45.0)
    env = w.render_scene().environment
    assert env.type == "map" and env.rotate_deg == 45.0
    w.document.undo()
    w.document.undo()
    assert w.document.scene.environment.type == "constant"


def test_deleted_part_stays_deleted_after_save_and_open(fresh, tmp_path):
    from renderer.world import World

    w = fresh
    w.import_mesh(write_obj(tmp_path / "pair.obj", {"left": (0, 0, 0), "right": (2, 0, 0)}))
    w.document.select_object("pair/right")
    w.delete_action.trigger()
    w.document.undo()  # undo restores the part ...
    assert sorted(o.name for o in w.document.objects()) == ["pair/left", "pair/right"]
    assert World(w.render_scene()).n_triangles == 24
    w.document.redo()  # ... and redo deletes it again
    assert World(w.render_scene()).n_triangles == 12  # the render has one cube
    project = tmp_path / "pair.json"
    assert w.save_project_as(project)
    assert json.loads(project.read_text())["meshes"][0]["exclude_groups"] == ["right"]
    w.new_project()
    assert w.open_project(project)
    assert [o.name for o in w.document.objects()] == ["pair/left"]
    assert set(w.viewport.actors) == {"pair/left"}
    assert World(w.render_scene()).n_triangles == 12
