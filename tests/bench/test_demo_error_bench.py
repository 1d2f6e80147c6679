"""``bench/demo_error.py``: the direct-only render is the first bounce's share of the full one (the premise
of its direct/indirect split), and the script writes its table."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from app.commands.render import demo_scene_path
from core.scene import load_scene
from tests.bench._load import bench_module


@pytest.fixture(scope="module")
def bench():
    yield from bench_module("demo_error")


def test_direct_only_is_a_prefix_of_the_full_render(bench):
    scene = load_scene(demo_scene_path())
    full, _, _, _, classes = bench.render_stats(scene, "cosine", 24, 4, 1, scene.render.max_depth)
    direct, _, _, _, _ = bench.render_stats(scene, "cosine", 24, 4, 1, 1)
    indirect = full - direct
    assert indirect.min() >= -1e-12  # the same paths: the longer ones only add light
    assert indirect.max() > 0.0
    assert classes.shape == (24, 24) and (classes == -2).any()  # some pixels see the sky


def test_the_script_writes_its_table(bench, tmp_path):
    assert bench.main(["--size", "16", "--spp", "2", "--ref-spp", "4", "--strategies", "uniform,cosine",
                       "--out", str(tmp_path)]) == 0  # fmt: skip
    with open(tmp_path / "demo_error.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["strategy"] for r in rows} == {"uniform", "cosine"}
    assert {r["component"] for r in rows} == {"full", "direct", "indirect"}
    total = [r for r in rows if r["class"] == "all" and r["component"] == "full"]
    assert all(float(r["mse_raw"]) > 0 and np.isfinite(float(r["mse"])) for r in total)
