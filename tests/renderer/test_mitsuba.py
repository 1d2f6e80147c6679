"""Cross-check against Mitsuba 3 (scalar_rgb): its Cornell box, rebuilt as our scene, renders the same image
within noise. Slow (a few hundred spp on both sides): run with ``pytest -m slow``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

SIZE = 32
DEPTH = 6  # bounces; Mitsuba counts path vertices, so its max_depth is DEPTH + 1


@pytest.mark.slow
def test_cornell_box_matches_mitsuba(tmp_path: Path) -> None:
    from scipy.stats import norm

    from core.scene import load_scene
    from renderer.mitsuba_scene import cornell_dict, export_cornell_box
    from renderer.render import prepare

    mscene = mi.load_dict(cornell_dict(SIZE, DEPTH))
    runs = 8
    theirs = np.array([np.array(mi.render(mscene, spp=128, seed=s)) for s in range(runs)])  # (runs, h, w, 3)

    job = prepare(load_scene(export_cornell_box(tmp_path, SIZE, DEPTH)))
    passes = 32
    ours = np.array([job.tracer.render_pass(k, 16).reshape(SIZE, SIZE, 3) for k in range(passes)])

    def blocks(x: np.ndarray) -> np.ndarray:  # (n, 8, 8, 3): means over 4x4-pixel blocks
        return x.reshape(len(x), 8, 4, 8, 4, 3).mean(axis=(2, 4))

    a, b = blocks(ours), blocks(theirs)
    diff = a.mean(0) - b.mean(0)
    se = np.sqrt(a.var(0, ddof=1) / len(a) + b.var(0, ddof=1) / len(b))
    z = np.abs(diff) / np.maximum(se, 1e-12)
    tests = z.size
    zcrit = norm.isf(0.01 / (2 * tests))  # Bonferroni, alpha = 0.01 two-sided
    assert z.max() < zcrit, (float(z.max()), zcrit, float(np.abs(diff).max()))
    # and the mean brightness agrees to 1 %
    assert np.allclose(a.mean((0, 1, 2)), b.mean((0, 1, 2)), rtol=0.01)
    assert math.isfinite(float(z.max()))
