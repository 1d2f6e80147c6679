"""The real main window under Xvfb: the BRDF exploration views follow edits of the current material."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

pytestmark = pytest.mark.gui


@pytest.fixture(autouse=True)
def _explore_tab(window):
    """These views are drawn while their tab is shown (an edit on another tab leaves them stale until it is):
    every test starts on the Explore tab, whatever tab an earlier test of the shared window left open."""
    window.tabs.setCurrentWidget(window.explore)
    window.refresh_now()


def _select(window, model: str) -> None:
    doc = window.document
    if model not in doc.material_names():
        doc.add_material(model, name=model)
    doc.select_material(model)
    window.refresh_now()


def test_window_opens_with_every_explore_view(window):
    assert window.isVisible()
    assert window.lobe_view.mesh.n_points > 0
    assert window.lobe_view.max_value > 0
    assert window.polar_view.values.shape[1] == 3
    assert window.sphere_view.image_rgb.max() > 0


def test_slider_edit_reshapes_the_lobe_and_slice(window, qtbot):
    _select(window, "phong")
    editor = window.material_editor.param_editor
    before_points = np.array(window.lobe_view.mesh.points)
    before_slice = window.polar_view.values.copy()
    name = next(p.name for p in editor.model.params if p.log)  # the exponent
    row = editor.rows[name]
    row.slider.setValue(row.slider.value() // 2 if row.slider.value() > 500 else row.slider.value() + 400)
    window.refresh_now()
    assert window.document.material().params[name] == pytest.approx(row.value())
    after = np.array(window.lobe_view.mesh.points)
    assert np.max(np.abs(after - before_points)) > 1e-3
    assert not np.allclose(window.polar_view.values, before_slice)
    window.document.undo()
    window.refresh_now()
    assert np.allclose(window.lobe_view.mesh.points, before_points)
    assert editor.rows[name].slider.value() == row.mapping.to_slider(window.document.material().params[name])


def test_spin_box_typing_sets_the_value_and_undo_restores_the_widget(window, qtbot):
    _select(window, "phong")
    editor = window.material_editor.param_editor
    name, row = next((n, r) for n, r in editor.rows.items() if hasattr(r, "spin"))
    old = window.document.material().params[name]
    target = round(0.5 * (row.param.lo + row.param.hi), 1)
    row.spin.selectAll()
    qtbot.keyClicks(row.spin, f"{target}")
    qtbot.keyClick(row.spin, Qt.Key.Key_Return)
    assert window.document.material().params[name] == pytest.approx(target, rel=1e-3)
    window.document.end_merge()
    window.undo_action.trigger()
    assert window.document.material().params[name] == old
    assert window.material_editor.param_editor.rows[name].value() == pytest.approx(old, rel=1e-3)


def test_model_switch_rebuilds_the_editor(window):
    _select(window, "phong")
    box = window.material_editor.model_box
    box.setCurrentIndex(box.findData("lambert"))
    box.activated.emit(box.findData("lambert"))
    window.refresh_now()
    assert window.document.material().model == "lambert"
    assert set(window.material_editor.param_editor.rows) == {"kd"}
    assert "Lambert" in window.lobe_view.caption.text()
    window.document.undo()
    window.refresh_now()
    assert window.document.material().model == "phong"


def test_colour_picker_sets_linear_rgb(window):
    from PySide6.QtGui import QColor

    _select(window, "lambert")
    row = window.material_editor.param_editor.rows["kd"]
    row.set_color(QColor.fromRgbF(1.0, 0.0, 0.0))
    window.refresh_now()
    assert window.document.material().params["kd"] == pytest.approx((1.0, 0.0, 0.0))
    img = window.sphere_view.image_rgb
    assert img[..., 0].max() > 0 and img[..., 1].max() == 0 and img[..., 2].max() == 0


def test_direction_by_typing_and_dragging(window, qtbot):
    _select(window, "phong")
    ed = window.direction_editor
    ed.theta.setValue(60.0)
    assert window.document.theta_deg == 60.0
    window.refresh_now()
    peak_60 = window.polar_view.theta[np.argmax(window.polar_view.values[:, 1])]
    assert abs(np.degrees(peak_60) - 60.0) < 10.0
    pad = ed.pad
    target = pad.point_for(20.0, 90.0)
    qtbot.mouseClick(pad, Qt.MouseButton.LeftButton, pos=QPoint(round(target.x()), round(target.y())))
    assert abs(window.document.theta_deg - 20.0) < 3.0
    assert abs(window.document.phi_deg - 90.0) < 5.0
    assert ed.theta.value() == pytest.approx(window.document.theta_deg, abs=0.05)


def test_dragging_the_light_relights_the_sphere(window, qtbot):
    _select(window, "lambert")
    view = window.sphere_view
    qtbot.mouseClick(view, Qt.MouseButton.LeftButton, pos=QPoint(view.width() // 2, view.height() // 2))
    window.refresh_now()
    assert window.document.light_dir[2] > 0.99
    centre = view.image_rgb[view.resolution // 2, view.resolution // 2].astype(int)
    x0 = view.width() // 2 - min(view.width(), view.height()) // 2
    qtbot.mouseClick(view, Qt.MouseButton.LeftButton, pos=QPoint(x0 + 2, view.height() // 2))
    window.refresh_now()
    assert window.document.light_dir[0] < -0.9
    # light from the left: the centre darkens, the left rim brightens
    assert view.image_rgb[view.resolution // 2, view.resolution // 2].astype(int).sum() < centre.sum()


def test_albedo_panel_shows_the_quadrature(window, qtbot):
    _select(window, "lambert")
    window.document.set_param("kd", (0.3, 0.5, 0.7))
    window.refresh_now()
    window.flush_slow_jobs()
    view = window.albedo_view
    qtbot.waitUntil(lambda: window.jobs_idle("albedo") and view.values.size > 0, timeout=60000)
    # Lambert's directional albedo is kd at every angle (the quadrature states ~1e-3 accuracy here)
    assert np.allclose(view.values, [0.3, 0.5, 0.7], atol=2e-3)
    lum = 0.2126 * 0.3 + 0.7152 * 0.5 + 0.0722 * 0.7  # the info line quotes the luminance
    assert f"0&deg;: {lum:.3f}" in window.material_editor.info.text()


def test_exports_sample_sets_and_plots(window, tmp_path):
    _select(window, "lambert")
    window.sampling_view.strategy.setCurrentText("cosine")
    rows = {}
    for suffix in ("csv", "npy", "ply"):
        out = window.export_samples(tmp_path / f"s.{suffix}", n=500)
        assert out is not None and out.exists()
    rows["csv"] = np.loadtxt(tmp_path / "s.csv", delimiter=",", skiprows=1)
    rows["npy"] = np.load(tmp_path / "s.npy")
    ply = (tmp_path / "s.ply").read_text().splitlines()
    rows["ply"] = np.array([[float(v) for v in line.split()] for line in ply[ply.index("end_header") + 1 :]])
    assert "element vertex 500" in ply
    for r in rows.values():
        assert r.shape == (500, 5)
        assert np.allclose(np.linalg.norm(r[:, :3], axis=1), 1.0, atol=1e-6)
        # cosine sampling of Lambert: pdf = cos/pi, weight = f cos/pdf = albedo (luminance of kd)
        assert np.allclose(r[:, 3], r[:, 2] / np.pi, rtol=1e-6)
        kd = window.document.material().params["kd"]
        assert np.allclose(r[:, 4], 0.2126 * kd[0] + 0.7152 * kd[1] + 0.0722 * kd[2], rtol=1e-6)
    assert window.export_samples(tmp_path / "s.txt") is None and "use .csv" in window.errors[-1]
    plots = window.export_plots(tmp_path, "svg")
    assert len(plots) == 3 and all(p.read_text().lstrip().startswith("<?xml") for p in plots)


def test_measured_material_from_a_merl_file(window):
    from importlib.resources import files

    merl = next(
        (p for p in files("resources").joinpath("materials").iterdir() if p.name.endswith(".binary")), None
    )
    if merl is None:
        pytest.skip("no bundled MERL file in this build")
    name = window.document.add_material("lambert", name="measured")
    before = np.array(window.lobe_view.mesh.points)
    assert window.load_measured(str(merl))
    window.refresh_now()
    assert window.document.material(name).measured is not None
    assert "MERL" in window.material_editor.model_box.currentText()
    assert not window.material_editor.param_editor.isVisibleTo(window.material_editor)
    assert np.max(np.abs(np.array(window.lobe_view.mesh.points) - before)) > 1e-3
    window.document.undo()
    assert window.document.material(name).measured is None


def test_polar_slice_changes_scale_without_a_full_draw(window):
    """A peak 100x higher (a sharper lobe) moves the outer ring to a round limit above it, relabels the rings
    and still draws only the curves and labels; the curves are the values divided by that limit."""
    from core.brdf import make_brdf

    view = window.polar_view
    wo = np.array([0.5, 0.0, np.sqrt(0.75)])
    view.show_slice(make_brdf("ggx", {"alpha": 0.5}), wo)
    view.canvas.draw()
    low, labels = view.r_max, view.ring_labels()
    full = view.full_draws
    view.show_slice(make_brdf("ggx", {"alpha": 0.02}), wo)
    peak = float(view.values.max())
    assert view.full_draws == full
    assert view.r_max > 10.0 * low and 0.4 * view.r_max <= 1.05 * peak <= view.r_max
    assert view.ring_labels() != labels and float(view.ring_labels()[-1]) == pytest.approx(view.r_max)
    curve = view._rgb[0].get_ydata()
    np.testing.assert_allclose(curve * view.r_max, view.values[:, 0], rtol=1e-12)


def _count_paints(widget):
    """An event filter on ``widget`` that counts its paint events (kept alive by the widget)."""
    from PySide6.QtCore import QEvent, QObject

    class Counter(QObject):
        count = 0

        def eventFilter(self, obj, event):  # noqa: N802 (Qt name)
            if obj is widget and event.type() == QEvent.Type.Paint:
                self.count += 1
            return False

    counter = Counter(widget)
    widget.installEventFilter(counter)
    return counter


def test_polar_slice_and_sampler_view_update_by_blitting(window, qtbot):
    """A data edit that keeps the scale redraws only the curves (no full figure draw), the pixels change, and
    they reach the screen with the window's next paint rather than a synchronous repaint of their own."""
    from app.sampling_data import sampling_snapshot
    from core.brdf import make_brdf

    window.tabs.setCurrentWidget(window.explore)  # the polar view on screen, whatever ran before
    wo = np.array([0.5, 0.0, np.sqrt(0.75)])
    for view, show, brdfs in (
        (window.polar_view, lambda b: window.polar_view.show_slice(b, wo), None),
        (window.sampling_view.figure_view, None, None),
    ):
        kd = (0.5, 0.45)  # Lambert: peaks within the kept radial limit, identical titles
        brdfs = [make_brdf("lambert", {"kd": k}) for k in kd]
        if show is None:
            # (Lambert's normalized pictures do not depend on kd: move wo instead, within the node's cell so
            # that the titles stay)
            first = sampling_snapshot(brdfs[0], 30.0, 0.0, n_samples=200, grid=32)
            later = 0.5 * (30.0 + first.tree.cell_deg[1])
            snaps = [first, sampling_snapshot(brdfs[0], later, 0.0, n_samples=200, grid=32)]
            assert snaps[1].tree.tree == first.tree.tree
            show = lambda b, snaps=snaps, brdfs=brdfs: window.sampling_view.show_snapshot(
                snaps[brdfs.index(b)]
            )  # noqa: E731
        show(brdfs[0])
        view.canvas.repaint()  # runs a pending idle draw, if any
        view.canvas.draw()  # a full draw: saves the background
        before = np.asarray(view.canvas.buffer_rgba()).copy()
        full = view.full_draws
        paints = _count_paints(view.canvas)
        show(brdfs[1])
        assert view.full_draws == full
        assert np.any(np.asarray(view.canvas.buffer_rgba()) != before)
        # shown with the window's next paint, not by a repaint of its own (a flush of the whole window)
        assert paints.count == 0
        if view is window.polar_view:  # on the tab shown (the sampler view's tab is hidden: nothing to paint)
            assert view.canvas.isVisible()
            qtbot.waitUntil(lambda paints=paints: paints.count > 0, timeout=5000)


def test_views_on_a_hidden_tab_wait_until_it_is_shown(window, qtbot, tmp_path):
    """An edit made while another tab is current leaves the lobe, the slice and the sphere as they were (no
    work for views nobody sees); showing the Explore tab draws them, through the app's own timer."""
    _select(window, "phong")
    doc = window.document
    name = next(p.name for p in window.material_editor.param_editor.model.params if p.log)
    lobe, polar, sphere = window.lobe_view, window.polar_view, window.sphere_view
    window.tabs.setCurrentWidget(window.sampling_panel)
    window.refresh_now()
    before = (np.array(lobe.mesh.points), polar.values.copy(), sphere.image_rgb.copy())
    doc.set_param(name, doc.material().params[name] * 3.0)
    doc.end_merge()
    window.refresh_now()
    assert np.array_equal(lobe.mesh.points, before[0])
    assert np.array_equal(polar.values, before[1]) and np.array_equal(sphere.image_rgb, before[2])
    plots = window.export_plots(tmp_path, "png")  # an export brings the hidden plots up to date
    assert len(plots) == 3 and not np.array_equal(polar.values, before[1])
    before = (np.array(lobe.mesh.points), polar.values.copy(), sphere.image_rgb.copy())
    doc.set_param(name, doc.material().params[name] * 2.0)
    doc.end_merge()
    window.refresh_now()
    window.tabs.setCurrentWidget(window.explore)  # schedules the redraw
    qtbot.waitUntil(lambda: not np.array_equal(polar.values, before[1]), timeout=10_000)
    assert not np.allclose(lobe.mesh.points, before[0])
    assert not np.array_equal(sphere.image_rgb, before[2])


def test_a_new_status_line_repaints_itself_and_lays_nothing_out(window, qtbot):
    """The status under the polar slice changes with every edit; a QLabel there asked its layout to lay out
    again, up to the window, and the whole tab was repainted twice more. The status line repaints itself only."""
    from PySide6.QtCore import QEvent, QObject

    from core.brdf import make_brdf

    window.tabs.setCurrentWidget(window.explore)
    polar = window.polar_view
    wo = np.array([0.5, 0.0, np.sqrt(0.75)])
    polar.show_slice(make_brdf("phong", {"n": 20.0}), wo)
    qtbot.wait(50)

    class Layouts(QObject):
        count = 0

        def eventFilter(self, obj, event):  # noqa: N802 (Qt name)
            if event.type() == QEvent.Type.LayoutRequest:
                self.count += 1
            return False

    layouts = Layouts()
    watched = [polar, polar.parentWidget(), window.explore]
    for w in watched:
        w.installEventFilter(layouts)
    before = polar.status.text()
    try:
        polar.show_slice(make_brdf("phong", {"n": 90.0}), wo)
        qtbot.wait(50)
    finally:
        for w in watched:
            w.removeEventFilter(layouts)
    assert polar.status.text() != before and "peak" in polar.status.text()
    assert layouts.count == 0


def test_the_material_facts_come_from_the_snapshot_process(window, qtbot, monkeypatch):
    """Once edits pause, the editor shows the albedo and the adaptive table's facts, both made in the snapshot
    process (the table's build and the albedo's quadrature never hold the GUI's interpreter lock); a new
    value's edit makes the process drop the slow facts of the previous one, which are asked again later."""
    from app import snapshot_process
    from app.view_data import albedo_line
    from app.views.albedo import ALBEDO_THETAS_DEG

    _select(window, "phong")
    asked, results = [], {}
    for name in ("table_facts", "albedo"):
        real = getattr(snapshot_process, name)

        def spy(spec, *args, real=real, name=name):
            asked.append((name, spec))
            results[name] = real(spec, *args)
            return results[name]

        monkeypatch.setattr(snapshot_process, name, spy)
    window.material_editor.set_info("adaptive", "")
    window.material_editor.set_info("albedo", "")
    window.albedo_view.values = np.zeros((0, 3))  # (as before any curve)
    window.schedule("brdf")  # as after an edit: the slow jobs start once edits pause
    window.refresh_now()
    window.flush_slow_jobs()
    qtbot.waitUntil(
        lambda: (
            results.get("albedo") is not None
            and "Adaptive table:" in window.material_editor.info.text()
            and np.array_equal(window.albedo_view.values, results["albedo"])
        ),
        timeout=240_000,
    )
    assert {name for name, _ in asked} == {"table_facts", "albedo"}
    assert all(spec[0] == "phong" for _, spec in asked)
    assert "KiB" in window.material_editor.info.text()
    assert np.all(np.isfinite(results["albedo"])) and np.all(results["albedo"] > 0)
    assert albedo_line(ALBEDO_THETAS_DEG, results["albedo"]) in window.material_editor.info.text()
