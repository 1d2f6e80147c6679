"""Make reference in the real window: chunks rendered in a render process of their own, stored beside the
project, resumed, used to measure RMSE and relMSE of both strategies live, dropped when the scene changes and
found again when it comes back (undo)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app import reference
from tests.app.meshes import write_obj

pytestmark = pytest.mark.gui

TIMEOUT_MS = 300_000  # the first render compiles kernels and builds the reference sampler's tables


def _finite(records, metric):
    return [r[metric] for r in records if math.isfinite(r[metric])]


def test_make_reference_resume_measure_and_invalidate(window, qtbot, tmp_path, monkeypatch):
    monkeypatch.setattr(reference, "CHUNK_SPP", 4)
    monkeypatch.setattr(reference, "TARGET_SPP", 4)
    w = window
    w.ask_unsaved = lambda: "discard"
    w.new_project()
    w.errors.clear()
    w.document.add_material("lambert", name="grey", params={"kd": 0.5})
    w.import_mesh(write_obj(tmp_path / "cubes.obj", {"a": (0, 0, 0), "b": (1.5, 0, 0)}))
    assert w.save_project_as(tmp_path / "proj.json")
    panel = w.render_view
    runner = panel.reference_runner
    panel.width_box.setValue(32)
    panel.height_box.setValue(24)
    panel.strategy_a.setCurrentText("uniform")
    panel.strategy_b.setCurrentText("cosine")
    panel.mode.setCurrentIndex(panel.mode.findData("spp"))
    panel.spp.setValue(8)
    panel.reference, panel.reference_key = None, None

    w.make_reference()  # one chunk: the target
    qtbot.waitUntil(lambda: runner.reference is not None and not runner.wanted, timeout=TIMEOUT_MS)
    assert w.errors == [] and (runner.reference.spp, runner.reference.chunks) == (4, 1)
    assert (tmp_path / "proj.reference.exr").is_file() and (tmp_path / "proj.reference.json").is_file()
    first = runner.reference.image.copy()

    monkeypatch.setattr(reference, "TARGET_SPP", 8)  # asked for more: resumes from the stored chunk
    w.make_reference()
    qtbot.waitUntil(lambda: runner.reference.spp == 8 and not runner.wanted, timeout=TIMEOUT_MS)
    assert runner.reference.chunks == 2
    assert not np.array_equal(runner.reference.image, first)  # a second chunk, with its own seed
    assert panel.reference_key == runner.reference.key and panel.reference.shape == (24, 32, 3)

    w.start_render()
    qtbot.waitUntil(lambda: not panel.running, timeout=TIMEOUT_MS)
    assert w.errors == []
    for name in ("uniform", "cosine"):
        assert len(_finite(panel.curves[name], "rmse")) == len(panel.curves[name]) > 0
        assert all(e > 0 for e in _finite(panel.curves[name], "relmse"))
    # the verdict compares the two in words (which one is ahead depends on the scene)
    assert "uniform" in panel.error_plot.verdict and "cosine" in panel.error_plot.verdict
    assert panel.error_plot.verdict in panel.error_plot.status.text()

    w.document.set_param("kd", 0.3, material="grey")  # another scene: the reference no longer applies
    w.start_render()
    assert panel.reference is None and "another scene" in panel.status_text
    qtbot.waitUntil(lambda: not panel.running, timeout=TIMEOUT_MS)
    assert _finite(panel.curves["uniform"], "rmse") == []

    w.document.undo()  # the scene of the stored reference again: found and used
    w.start_render()
    assert panel.reference_key == runner.reference.key and "stored reference" in panel.status_text
    qtbot.waitUntil(lambda: not panel.running, timeout=TIMEOUT_MS)
    assert _finite(panel.curves["uniform"], "rmse")


def test_a_scene_change_stops_the_reference(window, qtbot, tmp_path, monkeypatch):
    monkeypatch.setattr(reference, "CHUNK_SPP", 4)
    monkeypatch.setattr(reference, "TARGET_SPP", 10_000)
    w = window
    w.ask_unsaved = lambda: "discard"
    w.new_project()
    w.document.add_material("lambert", name="grey", params={"kd": 0.5})
    w.import_mesh(write_obj(tmp_path / "cube.obj", {"a": (0, 0, 0)}))
    panel = w.render_view
    panel.width_box.setValue(16)
    panel.height_box.setValue(12)
    w.make_reference()
    runner = panel.reference_runner
    assert runner.wanted and runner.running
    w.document.set_param("kd", 0.4, material="grey")
    assert not runner.wanted and not runner.running and "scene changed" in panel.status_text
