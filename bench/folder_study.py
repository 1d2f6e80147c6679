"""Scaling of the folder study on Dask: the same tasks on a local cluster of 1 and of 2 workers.

    .venv/bin/python bench/make_materials.py --out results/materials      # the 22-material folder, once
    .venv/bin/python bench/folder_study.py --materials results/materials [--workers 1 2] [--out results/bench]

Runs ``core.study_folder.run_folder_study`` (the code behind ``brdf-studio bench samplers --materials DIR``)
with the ``--quick`` study settings (one view angle, 30 degrees: one task per file) and the samplers
``uniform cosine analytic adaptive_warp factored`` — the exact ``adaptive`` mode is left out because its
tables for anisotropic measured files take ~80 s each and would make the run ~30 min per worker count; what
is measured is the cluster's scaling, not a sampler. Each run starts from an empty table cache
(``BRDF_STUDIO_CACHE`` set to a fresh folder, inherited by the workers), so no run reuses another's tables.
Wall time includes starting the cluster. Before the timed runs, one untimed run on the first ``--warmup`` files
compiles whatever numba has not cached yet (the first run after an edit of the RGL kernels paid such compiles in
its 1-worker run and made 2 workers look 3.6x faster); then ``--runs`` rounds time every worker count, the order
reversed every other round, and the table gives each count's median (lower median for an even count) with every
run. Target: 2 workers in <= 0.6 x the time of 1. Prints a table, writes ``folder_study.csv`` and
``folder_study.png``.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from core.errors import BrdfStudioError  # noqa: E402
from core.study import StudyConfig  # noqa: E402
from core.study_folder import material_files, run_folder_study  # noqa: E402

SAMPLERS = ("uniform", "cosine", "analytic", "adaptive_warp", "factored")
TARGET = 0.6


def _timed_run(materials: Path, config: StudyConfig, files: list[Path], workers: int) -> dict:
    with tempfile.TemporaryDirectory() as cache:
        saved = os.environ.get("BRDF_STUDIO_CACHE")
        os.environ["BRDF_STUDIO_CACHE"] = cache
        try:
            load = os.getloadavg()[0]
            t0 = time.perf_counter()
            study = run_folder_study(materials, config, workers=workers, files=files)
            seconds = time.perf_counter() - t0
        finally:
            if saved is None:
                os.environ.pop("BRDF_STUDIO_CACHE", None)
            else:
                os.environ["BRDF_STUDIO_CACHE"] = saved
    return {
        "workers": workers,
        "tasks": study.tasks,
        "failed": len(study.failures),
        "seconds": round(seconds, 1),
        "compute_seconds": round(study.compute_seconds, 1),
        "load_before": round(load, 2),
        "load_after": round(os.getloadavg()[0], 2),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--materials", type=Path, required=True, help="folder (bench/make_materials.py)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--samplers", nargs="+", default=list(SAMPLERS))
    parser.add_argument("--runs", type=int, default=2, help="timed rounds (order reversed every other one)")
    parser.add_argument("--warmup", type=int, default=3, help="files of the untimed warm-up run (0: none)")
    parser.add_argument("--out", type=Path, default=Path("results/bench"))
    args = parser.parse_args(argv)
    try:
        files = material_files(args.materials)
    except BrdfStudioError as exc:
        print(
            f"error: {exc} (write it with: python bench/make_materials.py --out {args.materials})",
            file=sys.stderr,
        )
        return 2
    config = StudyConfig(
        thetas=(30.0,),
        counts=(16, 64, 256),
        batch=1 << 14,
        reference_samples=1 << 17,
        samplers=tuple(args.samplers),
    )
    args.out.mkdir(parents=True, exist_ok=True)
    if args.warmup > 0:
        run_folder_study(args.materials, config, workers=max(args.workers), files=files[: args.warmup])
    timed: list[dict] = []
    for round_ in range(args.runs):
        order = args.workers if round_ % 2 == 0 else list(reversed(args.workers))
        for workers in order:
            r = _timed_run(args.materials, config, files, workers)
            timed.append(r)
            print(
                f"round {round_ + 1}: {workers} worker(s) {r['seconds']:.1f} s, {r['compute_seconds']:.1f} s after "
                f"the cluster's start (load {r['load_before']})",
                flush=True,
            )
    rows = []
    for workers in args.workers:
        mine = sorted((r for r in timed if r["workers"] == workers), key=lambda r: r["seconds"])
        rows.append({**mine[(len(mine) - 1) // 2], "runs": " / ".join(f"{r['seconds']:.1f}" for r in mine)})
    compute_base = rows[0]["compute_seconds"]
    base = rows[0]["seconds"]
    print(
        "\n| workers | tasks | failed | median wall s | runs (s) | × the first | after the cluster's start: s, × | "
        "load avg before / after |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        r["ratio"] = round(r["seconds"] / base, 3)
        r["compute_ratio"] = round(r["compute_seconds"] / compute_base, 3)
        print(
            f"| {r['workers']} | {r['tasks']} | {r['failed']} | {r['seconds']:.1f} | {r['runs']} | {r['ratio']:.2f} | "
            f"{r['compute_seconds']:.1f}, {r['compute_ratio']:.2f} | {r['load_before']} / {r['load_after']} |"
        )
    with open(args.out / "folder_study.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.bar([str(r["workers"]) for r in rows], [r["seconds"] for r in rows])
    ax.axhline(TARGET * base, color="C3", ls="--", label=f"target {TARGET} x the first")
    ax.set_xlabel("Dask workers")
    ax.set_ylabel("median wall time (s)")
    ax.set_title(f"Folder study, {len(files)} materials")
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out / "folder_study.png", dpi=120)
    print(f"wrote {args.out / 'folder_study.csv'}, {args.out / 'folder_study.png'}")
    met = len(rows) < 2 or rows[-1]["ratio"] <= TARGET
    print(f"target (2 workers <= {TARGET} x 1 worker): {'met' if met else 'missed'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
