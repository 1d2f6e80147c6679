"""``bench/placement.py``: a warp that keeps nothing of the points scores ~1, one that keeps them scores far
below, and the script writes one row per strategy and model (bad options refused)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from core.brdf import make_brdf
from core.geometry import degrees_to_dir
from core.sampling import make_sampler
from tests.bench._load import bench_module


@pytest.fixture(scope="module")
def bench():
    yield from bench_module("placement")


def test_the_spread_ratio_tells_an_inversion_from_independent_points(bench):
    wo = degrees_to_dir(35.0, 20.0)
    inversion = bench.spread_ratios(make_sampler("uniform_cdf", make_brdf("phong", {"n": 8.0})), wo, 16, 30)
    assert max(inversion["wi_z"], inversion["wi_x"], inversion["wi_y"]) < 0.3
    # Phong's analytic sampler picks its lobe by a number of its own: wi_z's spread stays that of iid points
    analytic = bench.spread_ratios(make_sampler("analytic", make_brdf("phong", {"n": 8.0})), wo, 16, 30)
    assert analytic["wi_z"] > 0.6


def test_the_script_writes_a_row_per_case_and_refuses_bad_options(bench, tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "cache"))
    assert bench.main(["--grid", "4", "--repeats", "3", "--runs", "1", "--out", str(tmp_path)]) == 0
    with open(tmp_path / "placement.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(bench.CASES) * len(bench.MODELS)
    assert all(np.isfinite(float(r["own_ns"])) and float(r["placed_ns"]) > 0 for r in rows)
    assert bench.main(["--grid", "1", "--out", str(tmp_path)]) == 2
