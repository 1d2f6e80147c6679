"""Scene editing in the real window: import, assign, pick, save/load, undo, prompts, autosave, drops, errors."""

from __future__ import annotations

import os

import numpy as np
import pytest
from PySide6.QtCore import QMimeData, QPointF, Qt, QUrl
from PySide6.QtGui import QDropEvent

from app import settings
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
    assert w.viewport.actors == {} and w.document.data.objects == []
    w.document.redo()
    assert set(w.viewport.actors) == set(names)


def test_click_in_viewport_selects_and_tree_follows(fresh, tmp_path, qtbot):
    w = fresh
    w.import_mesh(write_obj(tmp_path / "one.obj", {"cube": (0, 0, 0)}))
    name = w.document.data.objects[0].name
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
    saved_objects = [(o.name, o.part, o.material) for o in w.document.data.objects]
    saved_material = w.document.material()
    w.new_project()
    assert w.document.data.objects == []
    assert w.open_project(project)
    assert [(o.name, o.part, o.material) for o in w.document.data.objects] == saved_objects
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
    assert [o.name for o in w.document.data.objects] == ["dropped"]


def test_autosave_restores_edits_after_a_crash(fresh):
    w = fresh
    w.document.add_material("lambert", name="unsaved-work")
    w.document.set_param("kd", 0.123)
    w.autosave()
    mine = settings.autosave_path()
    assert mine.exists()
    dead = settings.autosave_path(pid=2**22 + 777)  # as if this session had crashed
    os.replace(mine, dead)
    w.document.replace(type(w.document.data)(), None)  # the next session starts empty
    assert w.restore_autosave(ask=False)
    assert w.document.material("unsaved-work").params["kd"] == (0.123, 0.123, 0.123)
    assert w.document.dirty
    assert not dead.exists()


# ---- lights, camera, environment: the property pages -------------------------------------------------


def _floor_with_light(w, tmp_path):
    """A floor (one part of a two-part file) lit by one quad light, selected."""
    w.import_mesh(write_obj(tmp_path / "floor.obj", {"slab": (0, -1, 0)}))
    w.document.add_light("quad", {"corner": [0.0, 2.0, 0.0], "radiance": [2.0, 2.0, 2.0]})
    w.scene_tree.setCurrentItem(w.scene_tree.item_for("light", 0))  # what a click does
    return w.item_editor.quad_page


def test_light_page_edits_radiance_through_the_document(fresh, tmp_path):
    w = fresh
    page = _floor_with_light(w, tmp_path)
    assert w.document.selected_item == ("light", 0)
    assert w.item_editor.current_page() is page and w.material_dock.windowTitle() == "Light"
    assert w.item_editor.isVisible()
    page.rows["radiance"].spins[1].setValue(7.0)  # a user edit of the green channel
    assert w.document.lights()[0]["radiance"] == [2.0, 7.0, 2.0]
    # an edge parallel to the other is refused with the schema's reason; nothing changes
    page.rows["edge2"].spins[0].setValue(1.0)  # (1, 0, 1): still spans an area
    assert w.document.lights()[0]["edge2"] == [1.0, 0.0, 1.0]
    before = w.document.to_dict()
    page.rows["edge2"].spins[2].setValue(0.0)  # (1, 0, 0) = edge1
    assert w.document.to_dict() == before
    assert "lights[0]: edge1 and edge2 span no area" in w.errors[-1]
    assert "span no area" in w.item_editor.message.text()
    assert page.rows["edge2"].value() == (1.0, 0.0, 1.0)  # the fields show the document again
    w.last_error_box.close()
    w.document.undo()  # edge2
    w.document.undo()
    assert w.document.lights()[0]["radiance"] == [2.0, 2.0, 2.0]
    assert page.rows["radiance"].value() == (2.0, 2.0, 2.0)  # the page follows undo
    w.document.redo()
    assert page.rows["radiance"].value() == (2.0, 7.0, 2.0)
