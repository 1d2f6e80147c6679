"""Renders on Dask (:mod:`renderer.distributed`) against one process: scaling and overhead at a fixed spp.

Each configuration renders the same scene, size, seed and samples per pixel, preparation included (wall
time from the call to the last image):

- ``one process, N threads``: :func:`renderer.render.prepare` and its passes in a process of that thread
  count's own (kept from round to round; this one hosts the Dask clients and local clusters);
- ``N local workers``: a local cluster of N single-threaded worker processes, already started and warm
  (a small render on it first, another seed, so that every worker has imported the renderer, loaded its
  kernels and read the tables), then :func:`renderer.distributed.prepare_distributed` and its passes: the
  client's tables and scene files sent, every worker preparing the scene, the blocks, the film;
- with ``--scheduler ADDRESS``: the cluster at that address instead of local ones (its workers as they are).

The one-process renders are warm too (a render of another seed first, in this process). Round ``r`` renders
seed ``--seed + r`` in every configuration, so that every round is a new render everywhere (a worker keeps a
render it prepared: the same seed again would skip its preparation). Rounds alternate the configurations (a
shared machine's load falls on all of them alike); the table shows each configuration's fastest and median
round. ``scaling`` is a configuration's median time over the 1-worker cluster's; ``overhead`` is its median
time over the median of the one-process render with as many threads as the cluster has, minus one.
``exact`` says whether every round's image equals the one-process image of that round bit for bit.
``cpu_overhead`` compares CPU seconds instead (this process's with the local clusters' schedulers, and every
worker process's, against the one-process render's): the cost of distributing, whatever else the machine
runs meanwhile.

The error: with ``--reference REF.exr`` (or ``--ref-spp N``: a reference of N spp and another seed rendered
on the largest cluster, cached under ``--out``) each configuration's RMSE against it, the mean over rounds. The
images of a round are equal bit for bit, so the RMSE is the same in every configuration and the time ratios
are ratios at equal error.

Prints the table and writes ``distributed_render.csv`` under ``--out`` (default ``results/bench``).

    .venv/bin/python bench/distributed_render.py [--spp 64] [--workers 1,2] [--rounds 3] [--ref-spp 1024]
    .venv/bin/python bench/distributed_render.py --scheduler tcp://HOST:8786 [--spp 1024]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from app.commands.render import demo_scene_path
from core.io import write_csv_rows
from core.scene import Scene, load_scene
from renderer.distributed import RenderCluster, connect, prepare_distributed
from renderer.image_io import image_errors, read_exr, write_exr
from renderer.render import prepare

WARM_SEED = 1234
"""The warm-up renders' seed (the timed ones use ``--seed`` and the following ones)."""
RETRIES = 3
"""Times a one-process render is tried when its process crashes."""
REF_SEED = 999_983
"""The seed of a reference rendered by ``--ref-spp`` (not one of the timed renders')."""


def make_reference(
    scene: Scene, args: argparse.Namespace, out: Path, clusters: dict[str, RenderCluster]
) -> np.ndarray:
    """A ``--ref-spp`` render of another seed (cached under ``out``), on the largest cluster."""
    path = out / f"distributed_reference_{args.width}x{args.height}_{args.ref_spp}spp_{REF_SEED}.exr"
    if path.is_file():
        print(f"reference: cached {path}", flush=True)
        return read_exr(path)
    t0 = time.perf_counter()
    if clusters:
        cluster = max(clusters.values(), key=lambda c: sum(c.threads().values()))
        job = prepare_distributed(cluster, scene, width=args.width, height=args.height, seed=REF_SEED)
    else:
        job = prepare(scene, width=args.width, height=args.height, seed=REF_SEED)
    try:
        image = job.run(spp=args.ref_spp).image
    finally:
        job.close()
    write_exr(path, image, {"spp": args.ref_spp, "seed": REF_SEED})
    print(f"reference: {args.ref_spp} spp in {time.perf_counter() - t0:.0f} s -> {path}", flush=True)
    return image


def cpu_seconds() -> float:
    """This process's CPU seconds (user and system, every thread)."""
    t = os.times()
    return t.user + t.system


def one_process(
    scene: Scene, args: argparse.Namespace, threads: int, seed: int
) -> tuple[float, np.ndarray, float]:
    """Wall seconds, image and CPU seconds of a one-process render."""
    t0, c0 = time.perf_counter(), cpu_seconds()
    job = prepare(scene, width=args.width, height=args.height, seed=seed, threads=threads)
    try:
        image = job.run(spp=args.spp if seed != WARM_SEED else 1).image
    finally:
        job.close()
    return time.perf_counter() - t0, image, cpu_seconds() - c0


def _one_process_in_child(
    scene_path: str, args: argparse.Namespace, threads: int, seed: int
) -> tuple[float, np.ndarray, float]:
    """:func:`one_process` in a process of the pool of its thread count (the scene read once there)."""
    scene = _SCENES.get(scene_path)
    if scene is None:
        scene = _SCENES[scene_path] = load_scene(scene_path)
    return one_process(scene, args, threads, seed)


_SCENES: dict[str, Scene] = {}


class OneProcess:
    """The one-process renders of one thread count, in a process of their own kept from round to round: the
    benchmark's own process hosts the Dask clients and local clusters, and one process renders with one
    thread count only (as a user's would)."""

    def __init__(self, scene_path: str, threads: int):
        self.scene_path, self.threads = scene_path, threads
        self.crashes = 0
        self.pool = self._start()

    @staticmethod
    def _start() -> Any:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        return ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))

    def render(self, args: argparse.Namespace, seed: int) -> tuple[float, np.ndarray, float]:
        """The render in the pool's process; a process that crashed is replaced, warmed and asked again
        (at most :data:`RETRIES` times; each crash is counted and printed)."""
        from concurrent.futures.process import BrokenProcessPool

        for _ in range(RETRIES):
            try:
                return self.pool.submit(
                    _one_process_in_child, self.scene_path, args, self.threads, seed
                ).result()
            except BrokenProcessPool:
                self.crashes += 1
                print(
                    f"one process, {self.threads} threads: the process crashed (seed {seed}); again",
                    flush=True,
                )
                self.pool.shutdown()
                self.pool = self._start()
                if seed != WARM_SEED:
                    self.render(args, WARM_SEED)
        raise RuntimeError(f"one process, {self.threads} threads: crashed {RETRIES} times in a row")

    def close(self) -> None:
        self.pool.shutdown()


def on_cluster(
    cluster: RenderCluster, scene: Scene, args: argparse.Namespace, seed: int
) -> tuple[float, np.ndarray, dict, float]:
    """Wall seconds, image, sidecar and CPU seconds (this process's, the local clusters' scheduler included,
    and every worker process's) of a render on ``cluster``."""
    workers0, c0 = cluster.client.run(cpu_seconds), cpu_seconds()
    t0 = time.perf_counter()
    job = prepare_distributed(cluster, scene, width=args.width, height=args.height, seed=seed)
    try:
        spp = args.spp if seed != WARM_SEED else job.batch * 8 * len(cluster.threads())
        image = job.run(spp=spp).image
    finally:
        job.close()
    wall = time.perf_counter() - t0
    workers1, c1 = cluster.client.run(cpu_seconds), cpu_seconds()
    cpu = c1 - c0 + sum(workers1[w] - workers0.get(w, 0.0) for w in workers1)
    return wall, image, job.info(), cpu


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", help="scene file (default: the bundled demo)")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    ap.add_argument("--width", type=int, help="image width (default: the scene's)")
    ap.add_argument("--height", type=int, help="image height (default: the scene's)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the timed renders (default 1)")
    ap.add_argument("--workers", default="1,2", help="local clusters' sizes (default 1,2)")
    ap.add_argument("--scheduler", metavar="ADDRESS", help="an existing cluster instead of local ones")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of every configuration (default 3)")
    ap.add_argument("--reference", metavar="REF.exr", help="an image to measure each render's RMSE against")
    ap.add_argument("--ref-spp", type=int, default=0, help="without --reference: render one of this many spp")
    ap.add_argument("--out", default="results/bench", help="output folder")
    args = ap.parse_args(argv)
    scene_path = args.scene or demo_scene_path()
    scene = load_scene(scene_path)
    args.width = args.width or scene.render.width
    args.height = args.height or scene.render.height
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    clusters: dict[str, RenderCluster] = {}
    local: dict[int, OneProcess] = {}
    started: dict[str, float] = {}
    sizes = [] if args.scheduler else [int(n) for n in args.workers.split(",") if n]
    try:
        for n in sizes:
            t0 = time.perf_counter()
            clusters[f"{n} local workers"] = connect(workers=n)
            started[f"{n} local workers"] = time.perf_counter() - t0
        if args.scheduler:
            clusters["scheduler"] = connect(args.scheduler)
        threads = {name: sum(c.threads().values()) for name, c in clusters.items()}
        one = sorted(set(threads.values()) | {1})
        configs = [f"one process, {t} threads" for t in one] + list(clusters)
        local.update({t: OneProcess(str(scene_path), t) for t in one})
        # warm-up: every configuration renders once (another seed) before any is timed
        for t in one:
            local[t].render(args, WARM_SEED)
        for c in clusters.values():
            c.warm((scene.render.sampler,))
            on_cluster(c, scene, args, WARM_SEED)
        reference = None
        if args.reference:
            reference = read_exr(args.reference)
        elif args.ref_spp > 0:
            reference = make_reference(scene, args, out, clusters)
        seconds: dict[str, list[float]] = {c: [] for c in configs}
        exact: dict[str, bool] = {c: True for c in configs}
        errors: dict[str, list[float]] = {c: [] for c in configs}
        infos: dict[str, list[dict]] = {c: [] for c in clusters}
        cpus: dict[str, list[float]] = {c: [] for c in configs}
        for r in range(args.rounds):
            seed = args.seed + r
            first: np.ndarray | None = None
            for config in configs:
                if config in clusters:
                    s, image, info, cpu = on_cluster(clusters[config], scene, args, seed)
                    infos[config].append(info)
                else:
                    s, image, cpu = local[int(config.split(", ")[1].split()[0])].render(args, seed)
                seconds[config].append(s)
                cpus[config].append(cpu)
                first = image if first is None else first
                exact[config] &= bool(np.array_equal(image, first))
                if reference is not None:
                    errors[config].append(image_errors(image, reference)["rmse"])
                print(f"round {r + 1} (seed {seed}): {config}: {s:.2f} s", flush=True)
    finally:
        for c in clusters.values():
            c.close()
        for p in local.values():
            p.close()

    base = statistics.median(seconds[next(iter(clusters))]) if clusters else None
    rows = []
    for config in configs:
        best, median = min(seconds[config]), statistics.median(seconds[config])
        t = threads.get(config, int(config.split(", ")[1].split()[0]) if config.startswith("one") else 1)
        equal = f"one process, {t} threads"
        row = {
            "configuration": config,
            "threads": t,
            "spp": args.spp,
            "size": f"{args.width}x{args.height}",
            "best_s": round(best, 3),
            "median_s": round(median, 3),
            "median_cpu_s": round(statistics.median(cpus[config]), 3),
            "cpu_overhead": round(statistics.median(cpus[config]) / statistics.median(cpus[equal]) - 1.0, 4)
            if config in clusters and equal in cpus
            else "",
            "rounds_s": " ".join(f"{s:.3f}" for s in seconds[config]),
            "scaling_vs_1_worker": round(median / base, 3) if base and config in clusters else "",
            "overhead": round(median / statistics.median(seconds[equal]) - 1.0, 4)
            if config in clusters and equal in seconds
            else "",
            "exact": exact[config],
            "crashes": local[t].crashes if config.startswith("one") and t in local else "",
            "rmse": round(statistics.fmean(errors[config]), 6) if errors[config] else "",
            "cluster_start_s": round(started.get(config, 0.0), 2) if config in started else "",
        }
        if infos.get(config):
            runs = infos[config]
            row["client_prepare_s"] = round(statistics.median(i["prepare"]["seconds"] for i in runs), 3)
            row["workers_prepare_s"] = round(
                statistics.median(i["prepare"]["workers_seconds"] for i in runs), 3
            )
            row["passes_s"] = round(statistics.median(i["render_seconds"] for i in runs), 3)
            row["blocks"] = runs[-1]["cluster"]["blocks"]
        rows.append(row)

    print(f"\n{scene.source} at {args.width}x{args.height}, {args.spp} spp, seeds {args.seed}-{args.seed + args.rounds - 1}; "
          f"best and median of {args.rounds} rounds, preparation included")  # fmt: skip
    print(
        f"{'configuration':<24}{'threads':>8}{'best s':>9}{'median s':>10}{'scaling':>9}{'overhead':>10}"
        f"{'CPU s':>8}{'CPU overhead':>14}{'exact':>7}{'RMSE':>11}"
    )
    for row in rows:
        scaling = f"{row['scaling_vs_1_worker']:.3f}" if row["scaling_vs_1_worker"] != "" else "-"
        overhead = f"{row['overhead']:+.1%}" if row["overhead"] != "" else "-"
        cpu_overhead = f"{row['cpu_overhead']:+.1%}" if row["cpu_overhead"] != "" else "-"
        rmse = f"{row['rmse']:.5f}" if row["rmse"] != "" else "-"
        print(f"{row['configuration']:<24}{row['threads']:>8}{row['best_s']:>9.2f}{row['median_s']:>10.2f}"
              f"{scaling:>9}{overhead:>10}{row['median_cpu_s']:>8.2f}{cpu_overhead:>14}"
              f"{'yes' if row['exact'] else 'NO':>7}{rmse:>11}")  # fmt: skip
    keys = list(dict.fromkeys(k for row in rows for k in row))
    write_csv_rows(out / "distributed_render.csv", [{k: row.get(k, "") for k in keys} for row in rows])
    print(f"wrote {out / 'distributed_render.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
