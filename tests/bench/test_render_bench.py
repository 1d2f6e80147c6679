"""``bench/render.py``: the Cornell comparison's sample counts, Embree alone on the timed pass's rays, the
reference's own noise."""

from __future__ import annotations

import csv

import pytest

from tests.bench._load import bench_module


@pytest.fixture(scope="module")
def bench():
    yield from bench_module("render")


def test_ldsampler_counts_are_the_square_powers_of_two_it_renders(bench):
    """Mitsuba's ``ldsampler`` rounds a sample count up to 4, 16, 64, ...: the records say what was rendered
    (they said what was asked: 1, 2 and 4 were three records of one 4-spp image), other samplers take the
    count as asked."""
    asked = [1, 2, 4, 8, 16, 32, 64, 128, 1024, 2048]
    assert [bench._mitsuba_spp("ldsampler", s) for s in asked] == [4, 4, 4, 16, 16, 64, 64, 256, 1024, 4096]
    assert [bench._mitsuba_spp(None, s) for s in asked] == asked
    assert [bench._mitsuba_spp("independent", s) for s in asked] == asked


def test_embree_alone_traces_the_very_rays_of_the_timed_pass(bench):
    """The share of Embree alone compares a pass with Embree on the rays that pass traced: one timed pass
    (pass 0) and the recorded one (pass 0 again) trace the same number of rays, and the rates are positive."""
    from app.commands.render import demo_scene_path
    from core.scene import load_scene

    tp = bench.throughput(load_scene(demo_scene_path()), 24, 1)
    assert tp["rays"] == tp["rays_recorded"] > 24 * 24
    assert 0.0 < tp["share_of_embree"] < 2.0 and tp["seconds_per_spp"] > 0.0


@pytest.mark.parametrize(("v", "spp", "ref_spp"), [(0.37, 300, 8192), (2e-3, 17, 256), (5.0, 4096, 4096)])
def test_the_references_own_noise_is_taken_from_the_row_of_the_estimator_that_rendered_it(
    bench, v, spp, ref_spp
):
    """An estimator of per-sample variance ``v`` at ``spp`` against an independent reference of ``ref_spp``
    shows ``v / spp + v / ref_spp``; the estimate returns the reference's part, ``v / ref_spp``."""
    measured = v / spp + v / ref_spp
    assert bench.reference_mse(measured, spp, ref_spp) == pytest.approx(v / ref_spp, rel=1e-12)


def test_the_equal_time_table_gives_each_rmse_without_the_references_noise(bench, tmp_path):
    """A tiny equal-time run writes ``render_equal_time.csv``: a row per strategy, the reference's estimated
    RMSE from analytic's row, and each RMSE without it (never above the RMSE measured)."""
    args = ["--size", "16", "--time", "0.3", "--ref-spp", "8", "--skip-throughput", "--strategies",
            "uniform,analytic", "--out", str(tmp_path)]  # fmt: skip
    assert bench.main(args) in (0, None)
    with open(tmp_path / "render_equal_time.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["strategy"] for r in rows] == ["uniform", "analytic"]
    for r in rows:
        rmse, own, ref = (
            float(r["rmse"]),
            float(r["rmse_without_reference"]),
            float(r["reference_rmse_estimate"]),
        )
        assert 0.0 < ref and 0.0 <= own <= rmse
        # (the file's six digits: a difference of squares within a few 1e-6 of the larger)
        assert own**2 == pytest.approx(max(rmse**2 - ref**2, 0.0), abs=5e-6 * rmse**2)


def test_the_last_cornell_ratio_is_against_the_fastest_mitsuba_at_each_level(bench):
    """Ours over each Mitsuba configuration, then over the fastest of them level by level: a configuration
    that is fastest at one level and slowest at another counts only where it leads."""
    ours = [{"seconds": 1.0, "rmse": 0.04}, {"seconds": 4.0, "rmse": 0.01}]
    fast_early = [{"seconds": 0.5, "rmse": 0.04}, {"seconds": 8.0, "rmse": 0.01}]
    fast_late = [{"seconds": 2.0, "rmse": 0.04}, {"seconds": 2.0, "rmse": 0.01}]
    never = [{"seconds": 1.0, "rmse": 0.09}, {"seconds": 9.0, "rmse": 0.05}]
    curves = {"us": ours, "mitsuba a": fast_early, "mitsuba b": fast_late, "mitsuba c": never}
    rows = {r["against"]: r for r in bench.ratio_rows(curves, "us", (0.04, 0.01))}
    assert list(rows) == ["a", "b", "c", bench.BEST_MITSUBA]
    assert rows["a"]["ratio_0.04"] == pytest.approx(2.0) and rows["a"]["ratio_0.01"] == pytest.approx(0.5)
    assert rows["b"]["ratio_0.04"] == pytest.approx(0.5) and rows["b"]["ratio_0.01"] == pytest.approx(2.0)
    assert rows["c"]["ratio_0.04"] is None
    best = rows[bench.BEST_MITSUBA]
    assert best["ratio_0.04"] == pytest.approx(2.0) and best["ratio_0.01"] == pytest.approx(2.0)
