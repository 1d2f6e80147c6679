"""The reference store and the equal-time verdict, without Qt: chunks merged by their samples, keys that
follow the scene, the verdict's arithmetic."""

from __future__ import annotations

import numpy as np
import pytest

from app.reference import ReferenceStore, equal_time_verdict, scene_key, time_to_reach
from core.scene import Camera, Material, Scene


def _curve(pairs):
    return [{"seconds": t, "rmse": e, "relmse": e * e, "spp": i + 1} for i, (t, e) in enumerate(pairs)]


def test_time_to_reach_interpolates_log_log():
    curve = _curve([(1.0, 0.4), (4.0, 0.1)])  # error ~ t^-1
    assert time_to_reach(curve, 0.2) == pytest.approx(2.0)
    assert time_to_reach(curve, 0.5) == pytest.approx(1.0)  # reached at the first record
    assert time_to_reach(curve, 0.05) is None


def test_verdict_names_the_faster_strategy_and_the_fraction():
    # uniform ends at 0.2 after 10 s; adaptive's error ~ 0.2 (t / 10)^-0.5 / sqrt(7): it reaches 0.2 at 10/7 s
    t = np.geomspace(0.5, 10.0, 20)
    curves = {
        "uniform": _curve([(x, 0.2 * (x / 10.0) ** -0.5) for x in t]),
        "adaptive_exact": _curve([(x, 0.2 / np.sqrt(7.0) * (x / 10.0) ** -0.5) for x in t]),
    }
    assert equal_time_verdict(curves) == "adaptive_exact reaches uniform's final RMSE in 1/7 of the time"
    assert "relMSE" in equal_time_verdict(curves, "relmse")
    assert equal_time_verdict({"uniform": curves["uniform"]}) == ""  # one strategy: nothing to compare
    nan = {k: [{**r, "rmse": float("nan")} for r in v] for k, v in curves.items()}
    assert equal_time_verdict(nan) == ""  # no reference: no verdict
    same = {"a": curves["uniform"], "b": curves["uniform"]}
    assert "about the same time" in equal_time_verdict(same)


def test_scene_key_follows_what_is_rendered_not_how():
    scene = Scene(materials=[Material(name="m", model="lambert")])
    key = scene_key(scene, 32, 24)
    other = scene.model_copy(deep=True)
    other.render.sampler, other.render.spp, other.render.seed = "uniform", 1, 7  # how: same reference
    assert scene_key(other, 32, 24) == key
    other.camera = Camera(fov_deg=20.0)  # what: another reference
    assert scene_key(other, 32, 24) != key
    assert scene_key(scene, 64, 24) != key


def test_store_merges_chunks_by_their_samples_and_resumes(tmp_path):
    store = ReferenceStore(tmp_path / "project")
    rng = np.random.default_rng(3)
    a, b = rng.random((4, 6, 3)).astype(np.float32), rng.random((4, 6, 3)).astype(np.float32)
    assert store.load("k") is None
    ref = store.add(None, "k", a, 16, 1.0)
    ref = store.add(ref, "k", b, 48, 2.5)
    assert (ref.spp, ref.chunks, ref.seconds) == (64, 2, 3.5)
    np.testing.assert_allclose(ref.image, (16 * a + 48 * b) / 64, rtol=1e-6)
    assert store.exr.name == "project.reference.exr" and store.meta.exists()
    again = ReferenceStore(tmp_path / "project").load("k")  # another session
    assert again.spp == 64 and np.array_equal(again.image, ref.image)
    assert ReferenceStore(tmp_path / "project").load("another scene") is None


def test_references_go_beside_the_project_but_never_into_the_bundled_scenes(tmp_path):
    from app.main_window import demo_scene_path
    from app.reference import location

    assert location(tmp_path / "proj.json") == tmp_path / "proj"
    demo = location(demo_scene_path())
    assert not demo.resolve().is_relative_to(demo_scene_path().parent.resolve()) and demo.name == "demo"
    assert location(None).name == "untitled"
