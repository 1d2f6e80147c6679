"""``bench/adaptive.py --quick``: the script runs, prints its three tables, writes its files, and the exact
mode reports no bound violation."""

from __future__ import annotations

import csv
import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_adaptive", ROOT / "bench" / "adaptive.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


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
    assert [r["case"] for r in build] == ["phong", "ward sx=0.05 sy=0.25"]
    assert all(float(r["build_s"]) > 0.0 and int(r["trees"]) > 0 for r in build)

    errors = {(r["case"], r["sampler"]): r for r in _read(tmp_path / "adaptive_error.csv")}
    for case in ("phong", "ward sx=0.05 sy=0.25"):
        exact = errors[(case, "adaptive")]
        assert int(exact["bound_violations"]) == 0
        # f cos / pdf is I(wo) for every exact sample: its spread is rounding
        assert float(exact["weight_rel_std_mean"]) < 1e-6
        assert float(errors[(case, "adaptive_warp")]["weight_rel_std_mean"]) > 0.0

    samplers = {r["sampler"] for r in _read(tmp_path / "adaptive_throughput.csv")}
    assert samplers == {"cosine", "analytic", "adaptive", "adaptive_warp"}


@pytest.mark.parametrize(
    ("argv", "message"),
    [(["--models", "nope"], "unknown model(s): nope"), (["--runs", "0"], "--runs must be positive")],
)
def test_bad_arguments_are_usage_errors(bench, argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        bench.main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
