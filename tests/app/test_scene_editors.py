"""The light, camera and environment pages are generated from the scene schema: a row per field, of the
field's kind, with the schema's bounds; edits through them move lights, set radiance and the camera, switch the
environment, and undo/redo restores both the document and the pages."""

from __future__ import annotations

import pytest

from app.editors.params import FloatRow
from app.editors.rows import CheckRow, EmissionRow, NumberOrVec3Row, Vec3Row
from app.editors.schema_form import SchemaForm
from core.scene import (
    MAX_SCALE,
    MIN_SCALE,
    Camera,
    ConstantEnvironment,
    MapEnvironment,
    PointLight,
    QuadLight,
    Transform,
)
from tests.app.meshes import write_obj

pytestmark = pytest.mark.gui


@pytest.mark.parametrize("model", [PointLight, QuadLight, Camera, ConstantEnvironment, MapEnvironment])
def test_a_row_for_every_editable_field_of_the_schema(qtbot, model):
    form = SchemaForm(model, model.__name__)
    qtbot.addWidget(form)
    editable = {n for n, f in model.model_fields.items() if n != "type" and f.annotation is not str}
    assert set(form.rows) == editable
    for name, row in form.rows.items():
        annotation = model.model_fields[name].annotation
        if annotation is bool:
            assert isinstance(row, CheckRow)
        elif annotation is float:
            assert isinstance(row, FloatRow)
        elif name in ("intensity", "radiance"):
            assert isinstance(row, EmissionRow)  # non-negative RGB: colour and strength
        else:
            assert isinstance(row, Vec3Row)
    if model is Camera:  # the schema's bounds (0, 180) narrowed by the hint to what a slider can reach
        assert (form.rows["fov_deg"].param.lo, form.rows["fov_deg"].param.hi) == (1.0, 179.0)


@pytest.fixture
def scene(window, tmp_path):
    window.ask_unsaved = lambda: "discard"
    window.new_project()
    window.errors.clear()
    window.import_mesh(write_obj(tmp_path / "cube.obj", {"cube": (0, 0, 0)}))
    yield window
    window.errors.clear()


def test_point_light_moved_and_brightened_through_its_page_then_undone(scene):
    w, doc = scene, scene.document
    w.item_editor.add_point_button.click()
    page = w.item_editor.point_page
    assert w.item_editor.current_page() is page
    page.rows["position"].spins[1].setValue(5.0)  # move it up
    page.rows["intensity"].strength.spin.setValue(40.0)  # brighter, same colour
    light = doc.scene.lights[0]
    assert light.position == (0.0, 5.0, 0.0) and light.intensity == (40.0, 40.0, 40.0)
    assert doc.undo_text() == "Set light 1 intensity"
    doc.undo()
    assert doc.scene.lights[0].intensity == (10.0, 10.0, 10.0)
    assert page.rows["intensity"].value() == (10.0, 10.0, 10.0)  # the page follows undo
    doc.undo()
    assert page.rows["position"].value() == (0.0, 3.0, 0.0)
    doc.redo()
    doc.redo()
    assert doc.scene.lights[0] == light and page.rows["intensity"].value() == (40.0, 40.0, 40.0)
    assert w.render_scene().lights[0].position == (0.0, 5.0, 0.0)


def test_camera_from_the_viewport_view_and_fov(scene):
    w, doc = scene, scene.document
    w.scene_tree.setCurrentItem(w.scene_tree.item_for("camera"))
    cam = w.viewport.plotter.camera
    cam.Azimuth(30.0)  # the user turned the view without it being recorded yet
    w.item_editor.view_button.click()
    assert doc.scene.camera.position == pytest.approx(cam.position)
    assert doc.undo_text() == "Camera from the view"
    w.item_editor.camera_page.rows["fov_deg"].spin.setValue(25.0)
    assert doc.scene.camera.fov_deg == 25.0 and cam.view_angle == pytest.approx(25.0)
    assert "fov 25 deg" in w.scene_tree.item_for("camera").text(0)
    doc.undo()
    doc.undo()
    assert cam.view_angle == pytest.approx(doc.scene.camera.fov_deg) and doc.scene.camera.fov_deg != 25.0


def test_environment_constant_then_map_scale_rotation_and_undo(scene, tmp_path):
    from app.main_window import demo_scene_path

    w, doc = scene, scene.document
    w.scene_tree.setCurrentItem(w.scene_tree.item_for("environment"))
    page = w.item_editor.environment_page
    page.kind.setCurrentIndex(page.kind.findData("constant"))
    page.kind.activated.emit(page.kind.currentIndex())
    assert page.constant.isVisibleTo(page) and not page.map.isVisibleTo(page)
    w.item_editor.ask_environment_map = lambda: str(demo_scene_path().parent / "sky.exr")
    page.kind.setCurrentIndex(page.kind.findData("map"))
    page.kind.activated.emit(page.kind.currentIndex())
    assert page.map.isVisibleTo(page) and not page.constant.isVisibleTo(page)
    page.rows["scale"].spin.setValue(2.0)
    page.rows["rotate_deg"].spin.setValue(-90.0)
    env = doc.scene.environment
    assert (env.type, env.scale, env.rotate_deg, page.map_path.text()) == ("map", 2.0, -90.0, "sky.exr")
    assert "environment (map)" in w.scene_tree.item_for("environment").text(0)
    for _ in range(3):
        doc.undo()
    assert doc.scene.environment.type == "constant" and page.kind.currentData() == "constant"
    doc.undo()
    assert doc.scene.environment is None and page.kind.currentData() is None
    for _ in range(4):
        doc.redo()
    assert doc.scene.environment == env


def test_material_emission_makes_an_area_light_and_undoes(scene):
    w, doc = scene, scene.document
    name = doc.object("cube").material
    doc.select_material(name)
    w.material_editor.emission.spins[0].setValue(2.0)
    assert doc.material(name).emission == (2.0, 0.0, 0.0) and doc.material(name).emissive
    assert w.render_scene().environment is None  # an emitter lights the scene: no fallback sky
    doc.undo()
    assert not doc.material(name).emissive and w.material_editor.emission.value() == (0.0, 0.0, 0.0)


def test_object_placement_moves_the_mesh_everywhere_and_undoes(scene):
    w, doc = scene, scene.document
    doc.select_object("cube")
    editor = w.object_editor
    assert editor.isVisibleTo(w) and set(editor.form.rows) == {"translate", "rotate_deg", "scale"}
    editor.form.rows["translate"].spins[1].setValue(2.0)  # up by 2
    assert doc.scene.meshes[0].transform.translate == (0.0, 2.0, 0.0)
    assert w.viewport.meshes["cube"].bounds[2] == pytest.approx(2.0)  # the viewport's mesh moved
    editor.smooth.setChecked(True)
    assert doc.object("cube").smooth and w.render_scene().meshes[0].smooth
    doc.undo()
    doc.undo()
    assert doc.scene.meshes[0].transform.translate == (0.0, 0.0, 0.0) and not doc.object("cube").smooth
    assert w.viewport.meshes["cube"].bounds[2] == pytest.approx(0.0)
    assert editor.form.rows["translate"].value() == (0.0, 0.0, 0.0)
    doc.select_object(None)
    assert not editor.isVisibleTo(w)


def test_transform_scale_union_gets_a_uniform_or_per_axis_row(qtbot):
    form = SchemaForm(Transform, "Transform")
    qtbot.addWidget(form)
    assert set(form.rows) == set(Transform.model_fields)  # the union is no longer left out
    row = form.rows["scale"]
    assert isinstance(row, NumberOrVec3Row)
    # within the schema's bounds (a positive minimum the spin box can show: 1e-6 would round to 0)
    assert MIN_SCALE <= row.spins[0].minimum() <= 1e-4 and row.spins[0].maximum() == MAX_SCALE
    seen = []
    form.edited.connect(lambda field, value: seen.append((field, value)))
    row.set_value(2.0)
    assert row.uniform.isChecked() and not row.spins[2].isEnabled() and row.value() == 2.0 and not seen
    row.spins[0].setValue(3.0)
    assert seen[-1] == ("scale", 3.0) and row.spins[2].value() == 3.0  # one number for every axis
    row.uniform.setChecked(False)
    assert len(seen) == 1 and row.spins[2].isEnabled()  # three equal numbers: nothing to edit yet
    row.spins[1].setValue(0.5)
    assert seen[-1] == ("scale", (3.0, 0.5, 3.0))
    row.set_value((1.0, 2.0, 4.0))
    assert not row.uniform.isChecked() and row.value() == (1.0, 2.0, 4.0)
    row.uniform.setChecked(True)  # back to one factor: the first axis's
    assert seen[-1] == ("scale", 1.0)


def test_object_non_uniform_scale_through_its_row_and_undo(scene):
    w, doc = scene, scene.document
    doc.select_object("cube")
    row = w.object_editor.form.rows["scale"]
    assert row.uniform.isChecked() and row.value() == 1.0
    row.uniform.setChecked(False)
    row.spins[1].setValue(2.0)  # twice as tall
    assert doc.scene.meshes[0].transform.scale == (1.0, 2.0, 1.0)
    bounds = w.viewport.meshes["cube"].bounds
    assert (bounds[1] - bounds[0], bounds[3] - bounds[2]) == pytest.approx((1.0, 2.0))
    assert w.render_scene().meshes[0].transform.scale == (1.0, 2.0, 1.0)
    doc.undo()
    assert doc.scene.meshes[0].transform.scale == 1.0 and row.uniform.isChecked() and row.value() == 1.0
    assert w.viewport.meshes["cube"].bounds[3] == pytest.approx(1.0)
    doc.redo()
    assert row.value() == (1.0, 2.0, 1.0) and not row.uniform.isChecked()
