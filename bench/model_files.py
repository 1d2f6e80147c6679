"""Benchmark of a model file against the built-in Disney principled BRDF: load, evaluation and table build.

    .venv/bin/python bench/model_files.py [FILE.brdf] [--n 1000000] [--repeat 5] [--builds 3] [--out DIR]

``FILE.brdf`` is BRDF Explorer's ``disney.brdf`` (github ``wdas/brdf``, ``src/brdfs/``; not in this
repository) or any translation of the same model with its parameter names (default: our fixture
``tests/core/glsl/fixtures/principled.brdf``). Each figure is reported with the error that goes with it:

- **load**: seconds of ``load_model_file`` in a new process (read, translate, compile with LLVM, probe), the
  median of ``--repeat`` processes;
- **evaluation**: ``core.kernels.eval_batch`` on ``--n`` random pairs of the upper hemisphere, one thread,
  millions of evaluations per second (the best of ``--repeat`` after a warm-up call), the file through the
  dispatch's file-model branch and the built-in ``disney`` kernel at the same parameters (the file's defaults; ``baseColor`` raised to 2.2 for the built-in, whose colour
  is linear), their ratio, and the
  largest difference between the two relative to the larger value (the file computes in float32, as GLSL);
- **tables**: the ``adaptive_exact`` and ``adaptive_warp`` tables built without a cache, isotropic
  (``anisotropic`` 0) and anisotropic (0.8), each build from scratch after a warm-up build of another model
  (the build's kernels compiled or loaded): seconds (median of ``--builds``), the layout's symmetry, leaves,
  evaluations, the smallest acceptance (the guarantee is ``1/n_max``) and the normalizer's estimated error;
  the same for the built-in model beside it.

Prints a table and writes ``model_files.csv`` under ``--out`` (default ``results/bench``).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from core.brdf import get_model, make_brdf  # noqa: E402
from core.io import write_csv_rows  # noqa: E402
from core.kernels import eval_batch  # noqa: E402
from core.sampling import make_sampler  # noqa: E402
from core.sampling.adaptive.sampler import clear_memory_cache  # noqa: E402

FIXTURE = ROOT / "tests" / "core" / "glsl" / "fixtures" / "principled.brdf"
SETTINGS = {"isotropic": {"anisotropic": 0.0}, "anisotropic": {"anisotropic": 0.8}}
TARGETS = {"evaluation ratio": 0.5, "isotropic": 0.2, "anisotropic": 2.0}
"""The issue's targets: throughput at least half the built-in kernel's; table builds within these seconds."""


def random_pairs(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    u = np.random.default_rng(seed).random((n, 4))
    out = []
    for a, b in ((0, 1), (2, 3)):
        cos_t, phi = u[:, a], 2.0 * np.pi * u[:, b]
        sin_t = np.sqrt(1.0 - cos_t**2)
        out.append(np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1))
    return out[0], out[1]


def as_built_in(values: dict) -> dict:
    """The built-in model's values for a file's: its ``baseColor`` is linear, the file's a monitor colour
    that the shader raises to 2.2."""
    return {**values, "baseColor": tuple(c**2.2 for c in values["baseColor"])}


def load_seconds(path: Path, repeat: int) -> float:
    code = (
        "import time, sys\n"
        "from core.model_files import load_model_file\n"
        "t = time.perf_counter(); load_model_file(sys.argv[1]); print(time.perf_counter() - t)\n"
    )
    times = []
    for _ in range(repeat):
        done = subprocess.run(
            [sys.executable, "-c", code, str(path)], cwd=ROOT, capture_output=True, text=True, check=True
        )
        times.append(float(done.stdout.split()[-1]))
    return statistics.median(times)


def throughput(brdf, wi: np.ndarray, wo: np.ndarray, repeat: int) -> tuple[float, np.ndarray]:
    values = eval_batch(brdf.model, wi, wo, brdf.params)  # warm-up (compile or load)
    best = min(_timed(lambda: eval_batch(brdf.model, wi, wo, brdf.params)) for _ in range(repeat))
    return len(wi) / best / 1e6, values


def _timed(fn) -> float:  # type: ignore[no-untyped-def]
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def table_row(brdf, strategy: str, builds: int) -> dict:  # type: ignore[no-untyped-def]
    seconds, info = [], {}
    for _ in range(builds):
        clear_memory_cache()
        sampler = make_sampler(strategy, brdf, n_max=2.0, cache=False)
        t = time.perf_counter()
        sampler.table  # noqa: B018 (builds it)
        seconds.append(time.perf_counter() - t)
        info = sampler.info()
    from core.sampling.adaptive.layout import ISOTROPIC, MIRROR
    from core.sampling.adaptive.survey import symmetry_of

    layout = {ISOTROPIC: "isotropic", MIRROR: "mirror"}.get(symmetry_of(brdf), "full")
    return {
        "seconds": statistics.median(seconds),
        "layout": layout,
        "leaves": info["leaves"],
        "evaluations": info["evaluations"],
        "acceptance_min": info["acceptance_min"],
        "normalizer_error": info["normalizer_error"],
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("file", nargs="?", type=Path, default=FIXTURE)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--builds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    args = ap.parse_args()
    path = args.file.resolve()

    rows = []
    load = load_seconds(path, args.repeat)
    print(f"{path.name}: load_model_file in a new process, median of {args.repeat}: {load:.3f} s")
    rows.append({"measure": "load", "file_model": load, "built_in": "", "ratio": "", "error": ""})

    wi, wo = random_pairs(args.n)
    print(f"\nevaluation, {args.n:g} random pairs, one thread, best of {args.repeat} (M evals/s)")
    print(
        f"{'setting':<12} {'file':>8} {'built-in':>9} {'ratio':>6} {'max rel diff':>13}  target ratio >= 0.5"
    )
    defaults = {p.name: p.default for p in get_model(str(path)).params}
    settings = {name: {**defaults, **values} for name, values in SETTINGS.items()}
    for name, values in settings.items():
        mine, builtin = make_brdf(str(path), values), make_brdf("disney", as_built_in(values))
        rate_file, f_file = throughput(mine, wi, wo, args.repeat)
        rate_builtin, f_builtin = throughput(builtin, wi, wo, args.repeat)
        top = np.maximum(np.abs(f_file), np.abs(f_builtin))
        rel = float(np.max(np.abs(f_file - f_builtin) / np.maximum(top, 1e-6 * top.max())))
        ratio = rate_file / rate_builtin
        met = "met" if ratio >= TARGETS["evaluation ratio"] else "MISSED"
        print(f"{name:<12} {rate_file:8.2f} {rate_builtin:9.2f} {ratio:6.2f} {rel:13.2e}  {met}")
        rows.append({"measure": f"evaluation {name} (M/s)", "file_model": rate_file, "built_in": rate_builtin,
                     "ratio": ratio, "error": rel})  # fmt: skip

    print(f"\ntables without a cache, n_max 2, median of {args.builds} builds")
    print(f"{'setting':<12} {'sampler':<14} {'model':<9} {'s':>7} {'layout':<10} {'leaves':>7} {'evals':>9} "
          f"{'acc min':>8} {'norm err':>9}  target")  # fmt: skip
    for strategy in ("adaptive_exact", "adaptive_warp"):  # warm-up: the build's kernels compiled or loaded
        make_sampler(strategy, make_brdf("lambert", {}), n_max=2.0, cache=False).table  # noqa: B018
    for name, values in settings.items():
        for strategy in ("adaptive_exact", "adaptive_warp"):
            for label, brdf in (
                ("file", make_brdf(str(path), values)),
                ("built-in", make_brdf("disney", as_built_in(values))),
            ):
                r = table_row(brdf, strategy, args.builds)
                target = TARGETS[name]
                met = ("met" if r["seconds"] <= target else "MISSED") if label == "file" else ""
                print(f"{name:<12} {strategy:<14} {label:<9} {r['seconds']:7.3f} {r['layout']:<10} "
                      f"{r['leaves']:7d} {r['evaluations']:9d} {r['acceptance_min']:8.3f} "
                      f"{r['normalizer_error']:9.2e}  <= {target:g} s {met}")  # fmt: skip
                rows.append({"measure": f"table {name} {strategy} {label} (s)", "file_model": r["seconds"],
                             "built_in": "", "ratio": "", "error": r["normalizer_error"]})  # fmt: skip

    args.out.mkdir(parents=True, exist_ok=True)
    write_csv_rows(args.out / "model_files.csv", rows)
    print(f"\ntable: {args.out / 'model_files.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
