"""Renders on a Dask cluster from the command line and the app: ``render --workers`` interrupted by a Ctrl-C in
its terminal (the workers' too) saves the passes done, the one process's image bit for bit; the cluster
setting kept in the config folder, chosen in its dialog and sent with long renders; the render process's
events from a local cluster (the same image as on this machine, with the cluster's state); a scheduler that
does not answer reported as the job's error."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from app import settings
from app.commands.render import demo_scene_path
from app.render_session import _run_job, render_events
from app.settings import ClusterSetting
from core.scene import load_scene, scene_to_dict
from renderer.image_io import read_exr
from renderer.render import prepare
from tests.app.test_cli_interrupt import SCENE, wait_for_passes
from tests.renderer.scenes import quad, sphere

ROOT = Path(__file__).resolve().parents[2]


def test_ctrl_c_in_the_terminal_saves_the_passes_done_the_one_process_image(tmp_path):
    """``render --workers 1 --until-cancelled``, then SIGINT to its whole process group (what a terminal's
    Ctrl-C does: the local cluster's worker gets it too): exit 130, no traceback, the EXR, PNG and sidecar
    (``interrupted``, the cluster's part) of the passes that came back, equal to one process's render of as
    many samples per pixel, bit for bit."""
    quad(tmp_path / "floor.obj", size=3.0, y=-1.0)
    sphere(tmp_path / "ball.obj", subdivisions=1)
    scene_file = tmp_path / "scene.json"
    scene_file.write_text(json.dumps(SCENE))
    out = tmp_path / "shot.exr"
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "TQDM_MININTERVAL": "0", "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "render", str(scene_file), "--until-cancelled", "--workers", "1",
         "-o", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp_path, start_new_session=True,
    )  # fmt: skip
    try:
        early = wait_for_passes(proc)
        os.killpg(proc.pid, signal.SIGINT)
        stdout, rest = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    err = early + rest.decode(errors="replace")
    assert proc.returncode == 130, err[-1500:]
    assert "Traceback" not in err and "Exception ignored" not in err and "internal error" not in err
    assert f"interrupted; saved {out}" in err
    sidecar = json.loads((tmp_path / "shot.json").read_text())
    assert sidecar["interrupted"] is True and sidecar["spp"] >= 1
    assert sidecar["cluster"]["scheduler"] == "local cluster of 1" and sidecar["cluster"]["passes"] >= 1
    job = prepare(load_scene(scene_file))
    try:
        expected = job.run(spp=sidecar["spp"]).image
    finally:
        job.close()
    assert np.array_equal(read_exr(out), expected)


def test_the_cluster_setting_is_kept_and_a_bad_file_means_this_machine():
    assert settings.cluster_setting() == ClusterSetting()  # nothing saved: this machine
    assert ClusterSetting().for_job() is None
    chosen = ClusterSetting("address", 2, "tcp://10.0.0.5:8786")
    settings.set_cluster_setting(chosen)
    assert settings.cluster_setting() == chosen
    assert chosen.for_job() == {"kind": "address", "workers": 2, "address": "tcp://10.0.0.5:8786"}
    path = settings.config_dir() / "cluster.json"
    for bad in ("{", json.dumps({"kind": "moon"}), json.dumps({"kind": "local", "workers": 0}), "[]"):
        path.write_text(bad)
        assert settings.cluster_setting() == ClusterSetting()


def _job(scene, cluster: dict) -> dict:
    return {
        "scene": scene_to_dict(scene), "base_dir": str(scene.base_dir), "source": scene.source,
        "strategies": ["analytic"], "mode": "spp", "budget": 24, "width": 48, "height": 32, "seed": 7,
        "reference": None, "cluster": cluster,
    }  # fmt: skip


@pytest.mark.gui
def test_the_render_process_renders_on_a_local_cluster_this_machines_image(qtbot):
    """A job with a local cluster of 1, sent to the real render process (a daemonic process, which starts the
    cluster in a process of its own): frames with the cluster's state, the last one this machine's image to
    the bit; the cluster's process ends with the render process."""
    import psutil

    from app.render_process import RenderServer
    from app.render_session import TERMINAL_KINDS

    scene = load_scene(demo_scene_path())
    server = RenderServer()
    events: list[dict] = []
    server.events_received.connect(events.extend)
    helpers: list[psutil.Process] = []
    try:
        server.submit(_job(scene, ClusterSetting("local", 1).for_job()))
        qtbot.waitUntil(lambda: any(e["kind"] in TERMINAL_KINDS for e in events), timeout=240_000)
        render_process = psutil.Process(server.pid)
        helpers = [
            p for p in render_process.children() if "renderer.distributed.local_cluster" in p.cmdline()
        ]
    finally:
        server.stop()
    assert events[-1]["kind"] == "done", events[-1]
    assert len(helpers) == 1, "the local cluster ran in a process of its own"
    texts = [e["text"] for e in events if e["kind"] == "status"]
    assert any(t.startswith("Connecting to a local cluster of 1 workers") for t in texts), texts
    frames = [e for e in events if e["kind"] == "frame"]
    assert frames and all("workers" in f["cluster"] for f in frames)
    here = [e for e in render_events(scene, ["analytic"], "spp", 24, 48, 32, seed=7) if e["kind"] == "frame"]
    assert frames[-1]["spp"] == here[-1]["spp"] == 24
    assert np.array_equal(frames[-1]["image"], here[-1]["image"])
    _, alive = psutil.wait_procs(helpers, timeout=20)
    assert not alive, "the local cluster's process ended with the render process"


def test_a_scheduler_that_does_not_answer_is_the_jobs_error():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    scene = load_scene(demo_scene_path())
    events: list[dict] = []
    t0 = time.monotonic()
    _run_job(_job(scene, ClusterSetting("address", 2, f"tcp://127.0.0.1:{port}").for_job()), threading.Event(),
             events.append)  # fmt: skip
    assert time.monotonic() - t0 < 15.0
    assert events[-1]["kind"] == "error"
    assert f"cannot reach the Dask scheduler at 'tcp://127.0.0.1:{port}'" in events[-1]["text"]
    assert "\n" not in events[-1]["text"]


@pytest.mark.gui
def test_the_cluster_dialog_refuses_an_address_of_the_wrong_form(qtbot):
    from app.views.cluster_dialog import ClusterDialog

    dialog = ClusterDialog(ClusterSetting())
    qtbot.addWidget(dialog)
    assert dialog.here.isChecked() and dialog.setting() == ClusterSetting()
    dialog.remote.setChecked(True)
    dialog.address.setText("http://sched:8786")
    dialog.accept()
    assert dialog.result() != ClusterDialog.DialogCode.Accepted and "is not a Dask scheduler address" in (
        dialog.problem.text()
    )
    dialog.address.setText("sched.example:8786")
    dialog.accept()
    assert dialog.result() == ClusterDialog.DialogCode.Accepted
    assert dialog.setting() == ClusterSetting("address", 2, "tcp://sched.example:8786")
    dialog.local.setChecked(True)
    dialog.workers.setValue(3)
    assert dialog.setting().for_job() == {"kind": "local", "workers": 3, "address": "sched.example:8786"}


@pytest.mark.gui
def test_the_render_panel_sends_long_renders_to_the_chosen_cluster(window, qtbot):
    """The panel's Cluster... button: the dialog's choice is saved; renders of LONG_RENDER_SPP spp or more
    carry it to the render process, shorter ones and equal-time ones run here."""
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app.views.cluster_dialog import ClusterDialog
    from app.views.render import LONG_RENDER_SPP

    panel = window.render_view

    def choose() -> None:
        dialog = QApplication.activeModalWidget()
        assert isinstance(dialog, ClusterDialog)
        dialog.local.setChecked(True)
        dialog.workers.setValue(3)
        dialog.accept()

    QTimer.singleShot(0, choose)
    panel.choose_cluster()
    assert settings.cluster_setting() == ClusterSetting("local", 3, "")
    assert "a local cluster of 3 workers" in panel.status_text
    scene = load_scene(demo_scene_path())
    panel.mode.setCurrentIndex(panel.mode.findData("spp"))
    panel.spp.setValue(LONG_RENDER_SPP)
    assert panel.request(scene)["cluster"] == {"kind": "local", "workers": 3, "address": ""}
    panel.spp.setValue(LONG_RENDER_SPP - 1)
    assert panel.request(scene)["cluster"] is None
    panel.mode.setCurrentIndex(panel.mode.findData("time"))
    assert panel.request(scene)["cluster"] is None


@pytest.fixture(autouse=True)
def _config(tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_STUDIO_CONFIG_DIR", str(tmp_path / "config"))
