"""The render panel in the real window: two strategies side by side, cancel and restart, exports."""

from __future__ import annotations

import numpy as np
import pytest

from app.capabilities import renderer_available
from tests.app.meshes import write_obj

pytestmark = [
    pytest.mark.gui,
    pytest.mark.skipif(not renderer_available(), reason="renderer/ is not in this build yet"),
]

PREPARE_TIMEOUT_MS = 240_000  # the first render compiles the renderer's kernels for the scene's model


@pytest.fixture
def scene_window(window, tmp_path):
    window.ask_unsaved = lambda: "discard"
    window.new_project()
    window.errors.clear()
    doc = window.document
    doc.add_material("lambert", name="grey", params={"kd": 0.5})
    window.import_mesh(write_obj(tmp_path / "cubes.obj", {"a": (0, 0, 0), "b": (1.5, 0, 0)}))
    panel = window.render_view
    panel.width_box.setValue(32)
    panel.height_box.setValue(24)
    panel.strategy_a.setCurrentText("uniform")
    panel.strategy_b.setCurrentText("cosine")
    panel.mode.setCurrentIndex(panel.mode.findData("spp"))
    panel.reference = None
    yield window
    panel.cancel()


def _wait_done(window, qtbot, timeout=PREPARE_TIMEOUT_MS):
    qtbot.waitUntil(lambda: not window.render_view.running, timeout=timeout)


def test_side_by_side_render_exports_and_errors(scene_window, qtbot, tmp_path):
    w = scene_window
    panel = w.render_view
    panel.spp.setValue(4)
    w.start_render()
    assert w.tabs.currentWidget() is w.render_panel
    _wait_done(w, qtbot)
    assert w.errors == []
    assert set(panel.frames) == {"uniform", "cosine"}
    for frame in panel.frames.values():
        assert frame["spp"] == 4
        assert frame["image"].shape == (24, 32, 3)
        assert np.all(np.isfinite(frame["image"])) and frame["image"].max() > 0
    assert panel.view_a.rgb8.shape == (24, 32, 3) and panel.view_b.rgb8 is not None
    assert "uniform" in panel.counter_a.text() and "4 spp" in panel.counter_a.text()

    # exports: EXR reads back exactly, the composite holds both images side by side
    from renderer.image_io import read_exr

    exr = w.export_render("exr", tmp_path / "shot.exr")
    assert sorted(p.name for p in exr) == ["shot_cosine.exr", "shot_uniform.exr"]
    assert np.array_equal(read_exr(tmp_path / "shot_uniform.exr"), panel.frames["uniform"]["image"])
    (comp,) = w.export_render("composite", tmp_path / "both.png")
    from matplotlib.image import imread

    assert imread(comp).shape[1] >= 2 * 32

    # with a reference the counters and the error plot show RMSE; a reference of itself has RMSE 0 at the end
    ref = tmp_path / "ref.exr"
    from renderer.image_io import write_exr

    write_exr(ref, panel.frames["cosine"]["image"])
    assert w.load_reference(ref)
    w.start_render()
    _wait_done(w, qtbot)
    assert panel.curves["cosine"][-1]["rmse"] == pytest.approx(0.0, abs=1e-7)  # same seed: same image
    assert panel.curves["uniform"][-1]["rmse"] > 0
    csv_path, png_path = w.export_render("errors", tmp_path / "errors")
    lines = csv_path.read_text().splitlines()
    assert lines[0].startswith("strategy,spp,seconds,rmse") and len(lines) == 1 + sum(
        len(v) for v in panel.curves.values()
    )
    assert png_path.stat().st_size > 0


def test_cancel_stops_and_restart_begins_again(scene_window, qtbot):
    w = scene_window
    panel = w.render_view
    panel.strategy_b.setCurrentText("(none)")
    panel.spp.setValue(100_000)
    w.start_render()
    qtbot.waitUntil(lambda: "uniform" in panel.frames, timeout=PREPARE_TIMEOUT_MS)
    w.cancel_render()
    assert not panel.running and "Cancelled" in panel.status_text
    spp_at_cancel = panel.frames["uniform"]["spp"]
    qtbot.wait(300)
    assert panel.frames["uniform"]["spp"] == spp_at_cancel  # no frame of the cancelled render is drawn
    assert spp_at_cancel < 100_000
    panel.start()
    qtbot.waitUntil(lambda: "uniform" in panel.frames, timeout=PREPARE_TIMEOUT_MS)
    assert panel.running
    panel.cancel()


def test_render_without_objects_says_why(window):
    window.ask_unsaved = lambda: "discard"
    window.new_project()
    window.errors.clear()
    window.render_view.start()
    assert window.errors and "no objects" in window.errors[-1]
    assert not window.render_view.running
