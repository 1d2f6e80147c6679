"""Where the path tracer's light samples go: at the camera's vertex, the light type (area, point, sky) and
the point on the light come from one Owen-scrambled Sobol pair of the pixel, so a pixel's first 2^k samples
split between the light types in proportion to their probabilities (to within two), where independent
choices would scatter binomially. Unbiasedness is the other tests' business (furnace, MIS, Mitsuba)."""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np

from renderer.render import prepare
from renderer.stages.surface import surface_stage
from tests.renderer.test_integrator import _mixed_scene

_NAMES = list(inspect.signature(surface_stage.py_func).parameters)


def _three_lights_scene(tmp_path: Path):
    """The mixed test scene with its quad light turned to face the ball and the floor (its normal down), a
    point light and a constant sky."""
    lights = [
        {"type": "quad", "corner": [-0.5, 2.5, -0.5], "edge1": [1, 0, 0], "edge2": [0, 0, 1], "radiance": 6},
        {"type": "point", "position": [2, 2, 2], "intensity": [3, 3, 3]},
    ]
    return _mixed_scene(tmp_path, "cosine", lights=lights)


def _light_choices_at_the_camera_vertex(job, spp: int) -> tuple[np.ndarray, np.ndarray]:
    """``(path, kind)`` of every camera-vertex light sample of one pass: kind 0 area, 1 point, 2 sky (an area
    sample has a finite distance, a point light's is a delta)."""
    tracer = job.tracer
    run = tracer._run
    seen: list[tuple[np.ndarray, np.ndarray]] = []

    def spy(stage, n, *args):  # type: ignore[no-untyped-def]
        out = run(stage, n, *args)
        if stage is surface_stage:
            a = dict(zip(_NAMES[2:], args, strict=True))
            if a["depth"] == 0:
                delta, t_max = a["light"].delta[:n], a["light"].tmax[:n]
                kind = np.where(delta, 1, np.where(t_max >= 1e30, 2, 0))
                seen.append((a["vtx"].path[:n].copy(), kind))
        return out

    tracer._run = spy  # type: ignore[method-assign]
    try:
        tracer.render_pass(0, spp)
    finally:
        tracer._run = run  # type: ignore[method-assign]
    return np.concatenate([s[0] for s in seen]), np.concatenate([s[1] for s in seen])


def test_a_pixels_samples_split_between_the_light_types_in_proportion(tmp_path: Path) -> None:
    job = prepare(_three_lights_scene(tmp_path), seed=5, max_depth=1)
    tracer = job.tracer
    spp = 16
    path, kind = _light_choices_at_the_camera_vertex(job, spp)
    n_pix = tracer.width * tracer.height
    pixel = path % n_pix
    probabilities = (tracer.p_area, tracer.p_point, tracer.p_env)
    assert all(p > 0.05 for p in probabilities)  # the scene has all three types
    full = np.flatnonzero(np.bincount(pixel, minlength=n_pix) == spp)  # pixels whose 16 rays all hit
    assert len(full) > 100
    worst = 0.0
    for k, p in enumerate(probabilities):
        counts = np.bincount(pixel[kind == k], minlength=n_pix)[full]
        worst = max(worst, float(np.abs(counts - spp * p).max()))
    # stratified: the first 16 points put one first coordinate in each sixteenth of [0, 1), so a type's
    # interval of length p gets 16 p points to within less than one at each of its two ends; independent
    # choices scatter binomially (std 1.9 at p = 1/3: a deviation of 2 or more in most of 100+ pixels)
    assert worst < 2.0, worst
