"""The sampler study: rows for every strategy, unbiasedness against the reference, files written, and the
zero-variance property showing up where it must (cosine sampling of Lambert in the furnace)."""

from __future__ import annotations

import csv
import math

import pytest

from app.cli import main
from core.study import StudyConfig, default_lights, materials, study_material, write_results


@pytest.fixture(scope="module")
def rows():
    cfg = StudyConfig(thetas=(30.0,), counts=(16, 256), batch=1 << 13, reference_samples=1 << 15)
    cfg.samplers = ("uniform", "cosine", "uniform_cdf", "ris")
    ((label, brdf),) = materials(["lambert"])
    return study_material(label, brdf, cfg, default_lights())


def test_every_strategy_light_and_count_has_a_finite_row(rows):
    keys = {(r.sampler, r.light, r.samples) for r in rows}
    assert len(keys) == 4 * 3 * 2 == len(rows)
    for r in rows:
        assert math.isfinite(r.rel_rmse) and r.rel_rmse >= 0.0
        assert r.seconds_per_sample > 0.0 and r.samples_per_second > 0.0


def test_error_falls_as_one_over_root_n(rows):
    by = {(r.sampler, r.light, r.samples): r.rel_rmse for r in rows}
    for s in ("uniform", "uniform_cdf"):
        assert by[(s, "environment", 256)] == pytest.approx(by[(s, "environment", 16)] / 4.0, rel=1e-9)


def test_strategies_are_unbiased_against_the_reference(rows):
    # 4 strategies x 3 lights; |z| < 5 has a false-alarm rate below 1e-5 per row for a Gaussian mean.
    for r in rows:
        assert abs(r.bias_z) < 5.0, r


def test_cosine_sampling_of_lambert_in_the_furnace_has_zero_variance(rows):
    cos = [r for r in rows if r.sampler == "cosine" and r.light == "furnace"]
    uni = [r for r in rows if r.sampler == "uniform" and r.light == "furnace"]
    assert all(r.rel_rmse < 1e-12 for r in cos)
    assert all(r.rel_rmse > 1e-3 for r in uni)


def test_results_files(rows, tmp_path):
    paths = write_results(rows, tmp_path)
    with open(paths["csv"]) as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == len(rows) and {"sampler", "rel_rmse", "efficiency"} <= set(table[0])
    assert "| lambert | uniform_cdf |" in paths["markdown"].read_text()
    for key in ("error_vs_samples", "error_vs_time"):
        assert paths[key].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "argv,message",
    [
        (["bench", "samplers", "--models", "nope"], "unknown model 'nope'"),
        (["bench", "samplers", "--samplers", "magic"], "unknown sampler(s) magic"),
        (["bench", "samplers", "--thetas", "95"], "[0, 90]"),
    ],
)
def test_bad_input_is_a_clear_error(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_quick_study_runs_end_to_end(tmp_path, capsys):
    """`brdf-studio bench samplers --quick` (the CI smoke run) writes its table, CSV and plots."""
    assert main(["bench", "samplers", "--quick", "--models", "lambert", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| lambert | adaptive |" in out and "| lambert | factored |" in out
    with open(tmp_path / "study.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["sampler"] for r in rows} >= {
        "uniform",
        "cosine",
        "adaptive",
        "uniform_cdf",
        "compress_cdf",
        "factored",
        "ris",
    }
    assert all(math.isfinite(float(r["rel_rmse"])) for r in rows)
