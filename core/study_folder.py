"""The sampler study over a folder of measured materials, as independent tasks on Dask.

``brdf-studio bench samplers --materials DIR`` runs :func:`core.study.study_material` for every measured
file of a folder (MERL ``.binary``, RGL ``.bsdf``) and every view angle: one **task** per (file, angle),
each loading its file, building its samplers and returning its rows of the study. The samplers of one case
stay in one task: they share the case's pilot run and its reference estimate (the lowest-variance strategy's
2^20 samples), which splitting them would repeat per sampler. Tasks go to ``dask.distributed``: a
``LocalCluster`` of ``workers`` single-threaded processes by default, or the scheduler at ``address``
(an existing cluster; its workers need this package installed and the folder at the same path).

A task that fails (a corrupt file, a sampler that raises) is reported with its file, angle and error; the
other tasks' rows are kept. Each worker process keeps numba to one thread (``NUMBA_NUM_THREADS=1``), so that
``n`` workers use ``n`` cores and the scaling measured is the cluster's, not numba's.

Nothing here runs Dask at import: the imports are inside the functions.
"""

from __future__ import annotations

import logging
import os
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from core.errors import BrdfStudioError, FileFormatError
from core.measured import SUFFIXES
from core.study import Row, StudyConfig

WORKER_BYTES = 768 << 20
"""An upper estimate of the memory of one local worker process running a task: the interpreter with numpy,
numba and Dask, the study's compiled kernels, one measured table and its samplers' tables."""


def local_worker_limit() -> tuple[int, str]:
    """The most local worker processes this machine holds, and why: one per core this process may run on,
    and no more than :data:`~core.budget.MEMORY_FRACTION` of the available memory holds at
    :data:`WORKER_BYTES` each (more would only queue for the cores, or swap)."""
    from core.budget import MEMORY_FRACTION, available_memory, format_bytes

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    memory = available_memory()
    limit = max(1, min(cores, int(MEMORY_FRACTION * memory // WORKER_BYTES)))
    why = (
        f"{cores} core{'s' if cores != 1 else ''}, {format_bytes(memory)} of memory available at up to "
        f"{format_bytes(WORKER_BYTES)} a worker"
    )
    return limit, why


@dataclass(frozen=True)
class Task:
    """One case of the folder study: a material file at one view angle."""

    path: str
    theta: float

    @property
    def label(self) -> str:
        from core.measured import measured_label

        return measured_label(self.path)


@dataclass(frozen=True)
class TaskFailure:
    task: Task
    error: str


@dataclass
class FolderStudy:
    """What a folder study gathered."""

    rows: list[Row]
    failures: list[TaskFailure]
    tasks: int
    seconds: float
    """Wall time, starting the cluster included."""
    workers: int
    compute_seconds: float = 0.0
    """Wall time from the cluster's being ready to the last result."""


def material_files(folder: str | os.PathLike[str]) -> list[Path]:
    """The measured files of ``folder`` (not recursive), sorted by name."""
    d = Path(folder)
    if not d.is_dir():
        raise FileFormatError(f"materials folder '{d}' does not exist or is not a folder")
    files = sorted(p for p in d.iterdir() if p.is_file() and p.suffix.lower() in SUFFIXES)
    if not files:
        raise FileFormatError(f"materials folder '{d}' holds no measured file ({', '.join(SUFFIXES)})")
    return files


def unreadable_files(files: Sequence[Path]) -> list[tuple[Path, str]]:
    """The files of ``files`` that cannot be read as measured materials, each with its reader's message.
    Each file is read once, here, before any task is submitted: a corrupt file is one line, instead of one
    failed task per view angle on the workers."""
    from core.measured import load_measured

    bad = []
    for path in files:
        try:
            load_measured(path)
        except BrdfStudioError as exc:
            bad.append((path, str(exc)))
    return bad


def run_task(task: Task, config: StudyConfig) -> list[dict[str, Any]]:
    """The study's rows for one task (run on a worker; rows as dicts, cheap to send back)."""
    from core.measured import load_measured
    from core.study import default_lights, study_material

    brdf = load_measured(task.path)
    cfg = replace(config, thetas=(task.theta,))
    return [asdict(r) for r in study_material(task.label, brdf, cfg, default_lights())]


def _describe(exc: BaseException) -> str:
    if isinstance(exc, BrdfStudioError):
        return str(exc)
    last = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
    where = f" ({Path(last[0].filename).name}:{last[0].lineno})" if last else ""
    return f"{type(exc).__name__}: {exc}{where}"


def run_folder_study(
    folder: str | os.PathLike[str],
    config: StudyConfig,
    workers: int = 2,
    address: str | None = None,
    progress: Callable[[int, int, Task, str | None], None] | None = None,
    files: Sequence[Path] | None = None,
) -> FolderStudy:
    """Every (file, angle) task of ``folder`` on a Dask cluster; ``progress(done, total, task, error)`` after
    each task. Raises :class:`BrdfStudioError` when the cluster cannot be reached or started."""
    from dask.distributed import Client, LocalCluster, as_completed

    paths = list(files) if files is not None else material_files(folder)
    tasks = [Task(str(p.resolve()), float(t)) for p in paths for t in config.thetas]
    cluster = None
    t0 = time.perf_counter()
    try:
        if address:
            try:
                client = Client(address, timeout="10s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise BrdfStudioError(f"cannot reach the Dask scheduler at '{address}': {exc}") from None
        else:
            saved = os.environ.get("NUMBA_NUM_THREADS")
            os.environ["NUMBA_NUM_THREADS"] = "1"  # the worker processes start with this environment
            try:
                cluster = LocalCluster(
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=":0",
                    silence_logs=logging.CRITICAL,  # a failed task is reported once, by the caller
                )
            finally:
                if saved is None:
                    os.environ.pop("NUMBA_NUM_THREADS", None)
                else:
                    os.environ["NUMBA_NUM_THREADS"] = saved
            client = Client(cluster)
        with client:
            n_workers = len(client.scheduler_info().get("workers", {})) or workers
            t_ready = time.perf_counter()
            futures = {}
            for task in tasks:
                # pure=False: a task is a measurement (it times itself), never deduplicated or cached.
                fut = client.submit(run_task, task, config, pure=False, key=f"study-{len(futures)}")
                futures[fut] = task
            rows: list[Row] = []
            failures: list[TaskFailure] = []
            for done, fut in enumerate(as_completed(futures), start=1):
                task = futures[fut]
                error = None
                if fut.status == "error":
                    error = _describe(fut.exception())
                    failures.append(TaskFailure(task, error))
                else:
                    rows += [Row(**r) for r in fut.result()]
                if progress is not None:
                    progress(done, len(tasks), task, error)
            compute = time.perf_counter() - t_ready
    finally:
        if cluster is not None:
            cluster.close()
    order = {(t.label, t.theta): i for i, t in enumerate(tasks)}
    rows.sort(key=lambda r: order.get((r.material, r.theta_o), 0))
    return FolderStudy(rows, failures, len(tasks), time.perf_counter() - t0, n_workers, compute)
