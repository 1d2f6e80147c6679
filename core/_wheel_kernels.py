"""Build step: the wheel carries its kernels compiled, so that the first run after ``pip install .`` loads them.

Used only when a wheel is built: ``pyproject.toml`` names :class:`BuildWithKernels` as setuptools' ``build_py``
(``[tool.setuptools.cmdclass]``; setuptools loads this file by its path, without importing ``core``). After the
packages are copied into the build folder, the warm-ups of ``core`` and ``renderer`` (``brdf-studio setup``'s)
run there, in two processes, with numba's cache pointed at ``core/_kernels`` inside that folder. The cache's
folders are named by the sources' place in the packages and its entries are stamped by the sources' bytes
(``core/_numba_cache.py``), so the installed copy finds them valid; the first ``import core`` copies them
into the user's cache (once per build). The compiles are for the CPU that builds the wheel: installed on
another, numba compiles at first use as it would without them.

An editable install (``pip install -e .``, ``make setup``) skips the step: ``make setup`` warms the cache of
the checkout itself. ``BRDF_STUDIO_PREBUILD=0`` skips it too (a wheel without compiled kernels).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import uuid
from pathlib import Path

from setuptools.command.build_py import build_py

KERNELS = Path("core") / "_kernels"


class BuildWithKernels(build_py):
    """``build_py``, then the kernels compiled into the build folder."""

    def run(self) -> None:
        super().run()
        lib = Path(self.build_lib).resolve()
        target = lib / KERNELS
        shutil.rmtree(target, ignore_errors=True)  # never a previous build's (the build folder is reused)
        if getattr(self, "editable_mode", False) or os.environ.get("BRDF_STUDIO_PREBUILD") == "0":
            return
        target.mkdir(parents=True)
        with tempfile.TemporaryDirectory(prefix="brdf-studio-build-") as tables:
            env = {
                **os.environ,
                # first the build folder; then what pip's isolated build environment put there (its packages)
                "PYTHONPATH": os.pathsep.join(p for p in (str(lib), os.environ.get("PYTHONPATH")) if p),
                "BRDF_STUDIO_NUMBA_CACHE": str(target),
                "BRDF_STUDIO_CACHE": tables,
            }
            code = "import sys; from core.warmup import WARM_UP_MODULES, run_in_processes; "
            code += "sys.exit(run_in_processes(WARM_UP_MODULES))"
            print("compiling the kernels into the wheel (minutes; the first run then loads them)", flush=True)
            if subprocess.run([sys.executable, "-c", code], cwd=lib, env=env).returncode != 0:
                raise SystemExit(
                    "compiling the kernels into the wheel failed (the output above says where); "
                    "BRDF_STUDIO_PREBUILD=0 builds the wheel without them, and they compile at first use"
                )
        (target / "BUILD_ID").write_text(uuid.uuid4().hex + "\n", encoding="utf-8")
