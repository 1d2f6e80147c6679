"""``brdf-studio open`` starts the real app on a project and quits cleanly (a subprocess under Xvfb)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.gui


def test_open_command_runs_and_exits(tmp_path):
    env = dict(os.environ, BRDF_STUDIO_CONFIG_DIR=str(tmp_path))
    done = subprocess.run(
        [sys.executable, "-m", "app", "open", "--quit-after", "1"],
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Traceback" not in done.stderr


def test_missing_project_is_one_clear_line(tmp_path, capsys):
    from app.cli import main

    assert main([str(tmp_path / "nope.json")]) == 2  # routed to 'open' by the .json suffix
    err = capsys.readouterr().err
    assert "nope.json" in err and "not found" in err and "Traceback" not in err
