"""The app's autosave survives a crash: the real app (a process of its own on the test's display) is edited,
autosaves, is killed with SIGKILL, and the next launch restores the edits; the user's own files are never
touched by any of it."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from app.document import default_scene
from core.scene import Mesh, save_scene
from tests.app.autosave_app import EDIT
from tests.app.meshes import write_obj

pytestmark = pytest.mark.gui

ROOT = Path(__file__).resolve().parents[2]
LAUNCH_TIMEOUT_S = 180  # importing the app and opening the window; seconds on an idle machine


def _digests(folder: Path) -> dict[str, str]:
    """Every file of ``folder`` (the user's project folder) by name: its content's digest."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def _wait_for(what, timeout_s: float, app: subprocess.Popen, why: str):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = what()
        if value:
            return value
        if app.poll() is not None:
            out, err = app.communicate()
            pytest.fail(f"the app ended (exit {app.returncode}) before {why}:\n{out}\n{err}")
        time.sleep(0.05)
    pytest.fail(f"timed out waiting for {why}")


def _launch(phase: str, project: Path, report: Path, config: Path) -> subprocess.Popen:
    env = {**os.environ, "BRDF_STUDIO_CONFIG_DIR": str(config)}
    return subprocess.Popen(
        [sys.executable, "-m", "tests.app.autosave_app", phase, str(project), str(report)],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _autosaved_edit(config: Path, pid: int) -> dict | None:
    path = config / f"autosave-{pid}.json"
    try:
        doc = json.loads(path.read_text())["document"]
    except (OSError, ValueError, KeyError):
        return None
    materials = {m["name"]: m for m in doc["materials"]}
    if EDIT["added"] in materials and materials[EDIT["material"]]["params"][EDIT["param"]] == EDIT["value"]:
        return doc
    return None


def test_edits_autosaved_by_a_killed_app_are_restored_by_the_next_launch(tmp_path):
    user = tmp_path / "project"
    user.mkdir()
    write_obj(user / "cubes.obj", {"a": (0, 0, 0), "b": (2, 0, 0)})
    scene = default_scene()
    scene.meshes = [Mesh(path="cubes.obj", name="cubes", material="ggx")]
    project = user / "scene.json"
    save_scene(scene, project)
    before = _digests(user)
    config = tmp_path / "config"
    config.mkdir()
    report = tmp_path / "report.json"

    # 1. the app opens the project and is edited; the edit reaches the autosave a few seconds later
    t0 = time.monotonic()
    app = _launch("edit", project, report, config)
    try:
        _wait_for(report.exists, LAUNCH_TIMEOUT_S, app, "the edit")
        edited = json.loads(report.read_text())
        assert edited["pid"] == app.pid and edited["dirty"]
        t_edit = time.monotonic()
        print(f"edit reported after {t_edit - t0:.1f} s")
        _wait_for(lambda: _autosaved_edit(config, app.pid), 30, app, "the autosave")
        autosave_delay = time.monotonic() - t_edit
        children = psutil.Process(app.pid).children(recursive=True)
        # 2. a crash: SIGKILL, no handler runs, nothing is cleaned up
        os.kill(app.pid, signal.SIGKILL)
        app.communicate(timeout=30)
    finally:
        app.kill()
    assert app.returncode == -signal.SIGKILL
    _, alive = psutil.wait_procs(children, timeout=30)  # its helper processes end with it
    assert not alive, f"processes left behind by the killed app: {alive}"
    assert _digests(user) == before  # the user's project and mesh: untouched, no temporary files beside them
    orphan = config / f"autosave-{app.pid}.json"
    assert orphan.exists()

    # 3. the next launch asks, restores the edits (on the same project, unsaved), and the user saves them
    report.unlink()
    print(f"killed after {time.monotonic() - t0:.1f} s")
    app = _launch("restore", project, report, config)
    try:
        _wait_for(report.exists, LAUNCH_TIMEOUT_S, app, "the restore and the save")
        os.kill(app.pid, signal.SIGKILL)  # killed again right after the save: the saved project stays
        app.communicate(timeout=30)
    finally:
        app.kill()
    print(f"restore phase ended after {time.monotonic() - t0:.1f} s")
    restored = json.loads(report.read_text())
    assert len(restored["asked"]) == 1  # the user was asked once
    assert restored["errors"] == []
    assert restored["path"] == str(project.resolve()) and restored["dirty"]
    materials = {m["name"]: m for m in restored["document"]["materials"]}
    assert materials[EDIT["material"]]["params"][EDIT["param"]] == EDIT["value"]
    assert materials[EDIT["added"]]["params"]["kd"] == [0.25, 0.25, 0.25]
    assert [m["name"] for m in restored["document"]["meshes"]] == ["cubes"]
    # before the old autosave was removed, the restoring session wrote its own copy of the edits
    assert restored["own_autosave"] == restored["document"]
    assert restored["autosaves"] == [f"autosave-{restored['pid']}.json"]
    assert restored["saved"] and restored["autosaves_after_save"] == []  # saved: nothing left to restore
    # saved by the user: the project now holds the edits, the mesh is untouched, nothing is left to restore
    saved = json.loads(project.read_text())
    saved_materials = {m["name"]: m for m in saved["materials"]}
    assert saved_materials[EDIT["material"]]["params"][EDIT["param"]] == EDIT["value"]
    assert EDIT["added"] in saved_materials
    after = _digests(user)
    assert after.keys() == before.keys() and after["cubes.obj"] == before["cubes.obj"]
    assert not list(config.glob("autosave-*.json"))
    print(f"autosave {autosave_delay:.1f} s after the edit; whole test {time.monotonic() - t0:.1f} s")


def test_an_edit_is_autosaved_once_the_edits_pause(window, qtbot, monkeypatch):
    """Not only by the periodic timer (stopped here): each edit (re)starts a single-shot timer of
    AUTOSAVE_AFTER_EDIT_MS, so a burst of edits is written once, after the last."""
    from app import settings
    from app.file_manager import AUTOSAVE_AFTER_EDIT_MS

    window.new_project()
    mine = settings.autosave_path()
    assert not mine.exists()
    soon = window.files.autosave_soon
    starts, writes = [], []
    start = soon.start
    monkeypatch.setattr(soon, "start", lambda: starts.append(1) or start())
    write = settings.write_autosave
    monkeypatch.setattr(settings, "write_autosave", lambda *a: writes.append(1) or write(*a))
    window.autosave_timer.stop()
    try:
        window.document.add_material("lambert", name="pause-then-save", params={"kd": 0.5})
        for k in range(5):  # a burst of edits, each restarting the wait
            window.document.set_param("kd", 0.1 + 0.1 * k, material="pause-then-save")
        assert len(starts) == 6 and soon.isActive()
        assert not mine.exists()  # never written by an edit itself (the GUI thread does not wait on a disk)
        qtbot.waitUntil(mine.exists, timeout=AUTOSAVE_AFTER_EDIT_MS * 10)
        qtbot.wait(AUTOSAVE_AFTER_EDIT_MS // 2)
    finally:
        window.autosave_timer.start()
    assert len(writes) == 1  # the burst written once
    doc = settings.read_autosave(mine)["document"]
    (mat,) = [m for m in doc["materials"] if m["name"] == "pause-then-save"]
    assert mat["params"]["kd"] == pytest.approx([0.5] * 3)  # the last value of the burst
    window.new_project()  # the edits discarded (the test's answer): their autosave goes with them
    window.autosave()
    assert not mine.exists()


def test_an_autosave_that_cannot_be_restored_is_kept_aside_and_the_app_starts(window):
    from app import settings

    dead = settings.autosave_path(pid=2**22 + 4242)
    dead.write_text('{"time": 0, "document": {"materials": [{"name": "x", "model": "no-such-model"}]}}')
    window.errors.clear()
    assert not window.restore_autosave(ask=False)
    assert not dead.exists() and window.errors and "kept as" in window.errors[-1]
    kept = Path(window.errors[-1].rsplit("kept as ", 1)[1].rstrip(")"))
    assert "no-such-model" in kept.read_text()
    kept.unlink()


def test_a_project_saved_while_the_app_is_killed_is_whole(tmp_path):
    """Saves go to a temporary file that replaces the project in one step: killed at any moment of a run of
    back-to-back saves, the project is one of the saved versions, complete."""
    from core.scene import load_scene
    from tests.app.autosave_app import saved_value

    user = tmp_path / "project"
    user.mkdir()
    project = user / "scene.json"
    save_scene(default_scene(), project)
    config = tmp_path / "config"
    config.mkdir()
    report = tmp_path / "report.json"
    app = _launch("saves", project, report, config)
    try:
        _wait_for(report.exists, LAUNCH_TIMEOUT_S, app, "the first save")
        versions = set()
        end = time.monotonic() + 30
        while len(versions) < 20 and time.monotonic() < end:  # let it save a few times, then kill it
            with open(project, "rb") as fh:  # the reader's view while saves go on: always a whole file
                data = json.loads(fh.read())
            versions.add(
                next(m for m in data["materials"] if m["name"] == EDIT["material"])["params"][EDIT["param"]]
            )
            time.sleep(0.01)
        os.kill(app.pid, signal.SIGKILL)
        app.communicate(timeout=30)
    finally:
        app.kill()
    assert len(versions) >= 2  # it was saving while we read
    scene = load_scene(project)
    alpha = next(m for m in scene.materials if m.name == EDIT["material"]).params[EDIT["param"]]
    assert alpha in {saved_value(i) for i in range(800)}
    leftovers = [p.name for p in user.iterdir() if p != project]
    assert all(name.startswith(".scene.json.") and name.endswith(".tmp") for name in leftovers), leftovers
