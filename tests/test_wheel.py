"""The wheel ``pip install .`` builds carries its kernels compiled (core/_wheel_kernels.py), and an installed
copy loads them instead of compiling: the first run after the install (bench/first_run.py times it) depends
on it."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_LOAD = """
import numpy as np
from core.kernels import _eval_serial, eval_batch
from core.brdf import make_brdf
m = make_brdf("ggx")
eval_batch(m.model, np.array([[0.0, 0.6, 0.8]]), np.array([[0.6, 0.0, 0.8]]), m.params)
s = _eval_serial.stats
print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))
"""


@pytest.mark.slow
def test_the_wheel_carries_compiled_kernels_that_an_installed_copy_loads(tmp_path):
    wheels = tmp_path / "wheels"
    env = {k: v for k, v in os.environ.items() if k != "BRDF_STUDIO_PREBUILD"}
    # as pip install . builds it: in an isolated build environment (pyproject.toml's build requirements)
    command = [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "-q", "-w", str(wheels)]
    subprocess.run(command, check=True, env=env)
    (wheel,) = wheels.glob("brdf_studio-*.whl")
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        z.extractall(site)
    assert "core/_kernels/BUILD_ID" in names
    compiled = [n for n in names if n.startswith("core/_kernels/") and n.endswith(".nbi")]
    assert any(n.startswith("core/_kernels/core/kernels") for n in compiled), compiled[:5]
    assert any(n.startswith("core/_kernels/renderer/stages") for n in compiled), compiled[:5]
    # installed elsewhere, with an empty cache of its own: the switch loads, nothing compiles
    user = tmp_path / "user-cache"
    env = {**env, "PYTHONPATH": str(site), "BRDF_STUDIO_NUMBA_CACHE": str(user)}
    done = subprocess.run(
        [sys.executable, "-c", _LOAD], cwd=tmp_path, env=env, capture_output=True, text=True, check=True
    )
    assert done.stdout.split() == ["1", "0"], done.stdout + done.stderr
    build = (site / "core" / "_kernels" / "BUILD_ID").read_text().strip()
    assert (user / f".seeded-{build}").is_file()
