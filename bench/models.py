"""Benchmark of the model library: evaluation throughput and directional albedo per model.

For every registered model at its default parameters (and the bundled measured demo material):

- throughput of ``core.kernels.eval_batch`` on random direction pairs over the upper hemisphere, in millions
  of evaluations per second, on one core (serial driver) and on two threads (numba ``prange`` driver); the
  best of ``--repeat`` alternating timed runs after a warm-up call (compile time excluded, reported apart: the
  drivers serve every model by its id, so the first model's warm-up call compiles or loads them for all);
- the directional albedo at theta = 0, 30, 60, 80 degrees with the stated error of ``core.analysis.albedo``
  (maximum over RGB), the number of evaluations it took and its wall time.

Prints a table and writes ``models.csv`` and ``models.png`` under ``--out`` (default ``results/bench``).

    .venv/bin/python bench/models.py [--n 2000000] [--repeat 3] [--out DIR] [--models a,b]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numba
import numpy as np

from core.analysis import albedo
from core.brdf import BRDF, all_models
from core.geometry import spherical_to_dir
from core.io import write_csv_rows
from core.kernels import eval_batch

THETAS_DEG = (0.0, 30.0, 60.0, 80.0)


def random_pairs(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    u = np.random.default_rng(seed).random((n, 4))
    wi = spherical_to_dir(np.arccos(u[:, 0]), 2.0 * np.pi * u[:, 1])
    wo = spherical_to_dir(np.arccos(u[:, 2]), 2.0 * np.pi * u[:, 3])
    return np.ascontiguousarray(wi), np.ascontiguousarray(wo)


def throughput(brdf: BRDF, wi: np.ndarray, wo: np.ndarray, repeat: int) -> tuple[float, float, float]:
    """``(M evaluations / s on one thread, on two threads, first-call seconds)`` (the first call compiles or
    loads the drivers, for every model at once).

    The serial and threaded runs alternate so that a change of machine load hits both alike."""
    t0 = time.perf_counter()
    for threads in (False, True):
        eval_batch(brdf.model, wi[:1000], wo[:1000], brdf.params, threads=threads)
    compile_s = time.perf_counter() - t0
    best = {False: float("inf"), True: float("inf")}
    for _ in range(repeat):
        for threads in (False, True):
            t0 = time.perf_counter()
            eval_batch(brdf.model, wi, wo, brdf.params, threads=threads)
            best[threads] = min(best[threads], time.perf_counter() - t0)
    n = wi.shape[0] / 1e6
    return n / best[False], n / best[True], compile_s


def subjects(names: list[str] | None) -> list[tuple[str, BRDF]]:
    out = [(m.name, m.bind()) for m in all_models() if names is None or m.name in names]
    if names is None or "merl" in names:
        from core.merl import measured_brdf
        from resources.materials import material_path

        out.append(("merl (red_plastic_ct)", measured_brdf(material_path("red_plastic_ct.binary"))))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--n", type=int, default=2_000_000, help="direction pairs per timed run")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs (best is kept)")
    parser.add_argument("--out", default="results/bench", help="output folder for CSV and PNG")
    parser.add_argument("--models", default=None, help="comma-separated subset (default: all, plus merl)")
    args = parser.parse_args(argv)
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    names = args.models.split(",") if args.models else None
    wi, wo = random_pairs(args.n)
    rows = []
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, numba {numba.__version__}, "
        f"threads {numba.get_num_threads()}, {args.n} pairs per run"
    )
    header = (
        f"{'model':<22} {'Meval/s 1':>9} {'Meval/s 2':>9} {'compile s':>9}  "
        + "  ".join(f"{'rho(' + f'{t:g}' + ')':>9} {'±err':>7}" for t in THETAS_DEG)
        + f"  {'evals':>8} {'s':>5}"
    )
    print(header)
    for name, brdf in subjects(names):
        one, two, compile_s = throughput(brdf, wi, wo, args.repeat)
        t0 = time.perf_counter()
        results = [albedo(brdf, t) for t in THETAS_DEG]
        alb_s = time.perf_counter() - t0
        lum = np.array([0.2126, 0.7152, 0.0722])
        row = {
            "model": name,
            "meval_per_s_1_thread": one,
            "meval_per_s_2_threads": two,
            "compile_s": compile_s,
            "albedo_evaluations": sum(r.evaluations for r in results),
            "albedo_seconds": alb_s,
            "albedo_converged": all(r.converged for r in results),
        }
        for t, r in zip(THETAS_DEG, results, strict=True):
            for c, ch in enumerate("RGB"):
                row[f"rho_{t:g}_{ch}"] = r.value[c]
                row[f"err_{t:g}_{ch}"] = r.error[c]
            row[f"rho_{t:g}_Y"] = float(np.dot(lum, r.value))
        rows.append(row)
        cells = "  ".join(
            f"{row[f'rho_{t:g}_Y']:9.5f} {max(r.error):7.1e}"
            for t, r in zip(THETAS_DEG, results, strict=True)
        )
        flag = "" if row["albedo_converged"] else " (budget)"
        print(
            f"{name:<22} {one:9.1f} {two:9.1f} {compile_s:9.2f}  {cells}  {row['albedo_evaluations']:8d} {alb_s:5.2f}{flag}"
        )
    print(
        "rho: luminance (Rec. 709) of the RGB albedo at default parameters; ±err: largest stated error of R, G, B"
    )

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv_rows(out / "models.csv", rows)
    _plot(rows, out / "models.png")
    print(f"wrote {out / 'models.csv'} and {out / 'models.png'}")
    return 0


def _plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["model"] for r in rows]
    y = np.arange(len(rows))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 0.35 * len(rows) + 2))
    ax1.barh(y - 0.2, [r["meval_per_s_1_thread"] for r in rows], height=0.4, label="1 thread")
    ax1.barh(y + 0.2, [r["meval_per_s_2_threads"] for r in rows], height=0.4, label="2 threads")
    ax1.set_yticks(y, names)
    ax1.invert_yaxis()
    ax1.set_xscale("log")
    ax1.set_xlabel("million evaluations / s (eval_batch)")
    ax1.legend()
    for i, r in enumerate(rows):
        style = ("-", "--", ":")[(i // 10) % 3]  # the colour cycle has 10 entries
        ax2.plot(THETAS_DEG, [r[f"rho_{t:g}_Y"] for t in THETAS_DEG], style, marker="o", label=r["model"])
    ax2.set_xlabel("theta_o (deg)")
    ax2.set_ylabel("directional albedo (luminance)")
    ax2.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
