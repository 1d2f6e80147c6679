"""Lights and objects dragged in the real viewport (VTK sphere widgets driven by the interactor's own mouse
events): the drag moves the light or object in the document as one undo step, its page's fields follow, undo
puts it back, and the drag records no camera move."""

from __future__ import annotations

import numpy as np
import pytest

from tests.app.meshes import write_obj

pytestmark = pytest.mark.gui


@pytest.fixture
def scene(window, tmp_path, qapp):
    window.ask_unsaved = lambda: "discard"
    window.new_project()
    window.errors.clear()
    window.tabs.setCurrentWidget(window.scene_panel)
    window.import_mesh(write_obj(tmp_path / "cube.obj", {"cube": (0, 0, 0)}))
    vp = window.viewport
    vp.plotter.camera.position = (0.5, 0.5, 10.0)  # looking down -z at the cube: x right, y up
    vp.plotter.camera.focal_point = (0.5, 0.5, 0.5)
    vp.plotter.camera.up = (0.0, 1.0, 0.0)
    vp.plotter.camera.view_angle = 40.0
    qapp.processEvents()
    vp.plotter.render()
    yield window
    window.errors.clear()


def drag(viewport, start_world, end_world, qapp) -> None:
    """Press the left button on ``start_world``, move in steps to ``end_world`` and release, as the
    interactor's events (what a mouse drag delivers to VTK)."""
    iren = viewport.plotter.iren.interactor
    viewport.plotter.render()
    x0, y0 = viewport.display_point(np.asarray(start_world, float))
    x1, y1 = viewport.display_point(np.asarray(end_world, float))
    iren.SetEventInformation(x0, y0, 0, 0)
    iren.InvokeEvent("MouseMoveEvent")
    iren.InvokeEvent("LeftButtonPressEvent")
    for t in np.linspace(0.0, 1.0, 6)[1:]:
        iren.SetEventInformation(int(round(x0 + t * (x1 - x0))), int(round(y0 + t * (y1 - y0))), 0, 0)
        iren.InvokeEvent("MouseMoveEvent")
    iren.InvokeEvent("LeftButtonReleaseEvent")
    qapp.processEvents()


def test_dragging_a_point_light_moves_it_as_one_undo_step(scene, qapp):
    w, doc, vp = scene, scene.document, scene.viewport
    doc.add_light("point", {"position": (0.5, 2.0, 0.5)})
    camera, steps = doc.scene.camera, doc.undo_steps
    start = np.array(vp.handles.light_widgets[0].GetCenter())
    assert start == pytest.approx((0.5, 2.0, 0.5))
    drag(vp, start, start + (1.0, 0.5, 0.0), qapp)
    moved = np.array(doc.scene.lights[0].position)
    assert moved[0] > 1.2 and moved[1] > 2.3  # right and up, as dragged on the screen
    assert moved[2] == pytest.approx(0.5, abs=1e-6)  # in the plane facing the view
    assert doc.undo_steps == steps + 1 and doc.undo_text() == "Drag light 1"  # one step for the whole drag
    assert doc.selected_item == ("light", 0)
    page = w.item_editor.point_page
    assert w.item_editor.current_page() is page
    assert page.rows["position"].value() == pytest.approx(tuple(moved), abs=1e-3)  # the fields follow
    assert np.array(vp.handles.light_widgets[0].GetCenter()) == pytest.approx(moved)
    assert doc.scene.camera == camera  # the drag moved the light, not the view
    doc.undo()
    assert doc.scene.lights[0].position == pytest.approx((0.5, 2.0, 0.5))
    assert page.rows["position"].value() == pytest.approx((0.5, 2.0, 0.5))
    assert np.array(vp.handles.light_widgets[0].GetCenter()) == pytest.approx(start)
    doc.redo()
    assert doc.scene.lights[0].position == pytest.approx(tuple(moved))


def test_dragging_a_quad_light_moves_its_corner_and_keeps_its_edges(scene, qapp):
    doc, vp = scene.document, scene.viewport
    doc.add_light("quad", {"corner": (0.0, 2.0, 0.0)})
    before = doc.scene.lights[0]
    start = np.array(vp.handles.light_widgets[0].GetCenter())
    assert start == pytest.approx((0.5, 2.0, 0.5))  # the quad's centre
    drag(vp, start, start + (-1.0, 0.0, 0.0), qapp)
    after = doc.scene.lights[0]
    shift = np.array(after.corner) - np.array(before.corner)
    assert shift[0] < -0.7 and abs(shift[1]) < 0.05 and shift[2] == pytest.approx(0.0, abs=1e-6)
    assert (after.edge1, after.edge2) == (before.edge1, before.edge2)
    assert doc.undo_text() == "Drag light 1"
    doc.undo()
    assert doc.scene.lights[0] == before


def test_dragging_the_selected_object_moves_it_and_records_no_camera(scene, qapp):
    w, doc, vp = scene, scene.document, scene.viewport
    assert vp.handles.object_key is None and not vp.handles.object_widget.GetEnabled()
    drag(vp, (0.15, 0.15, 1.0), (0.15, 0.15, 1.0), qapp)  # a click on the cube's front face selects it
    assert doc.selected_object == "cube"
    assert vp.handles.object_key == ("object", "cube") and vp.handles.object_widget.GetEnabled()
    centre = np.array(vp.handles.object_widget.GetCenter())
    assert centre == pytest.approx((0.5, 0.5, 0.5))
    camera, steps = doc.scene.camera, doc.undo_steps
    drag(vp, centre, centre + (0.0, 1.0, 0.0), qapp)
    qapp.processEvents()
    translate = np.array(doc.scene.meshes[0].transform.translate)
    assert translate[1] > 0.7 and abs(translate[0]) < 0.05 and translate[2] == pytest.approx(0.0, abs=1e-6)
    assert doc.undo_steps == steps + 1 and doc.undo_text() == "Drag cube"
    assert doc.scene.camera == camera  # the drag moved the object, not the view
    assert vp.meshes["cube"].bounds[2] == pytest.approx(translate[1])  # the viewport's mesh moved
    assert vp.actors["cube"].GetPosition() == (0.0, 0.0, 0.0)  # the drag's preview offset is gone
    assert w.object_editor.form.rows["translate"].value() == pytest.approx(tuple(translate), abs=1e-3)
    assert w.render_scene().meshes[0].transform.translate == pytest.approx(tuple(translate))
    doc.undo()
    assert doc.scene.meshes[0].transform.translate == (0.0, 0.0, 0.0)
    assert w.object_editor.form.rows["translate"].value() == (0.0, 0.0, 0.0)
    assert np.array(vp.handles.object_widget.GetCenter()) == pytest.approx(centre)


def test_a_click_on_a_handle_selects_the_light_and_edits_nothing(scene, qapp):
    doc, vp = scene.document, scene.viewport
    doc.add_light("point", {"position": (0.5, 2.0, 0.5)})
    doc.select_object("cube")
    steps = doc.undo_steps
    centre = np.array(vp.handles.light_widgets[0].GetCenter())
    drag(vp, centre, centre, qapp)
    assert doc.undo_steps == steps and doc.selected_item == ("light", 0)
