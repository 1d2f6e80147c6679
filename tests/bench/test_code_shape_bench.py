"""``bench/code_shape.py``: the codebase's shape targets hold on the tree, and the measures see what they
count (a positional read, a wide compiled function, a second guide builder planted in a copy)."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest

from tests.bench._load import bench_module


@pytest.fixture(scope="module")
def bench():
    yield from bench_module("code_shape")


def test_the_tree_meets_every_target(bench, tmp_path: Path) -> None:
    assert bench.main(["--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader(open(tmp_path / "code_shape.csv", encoding="utf-8")))
    assert {r["measure"] for r in rows} >= {
        "positional parameter reads in core/models",
        "guide-table builders",
    }
    assert all(r["met"] == "True" for r in rows)


def test_the_measures_find_what_they_count(bench, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "tree"
    for package in ("core", "renderer", "app"):
        shutil.copytree(bench.ROOT / package, root / package, ignore=shutil.ignore_patterns("__pycache__"))
    (root / "core" / "models" / "planted.py").write_text("def eval_planted(wi, wo, p):\n    return p[3]\n")
    args = ", ".join(f"a{i}" for i in range(13))
    (root / "renderer" / "planted.py").write_text(
        f"from numba import njit\n\n\n@njit\ndef wide({args}):\n    return a0\n\n\n"
        "def make_guide(cdf, out):\n    for g in range(out.shape[0]):\n        out[g] = cdf[g]\n"
    )
    monkeypatch.setattr(bench, "ROOT", root)
    assert bench.main(["--out", str(tmp_path / "out")]) == 1
    rows = {
        r["measure"]: r for r in csv.DictReader(open(tmp_path / "out" / "code_shape.csv", encoding="utf-8"))
    }
    assert rows["positional parameter reads in core/models"]["value"] == "1"
    assert rows["compiled functions over 12 arguments"]["value"] == "1"
    assert rows["guide-table builders"]["value"].startswith("2 ")
