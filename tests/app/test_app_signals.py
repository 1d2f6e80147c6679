"""Ctrl-C and SIGTERM close the real app (a process of its own on the test's display): at once, with exit code
130 or 143, one line on stderr and no traceback, its unsaved edits autosaved first, its helper processes gone
with it.

Ctrl-C in a terminal signals the whole foreground process group: the app and the processes it started (the
render and snapshot processes) get SIGINT together, so the app is started in a session of its own and the
signal goes to its group; SIGTERM (``kill PID``) goes to the app alone."""

from __future__ import annotations

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
LAUNCH_TIMEOUT_S = 240
"""Importing the app, opening the window and the project: seconds on an idle machine, a minute or more on a
loaded one with cold caches."""
CLOSE_S = 3.0
"""The issue's target: the app is gone this long after the signal."""


def _launch(project: Path, report: Path, config: Path, stderr: Path) -> subprocess.Popen:
    """The app, its output to files (a pipe would stay open until its helper processes have gone too)."""
    env = {**os.environ, "BRDF_STUDIO_CONFIG_DIR": str(config)}
    with open(stderr, "w") as err:
        return subprocess.Popen(
            [sys.executable, "-m", "tests.app.autosave_app", "hold", str(project), str(report)],
            cwd=ROOT,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=err,
            start_new_session=True,  # a process group of its own, as a terminal's foreground job has
        )


def _wait_for_report(report: Path, app: subprocess.Popen) -> dict:
    end = time.monotonic() + LAUNCH_TIMEOUT_S
    while time.monotonic() < end:
        if report.exists():
            return json.loads(report.read_text())
        if app.poll() is not None:
            pytest.fail(f"the app ended (exit {app.returncode}) before it was edited")
        time.sleep(0.05)
    pytest.fail("timed out waiting for the app to open and be edited")


@pytest.mark.parametrize(
    ("signum", "code", "to_group"),
    [(signal.SIGINT, 130, True), (signal.SIGTERM, 143, False)],
    ids=["ctrl-c", "sigterm"],
)
def test_a_signal_closes_the_app_at_once_with_its_edits_autosaved(tmp_path, signum, code, to_group):
    user = tmp_path / "project"
    user.mkdir()
    write_obj(user / "cubes.obj", {"a": (0, 0, 0), "b": (2, 0, 0)})
    scene = default_scene()
    scene.meshes = [Mesh(path="cubes.obj", name="cubes", material="ggx")]
    project = user / "scene.json"
    save_scene(scene, project)
    saved = project.read_text()
    config = tmp_path / "config"
    config.mkdir()
    report = tmp_path / "report.json"

    app = _launch(project, report, config, tmp_path / "stderr.txt")
    try:
        edited = _wait_for_report(report, app)
        assert edited["pid"] == app.pid and edited["dirty"]
        autosave = config / f"autosave-{app.pid}.json"
        assert not autosave.exists()  # the edit is held in memory only: the signal's handling must write it
        children = psutil.Process(app.pid).children(recursive=True)
        t0 = time.monotonic()
        if to_group:
            os.killpg(app.pid, signum)  # Ctrl-C: the app and its helper processes
        else:
            os.kill(app.pid, signum)
        app.wait(timeout=60)
        closed_s = time.monotonic() - t0
    finally:
        if app.poll() is None:
            os.killpg(app.pid, signal.SIGKILL)
            app.wait()
    _, alive = psutil.wait_procs(children, timeout=30)  # the render and snapshot processes end with it
    err = (tmp_path / "stderr.txt").read_text()  # complete once they have gone
    print(f"{signal.Signals(signum).name}: closed {closed_s:.2f} s after the signal (exit {app.returncode})")
    assert app.returncode == code, err[-3000:]
    assert closed_s < CLOSE_S
    for bad in ("Traceback", "Exception ignored", "KeyboardInterrupt", "Error"):
        assert bad not in err, err[-3000:]
    about = [line for line in err.splitlines() if signal.Signals(signum).name in line or "interrupt" in line]
    assert about == [f"brdf-studio: {signal.Signals(signum).name}: closed; the unsaved edits are kept and "
                     "offered at the next start"], err[-3000:]  # fmt: skip
    # the edits, autosaved before the app went: the next launch offers them as after a crash
    doc = json.loads(autosave.read_text())["document"]
    materials = {m["name"]: m for m in doc["materials"]}
    assert (
        materials[EDIT["material"]]["params"][EDIT["param"]] == EDIT["value"] and EDIT["added"] in materials
    )
    assert project.read_text() == saved  # the project itself is the user's to save
    assert not alive, f"processes left behind: {alive}"
