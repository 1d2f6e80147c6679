"""Ctrl-C and SIGTERM during ``brdf-studio render``, on real processes (issue 18, "nothing lost").

The first signal while passes run finishes the pass in flight and saves the image of every completed pass
(EXR, PNG and a JSON sidecar marked ``interrupted``), then exits with 130 (143 for SIGTERM), with no traceback
and no "Exception ignored" report from a thread pool; a signal before the first pass ends, or a kill -9 at any
time, leaves a previous output untouched (outputs are written to a temporary file and renamed).
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from renderer.image_io import read_exr
from tests.renderer.scenes import quad, sphere

SCENE = {
    "version": 2,
    "camera": {"position": [0, 1, 3], "target": [0, 0, 0], "fov_deg": 45},
    "materials": [{"name": "m", "model": "lambert", "params": {"kd": 0.5}}],
    "meshes": [{"path": "floor.obj", "material": "m"}, {"path": "ball.obj", "material": "m"}],
    "lights": [{"type": "point", "position": [1, 3, 1], "intensity": 5}],
    "environment": {"type": "constant", "radiance": 0.2},
    "render": {"width": 32, "height": 24, "spp": 4, "max_depth": 3, "sampler": "cosine"},
}


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("interrupt")
    quad(folder / "floor.obj", size=3.0, y=-1.0)
    sphere(folder / "ball.obj", subdivisions=1)
    path = folder / "scene.json"
    path.write_text(json.dumps(SCENE))
    return path


def start(scene_file: Path, out: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "TQDM_MININTERVAL": "0"}
    return subprocess.Popen(
        [sys.executable, "-m", "app", "render", str(scene_file), "--until-cancelled", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )


def wait_for_passes(proc: subprocess.Popen, timeout: float = 240.0) -> str:
    """Read the progress bar until it reports samples rendered (the bar writes ``spp=K`` after each pass)."""
    seen = b""
    t0 = time.monotonic()
    assert proc.stderr is not None
    fd = proc.stderr.fileno()
    while time.monotonic() - t0 < timeout:
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            chunk = os.read(fd, 65536)
            seen += chunk
            if b"spp=" in seen:
                return seen.decode(errors="replace")
            if not chunk and proc.poll() is not None:
                break
    raise AssertionError(f"no pass finished within {timeout} s: {seen[-500:]!r}")


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_during_passes_saves_the_rendered_image(scene_file, tmp_path, signum, code):
    out = tmp_path / "shot.exr"
    proc = start(scene_file, out)
    try:
        early = wait_for_passes(proc)
        proc.send_signal(signum)
        stdout_bytes, rest = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    err, stdout = early + rest.decode(errors="replace"), stdout_bytes.decode(errors="replace")
    assert proc.returncode == code, err[-800:]
    assert "Traceback" not in err and "Exception ignored" not in err and "internal error" not in err
    assert f"interrupted; saved {out}" in err
    image = read_exr(out)  # complete, finite (read_exr refuses non-finite pixels)
    assert image.shape == (24, 32, 3) and image.max() > 0.0
    sidecar = json.loads((tmp_path / "shot.json").read_text())
    assert sidecar["interrupted"] is True and sidecar["spp"] >= 1
    assert (tmp_path / "shot.png").stat().st_size > 0
    assert "cosine" in stdout  # the summary table was printed


@pytest.mark.parametrize("delay", [1.0, 2.5, 4.0])
def test_signal_at_any_moment_leaves_the_previous_output_or_a_complete_new_one(scene_file, tmp_path, delay):
    """Early (imports, preparation: nothing written) or late (a pass done: the new image, complete)."""
    out = tmp_path / "keep.exr"
    out.write_bytes(b"previous render")
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "render", str(scene_file), "--spp", "4", "-o", str(out), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    # 130, or ended by the signal itself (returncode -2): a shell reports both as exit status 130. Python ends a
    # process by re-raising SIGINT when the KeyboardInterrupt of a Ctrl-C that lands while the interpreter
    # is still importing or shutting down escapes (a fresh clone's `make test` can see it, signal at 1 s)
    assert proc.returncode in (0, 130, -signal.SIGINT), err
    assert "Traceback" not in err and "Exception ignored" not in err and "internal error" not in err
    if out.read_bytes() != b"previous render":
        assert read_exr(out).shape == (24, 32, 3)  # complete (a torn file would not read)


def test_kill_9_while_rendering_leaves_the_previous_output(scene_file, tmp_path):
    out = tmp_path / "keep.exr"
    out.write_bytes(b"previous render")
    proc = start(scene_file, out)
    try:
        wait_for_passes(proc)
        proc.kill()
        proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL
    assert out.read_bytes() == b"previous render"
