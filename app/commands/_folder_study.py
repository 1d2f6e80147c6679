"""``brdf-studio bench samplers --materials DIR``: the sampler study over a folder of measured materials, one
Dask task per (file, view angle) (:mod:`core.study_folder`), with a progress bar; the gathered rows go to the
study's usual table, CSV and plots, and failed tasks to ``failures.csv`` and the terminal (exit code 1 when any
task failed; the others' results are still written)."""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

from tqdm import tqdm

from core.errors import FileFormatError
from core.study import StudyConfig, write_results
from core.study_folder import local_worker_limit, material_files, run_folder_study, unreadable_files

DEFAULT_WORKERS = 2
NAMED_BAD_FILES = 3
"""How many unreadable files the refusal names, each with its reason (the line stays readable)."""


def local_workers(asked: int | None) -> int:
    """The local cluster's size: ``--workers`` (default :data:`DEFAULT_WORKERS`) capped to what the machine
    holds (:func:`core.study_folder.local_worker_limit`); a request above it is capped with a note saying so."""
    limit, why = local_worker_limit()
    workers = DEFAULT_WORKERS if asked is None else asked
    if workers <= limit:
        return workers
    if asked is not None:
        print(f"brdf-studio bench: note: --workers {asked} capped to {limit}, what this machine holds ({why})",
              file=sys.stderr)  # fmt: skip
    return limit


def run_folder(args: argparse.Namespace, config: StudyConfig) -> int:
    files = material_files(args.materials)
    bad = unreadable_files(files)
    if bad:
        named = "; ".join(why for _, why in bad[:NAMED_BAD_FILES])
        more = f"; and {len(bad) - NAMED_BAD_FILES} more" if len(bad) > NAMED_BAD_FILES else ""
        raise FileFormatError(
            f"{len(bad)} of {len(files)} measured files of '{args.materials}' cannot be read: {named}{more}; "
            "fix or move them"
        )
    workers = local_workers(args.workers) if args.scheduler is None else 0  # (a note only once it will run)
    total = len(files) * len(config.thetas)
    where = f"scheduler {args.scheduler}" if args.scheduler else f"a local cluster of {workers} workers"
    print(f"{len(files)} materials x {len(config.thetas)} view angles = {total} tasks on {where}")
    with tqdm(total=total, desc="sampler study", unit="task", disable=None) as bar:

        def progress(done: int, n: int, task, error: str | None) -> None:  # type: ignore[no-untyped-def]
            bar.update(1)
            bar.set_postfix_str(f"{task.label} {task.theta:g} deg" + (" FAILED" if error else ""))

        study = run_folder_study(
            args.materials,
            config,
            workers=workers,
            address=args.scheduler,
            progress=progress,
            files=files,
        )
    args.out.mkdir(parents=True, exist_ok=True)
    failures_path = args.out / "failures.csv"
    with open(failures_path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["file", "theta_o", "error"])
        for f in study.failures:
            writer.writerow([f.task.path, f.task.theta, f.error])
    if study.rows:
        paths = write_results(study.rows, args.out)
        print(paths["markdown"].read_text())
        print("wrote " + ", ".join(str(p) for p in paths.values()) + f", {failures_path}")
    print(
        f"{study.tasks - len(study.failures)} of {study.tasks} tasks done in {study.seconds:.1f} s "
        f"on {study.workers} workers"
    )
    for f in study.failures:
        print(f"FAILED {Path(f.task.path).name} at {f.task.theta:g} deg: {f.error}")
    return 1 if study.failures else 0
