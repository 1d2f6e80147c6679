"""Run a Qt script on a display: re-execute under Xvfb (``xvfb-run``) when there is none."""

from __future__ import annotations

import os
import shutil
import sys


def ensure_display(size: str = "1600x1000x24") -> None:
    if os.environ.get("DISPLAY") or os.environ.get("BRDF_STUDIO_NO_XVFB"):
        return
    xvfb_run = shutil.which("xvfb-run")
    if xvfb_run is None:
        sys.exit("no display and no xvfb-run: install Xvfb (bash .ci/system-deps.sh as root)")
    os.environ["BRDF_STUDIO_NO_XVFB"] = "1"
    os.execv(xvfb_run, [xvfb_run, "-a", "-s", f"-screen 0 {size}", sys.executable, *sys.argv])
