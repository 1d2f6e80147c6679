"""NEE's light-type probabilities: set by a pilot of camera rays (renderer.light_shares),
following where the light comes from, and unbiased whatever they are."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from renderer.light_shares import SHARE_FLOOR
from renderer.render import prepare
from tests.renderer.scenes import make_scene, quad
from tests.renderer.test_integrator import _mixed_scene

_QUAD = {"type": "quad", "corner": [-0.5, 2.5, -0.5], "edge1": [1, 0, 0], "edge2": [0, 0, 1], "radiance": 6}


def _shares(tmp_path: Path, quad: float, sky: float, point: float | None = None, seed: int = 3):
    lights = [dict(_QUAD, radiance=quad)]
    if point is not None:
        lights.append({"type": "point", "position": [2, 2, 2], "intensity": [point] * 3})
    job = prepare(
        _mixed_scene(tmp_path, "cosine", lights=lights, env={"type": "constant", "radiance": sky}), seed=seed
    )
    t = job.tracer
    return t.p_area, t.p_point, t.p_env


def test_the_shares_follow_where_the_light_comes_from(tmp_path: Path) -> None:
    """A brighter type gets a larger share, every type present keeps at least about SHARE_FLOOR, absent
    types none, the shares sum to 1 and depend on the seed only through the pilot (the same seed, the same
    shares)."""
    base = _shares(tmp_path, 6.0, 0.3, 3.0)
    assert abs(sum(base) - 1.0) < 1e-12 and all(p >= SHARE_FLOOR / 1.3 for p in base)
    assert _shares(tmp_path, 6.0, 0.3, 3.0) == base
    bright_sky = _shares(tmp_path, 6.0, 30.0, 3.0)
    bright_quad = _shares(tmp_path, 600.0, 0.3, 3.0)
    bright_point = _shares(tmp_path, 6.0, 0.3, 300.0)
    assert bright_sky[2] > base[2] and bright_quad[0] > base[0] and bright_point[1] > base[1]
    assert max(bright_sky) == bright_sky[2] and max(bright_quad) == bright_quad[0]
    two = _shares(tmp_path, 6.0, 0.3)
    assert two[1] == 0.0 and abs(two[0] + two[2] - 1.0) < 1e-12


def test_one_light_type_takes_every_sample(tmp_path: Path) -> None:
    quad(tmp_path / "floor.obj", size=3.0, y=-1.0)
    scene = make_scene(
        tmp_path,
        {
            "camera": {"position": [0, 0.5, 3.5], "target": [0, -0.2, 0], "fov_deg": 45},
            "materials": [{"name": "floor", "model": "lambert"}],
            "meshes": [{"path": "floor.obj", "material": "floor"}],
            "lights": [_QUAD],
            "render": {"width": 8, "height": 8},
        },
    )
    job = prepare(scene, seed=1)
    assert (job.tracer.p_area, job.tracer.p_point, job.tracer.p_env) == (1.0, 0.0, 0.0)


def test_the_image_does_not_depend_on_the_shares(tmp_path: Path) -> None:
    """The estimator is unbiased for any shares (MIS reads them): the pilot's shares and forced equal ones
    give the same mean brightness within 4 standard errors (estimated from 24 independent passes each)."""
    scene = _mixed_scene(
        tmp_path, "cosine", lights=[_QUAD, {"type": "point", "position": [2, 2, 2], "intensity": [3, 3, 3]}]
    )
    means = []
    for forced in (False, True):
        job = prepare(scene, seed=7, max_depth=2)
        t = job.tracer
        if forced:
            t.p_area = t.p_point = t.p_env = 1.0 / 3.0
        else:
            assert max(t.p_area, t.p_point, t.p_env) > 0.4  # the pilot's shares are not the equal ones
        passes = np.array([t.render_pass(k, 32).mean() for k in range(24)])
        means.append((passes.mean(), passes.std(ddof=1) / np.sqrt(len(passes))))
    (a, sa), (b, sb) = means
    assert abs(a - b) < 4.0 * np.hypot(sa, sb), (a, sa, b, sb)


def test_a_pilot_that_finds_nothing_gives_equal_shares(tmp_path: Path) -> None:
    """Camera rays that hit nothing (the camera looks away from every surface) leave every moment 0: the
    types present share equally, none is dropped."""
    scene = _mixed_scene(tmp_path, "cosine", lights=[_QUAD], env={"type": "constant", "radiance": 0.3})
    scene.camera.target = (0.0, 10.0, 0.0)  # steeply up, past the light: no surface in view
    t = prepare(scene, seed=2).tracer
    assert (t.p_area, t.p_point, t.p_env) == (0.5, 0.0, 0.5)


def test_lights_twenty_orders_apart_keep_finite_shares(tmp_path: Path) -> None:
    """The brightest light a scene may hold (1e9) beside a sky of 1e-9: finite shares summing to 1, the bright
    type nearly all of them and the dim one still its floor (its samples are not dropped)."""
    scene = _mixed_scene(
        tmp_path, "cosine", lights=[dict(_QUAD, radiance=1e9)], env={"type": "constant", "radiance": 1e-9}
    )
    t = prepare(scene, seed=2).tracer
    shares = np.array([t.p_area, t.p_point, t.p_env])
    assert np.all(np.isfinite(shares)) and abs(shares.sum() - 1.0) < 1e-12 and shares[1] == 0.0
    assert shares[2] >= SHARE_FLOOR / (1.0 + SHARE_FLOOR) - 1e-12 and shares[0] > 0.85
