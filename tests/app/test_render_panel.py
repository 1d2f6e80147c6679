"""The render panel in the real window: two strategies side by side, cancel and restart, exports; the render
process: separate, kept warm, replaced when stuck or crashed, never left behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.app.meshes import write_obj

pytestmark = pytest.mark.gui

ROOT = Path(__file__).resolve().parents[2]
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


# ---- the render process ---------------------------------------------------------------------------------


def _with_hold(panel, monkeypatch, seconds):
    """Make the panel's jobs pause ``seconds`` in the render process before preparing, deaf to cancel (as a
    long compilation is)."""
    plain = type(panel).request.__get__(panel)
    monkeypatch.setattr(panel, "request", lambda scene: {**plain(scene), "hold_s": seconds})


def _alive(pid: int) -> bool:
    """True if process ``pid`` exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/status") as fh:
            return not any(line.startswith("State:") and "Z" in line.split()[1] for line in fh)
    except FileNotFoundError:
        return False


def test_render_runs_in_a_separate_process_kept_warm(scene_window, qtbot):
    w = scene_window
    panel = w.render_view
    panel.spp.setValue(2)
    w.start_render()
    _wait_done(w, qtbot)
    assert w.errors == [] and set(panel.frames) == {"uniform", "cosine"}
    pid = panel.server.pid
    assert pid is not None and pid != os.getpid() and _alive(pid)
    assert {f["pid"] for f in panel.frames.values()} == {pid}  # the frames were rendered there
    w.start_render()
    _wait_done(w, qtbot)
    assert {f["pid"] for f in panel.frames.values()} == {pid}  # the same process renders the next one


def test_cancel_during_preparation_and_restart_replace_a_stuck_process(scene_window, qtbot, monkeypatch):
    w = scene_window
    panel = w.render_view
    panel.spp.setValue(2)
    _with_hold(panel, monkeypatch, 600.0)  # a preparation step that would not see a cancel for 10 minutes
    w.start_render()
    qtbot.waitUntil(lambda: "Holding" in panel.status_text, timeout=PREPARE_TIMEOUT_MS)
    stuck = panel.server.pid
    w.cancel_render()  # returns at once
    assert not panel.running and "Cancelled" in panel.status_text
    monkeypatch.undo()
    restarts = panel.server.restarts
    w.start_render()  # the stuck process does not stop within the grace period: a new one takes the job
    _wait_done(w, qtbot)
    assert w.errors == [] and set(panel.frames) == {"uniform", "cosine"}
    assert panel.server.restarts == restarts + 1
    assert panel.server.pid != stuck
    qtbot.waitUntil(lambda: not _alive(stuck), timeout=10_000)


def test_render_process_crash_is_reported_and_the_next_render_recovers(scene_window, qtbot):
    w = scene_window
    panel = w.render_view
    panel.strategy_b.setCurrentText("(none)")
    panel.spp.setValue(100_000)
    w.start_render()
    qtbot.waitUntil(lambda: "uniform" in panel.frames, timeout=PREPARE_TIMEOUT_MS)
    crashed = panel.server.pid
    os.kill(crashed, signal.SIGKILL)
    qtbot.waitUntil(lambda: not panel.running, timeout=30_000)
    assert w.errors and "render process stopped unexpectedly" in w.errors[-1] and "SIGKILL" in w.errors[-1]
    assert "Render failed" in panel.status_text
    w.errors.clear()
    panel.spp.setValue(2)
    w.start_render()
    _wait_done(w, qtbot)
    assert w.errors == [] and panel.frames["uniform"]["spp"] == 2
    assert panel.server.pid not in (None, crashed)


def test_own_panel_event_loop_runs_while_preparing_and_quit_ends_the_process(qtbot, tmp_path):
    """A panel of its own (a fresh render process, nothing else in the window): a timer on the GUI thread
    keeps firing while the process starts and prepares, and the pool's shutdown (app quit) ends it."""
    from PySide6.QtCore import QTimer

    from app.views.render import RenderPanel
    from app.workers import WorkerPool
    from core.scene import SCENE_VERSION, scene_from_dict

    write_obj(tmp_path / "cubes.obj", {"a": (0, 0, 0)})
    data = {
        "version": SCENE_VERSION,
        "materials": [{"name": "grey", "model": "lambert", "params": {"kd": 0.5}}],
        "meshes": [{"name": "cubes", "path": "cubes.obj", "material": "grey"}],
        "environment": {"type": "constant", "radiance": [1.0, 1.0, 1.0]},
    }
    pool = WorkerPool()
    panel = RenderPanel(lambda: scene_from_dict(data, base_dir=tmp_path), pool)
    qtbot.addWidget(panel)
    errors = []
    panel.error.connect(errors.append)
    panel.width_box.setValue(16)
    panel.height_box.setValue(12)
    panel.spp.setValue(1)
    panel.strategy_a.setCurrentText("uniform")
    panel.strategy_b.setCurrentText("(none)")
    ticks = []
    timer = QTimer()
    timer.setInterval(20)
    timer.timeout.connect(lambda: ticks.append(len(panel.frames)))
    timer.start()
    panel.start()
    qtbot.waitUntil(lambda: not panel.running, timeout=PREPARE_TIMEOUT_MS)
    timer.stop()
    assert errors == [] and panel.frames["uniform"]["spp"] == 1
    # starting the interpreter and importing the renderer alone take seconds: ~50 ticks a second are due
    assert ticks.count(0) >= 10
    pid = panel.server.pid
    assert pid is not None and _alive(pid)
    pool.shutdown()  # what the main window does when the app quits
    assert panel.server.pid is None and not _alive(pid)


def test_render_process_never_outlives_a_killed_app(tmp_path):
    """An app that ends abruptly (os._exit, a crash) leaves no render process behind."""
    script = tmp_path / "app.py"
    script.write_text(
        "import os, sys\n"
        f"sys.path.insert(0, {str(ROOT)!r})\n"
        "from app.render_process import RenderServer\n"
        "if __name__ == '__main__':\n"
        "    server = RenderServer()\n"
        "    server.ensure_started()\n"
        "    print(server.pid, flush=True)\n"
        "    sys.stdin.readline()\n"
        "    os._exit(0)\n"
    )
    app = subprocess.Popen(
        [sys.executable, str(script)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        pid = int(app.stdout.readline())
        assert _alive(pid)
        app.communicate("quit\n", timeout=60)
        deadline = time.monotonic() + 60
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(pid)
    finally:
        app.kill()


def test_a_destroyed_server_is_never_signalled_by_its_reader_threads(qtbot):
    """The render process's reader threads outlive the server object (they end when the pipe closes). Once Qt
    has destroyed the server, a late message must not emit its signal (that crashed a test worker: a signal
    of a destroyed QObject); it is dropped, and posting it neither raises nor crashes."""
    import threading

    import shiboken6

    from app.render_process import RenderServer

    server = RenderServer()
    assert server._alive["yes"]
    shiboken6.delete(server)
    assert not server._alive["yes"]
    done = threading.Event()

    def late() -> None:
        server._post(None, {"kind": "progress"})  # type: ignore[arg-type]
        done.set()

    threading.Thread(target=late).start()
    assert done.wait(5.0)
    assert list(server._inbox)  # kept (nobody drains it), never signalled


def test_a_strategys_first_image_is_shown_at_once_later_ones_with_the_frame_timer(window):
    """Frames are drawn at most every FRAME_INTERVAL_MS (one window flush for images, counters and plot),
    but a strategy's first image is what the user waits for after Render: it is drawn as it arrives."""
    panel = window.render_view
    panel.job, panel.curves, panel.frames = 99, {"uniform": [], "cosine": []}, {}
    try:

        def frame(name, spp, value):
            image = np.full((6, 8, 3), value, dtype=np.float32)
            return {"kind": "frame", "job": 99, "strategy": name, "spp": spp, "seconds": 0.1 * spp,
                    "rmse": float("nan"), "relmse": float("nan"), "rays": 100, "image": image}  # fmt: skip

        panel._on_events([frame("uniform", 1, 0.25)])
        assert panel.view_a.rgb8 is not None and panel.view_a.rgb8.shape == (6, 8, 3)
        first = panel.view_a.rgb8.copy()
        panel._on_events([frame("uniform", 2, 0.75)])  # not the first: waits for the timer
        assert np.array_equal(panel.view_a.rgb8, first) and panel._frame_timer.isActive()
        panel._on_events([frame("cosine", 1, 0.5)])  # cosine's first: at once, with uniform's due one
        assert panel.view_b.rgb8 is not None and not np.array_equal(panel.view_a.rgb8, first)
    finally:
        panel._frame_timer.stop()
        panel.job, panel.curves, panel.frames = None, {}, {}
