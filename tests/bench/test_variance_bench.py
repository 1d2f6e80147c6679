"""``bench/variance.py``: the common-sample variance estimates agree with closed forms and the script writes
its files."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from core.brdf import LUMINANCE, make_brdf
from core.geometry import degrees_to_dir
from tests.bench._load import bench_module


@pytest.fixture(scope="module")
def bench():
    yield from bench_module("variance")


def test_lambert_variances_match_closed_forms(bench, tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path))
    brdf = make_brdf("lambert")
    rho = float(brdf.params[:3] @ LUMINANCE)  # kd, an RGB albedo
    rots = np.stack([np.eye(3)])
    v = bench.variances(brdf, degrees_to_dir(30.0, 20.0), 1 << 16, rots, seed=3)
    # uniform: int (rho cos / pi)^2 2 pi dw - rho^2 = 4 rho^2 / 3 - rho^2 = rho^2 / 3; the estimate's sd is ~0.4 %
    assert v["uniform"]["furnace"] == pytest.approx(rho**2 / 3.0, rel=0.02)
    # cosine and adaptive have the Lambertian's own density: zero variance in the furnace, equal under light
    assert abs(v["cosine"]["furnace"]) < 1e-6 and abs(v["adaptive_exact"]["furnace"]) < 1e-6
    assert v["adaptive_exact"]["sky"] == pytest.approx(v["cosine"]["sky"], rel=1e-4)


def test_the_script_writes_its_table(bench, tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "cache"))
    rows = bench.run(["phong"], 4096, 4, tmp_path)
    assert (tmp_path / "variance.png").stat().st_size > 0
    with open(tmp_path / "variance.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [r["model"] for r in table] == ["phong"]
    assert rows[0]["furnace_met"]  # f cos / I is exact: zero variance in the furnace
    assert float(table[0]["sky_adaptive"]) > 0.0


@pytest.mark.parametrize(
    ("argv", "message"),
    [(["--models", "nope"], "unknown model(s): nope"), (["--n", "-5"], "must be positive")],
)
def test_bad_arguments_are_usage_errors(bench, argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        bench.main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
