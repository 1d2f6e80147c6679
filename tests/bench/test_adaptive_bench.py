"""``bench/adaptive.py --quick``: the script runs, prints its three tables, writes its files (the build's
with a row per mode), and the exact mode reports no bound violation."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from tests.bench._load import bench_module


@pytest.fixture(scope="module")
def bench():
    yield from bench_module("adaptive")


def _read(path: Path) -> list[dict[str, str]]:
    with open(path) as fh:
        return list(csv.DictReader(fh))


def test_quick_run_writes_its_tables(bench, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "cache"))  # the samplers use none; in case
    assert bench.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    for title in ("1. Build", "2. Throughput", "3. Error"):
        assert title in printed
    for name in ("build", "throughput", "error", "albedo"):
        assert (tmp_path / f"adaptive_{name}.csv").stat().st_size > 0
    assert (tmp_path / "adaptive.png").stat().st_size > 0

    build = _read(tmp_path / "adaptive_build.csv")
    cases = ["phong", "ward sx=0.05 sy=0.25"]
    # one row per case and mode: each mode builds its own table
    assert [(r["case"], r["mode"]) for r in build] == [(c, m) for c in cases for m in ("exact", "warp")]
    assert all(float(r["build_s"]) > 0.0 and int(r["trees"]) > 0 for r in build)
    assert all(r["same_table_all_cores"] == "True" for r in build)
    for row in build:
        assert float(row["chi2_max_edge"]) >= 0.0
        assert row["build_met"] in ("yes", "NO")  # both cases have a build target, judged per mode
        if row["mode"] == "exact":
            assert 0.0 < float(row["acceptance_min"]) <= 1.0
            assert float(row["normalizer_error"]) >= 0.0
        else:  # a warp table has no bounds (no acceptance), and its mode reads no normalizer
            assert row["acceptance_min"] == "" and row["normalizer_error"] == ""
    ward = [r for r in build if r["case"] == cases[1]]
    assert all(r["memory_met"] in ("yes", "NO") for r in ward)
    section1 = printed.split("1. Build")[1].split("2. Throughput")[0].splitlines()
    for case in cases:
        for mode in ("exact", "warp"):
            assert any(line.startswith(case) and f" {mode} " in line for line in section1), (case, mode)

    errors = {(r["case"], r["sampler"]): r for r in _read(tmp_path / "adaptive_error.csv")}
    for case in ("phong", "ward sx=0.05 sy=0.25"):
        exact = errors[(case, "adaptive_exact")]
        assert int(exact["bound_violations"]) == 0
        # f cos / pdf is I(wo) for every exact sample: its spread is rounding
        assert float(exact["weight_rel_std_mean"]) < 1e-6
        assert float(errors[(case, "adaptive_warp")]["weight_rel_std_mean"]) > 0.0

    samplers = {r["sampler"] for r in _read(tmp_path / "adaptive_throughput.csv")}
    assert samplers == {"cosine", "analytic", "adaptive_exact", "adaptive_warp"}


@pytest.mark.parametrize(
    ("argv", "message"),
    [(["--models", "nope"], "unknown model(s): nope"), (["--runs", "0"], "--runs must be positive"),
     (["--option", "warp_chi2"], "--option takes K=V"), (["--option", "bogus=1"], "has no option 'bogus'"),
     (["--option", "warp_chi2=-1"], "warp_chi2")],
)  # fmt: skip
def test_bad_arguments_are_usage_errors(bench, argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        bench.main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err


def test_options_reach_both_modes_tables(bench):
    options = bench.mode_options({"warp_chi2": 0.2, "phi_count": 6})
    assert options["exact"].warp_chi2 == options["warp"].warp_chi2 == 0.2
    assert options["exact"].phi_count == options["warp"].phi_count == 6
    assert options["exact"].bounds and not options["warp"].bounds
