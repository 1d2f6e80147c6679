"""Where a pass of the path tracer spends its time: CPU seconds per stage of a demo-scene pass.

Each strategy's scene is prepared with one thread (``threads=1``: the stages and Embree run on the calling
thread, so the process CPU time of a call is that stage's own; other jobs on the machine still inflate it
through shared caches and memory, so quote the load average printed with the table), one warm-up
pass is rendered, then ``--passes`` passes with every stage of the wavefront timed (camera, Embree closest
hits, hits, material sort, surface + light sample, the compiled BRDF stage, the samplers with tables,
continuation with the packing of the next rays, Embree shadow rays, shadows) plus what is left (the pass's
own numpy: the sum of its paths per pixel, and Python). Prints a table in milliseconds of CPU per pass and
per cent; writes ``render_stages.csv`` under ``--out``.

    .venv/bin/python bench/render_stages.py [--size 512] [--passes 3] [--samplers cosine,adaptive_warp]
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

from app.commands.render import demo_scene_path
from core.scene import load_scene
from renderer import integrator
from renderer.render import prepare

STAGES = (
    "camera_stage",
    "embree closest hits",
    "hit_stage",
    "sort_by_material",
    "surface_stage",
    "bsdf_stage",
    "samplers with tables",
    "continue_stage",
    "embree shadow rays",
    "shadow_stage",
)


def profile(scene_path: str, sampler: str, size: int, passes: int) -> dict[str, float]:
    """CPU seconds per pass of every stage (and ``"total"``, ``"rest"``) for one strategy."""
    job = prepare(load_scene(scene_path), sampler=sampler, width=size, height=size, seed=1, threads=1)
    tracer, accel = job.tracer, job.world.accel
    tracer.render_pass(10_000, job.batch)  # warm-up
    spent: dict[str, float] = dict.fromkeys(STAGES, 0.0)

    def timed(name: str, fn):  # type: ignore[no-untyped-def]
        def run(*a, **k):  # type: ignore[no-untyped-def]
            t0 = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                spent[name] += time.process_time() - t0

        return run

    run_stage = tracer._run

    def run(stage, n, *args):  # type: ignore[no-untyped-def]
        t0 = time.process_time()
        try:
            return run_stage(stage, n, *args)
        finally:
            spent[stage.__name__] = spent.get(stage.__name__, 0.0) + time.process_time() - t0

    tracer._run = run  # type: ignore[method-assign]
    tracer._draw_by_samplers = timed("samplers with tables", tracer._draw_by_samplers)  # type: ignore[method-assign]
    sort = integrator.sort_by_material
    integrator.sort_by_material = timed("sort_by_material", sort)
    accel.trace = timed("embree closest hits", accel.trace)
    accel.occluded = timed("embree shadow rays", accel.occluded)
    try:
        t0 = time.process_time()
        for k in range(passes):
            tracer.render_pass(k, job.batch)
        total = time.process_time() - t0
    finally:
        integrator.sort_by_material = sort
        accel.close()
    out = {k: v / passes for k, v in spent.items()}
    out["total"] = total / passes
    out["rest"] = out["total"] - sum(v for k, v in out.items() if k != "total")
    out["spp"] = job.batch
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=None, help="scene file (default: the bundled demo)")
    ap.add_argument("--size", type=int, default=512, help="image width and height (default 512)")
    ap.add_argument("--passes", type=int, default=3, help="timed passes per strategy (default 3)")
    ap.add_argument("--samplers", default="cosine,adaptive_warp", help="strategies, comma-separated")
    ap.add_argument("--out", default="results/bench", help="folder for render_stages.csv")
    args = ap.parse_args(argv)
    if args.size < 1 or args.passes < 1:
        print("error: --size and --passes must be at least 1", file=sys.stderr)
        return 2
    scene_path = args.scene or str(demo_scene_path())
    samplers = [s for s in args.samplers.split(",") if s]
    rows = {s: profile(scene_path, s, args.size, args.passes) for s in samplers}
    print(f"CPU ms per pass ({args.size}x{args.size}, one thread, load average {os.getloadavg()[0]:.1f})")
    print(f"{'stage':<24}" + "".join(f"{s:>22}" for s in samplers))
    for stage in (*STAGES, "rest", "total"):
        cells = []
        for s in samplers:
            v, tot = rows[s].get(stage, 0.0), rows[s]["total"]
            cells.append(f"{v * 1e3:10.1f} ({100 * v / tot:4.1f} %)")
        print(f"{stage:<24}" + "".join(f"{c:>22}" for c in cells))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "render_stages.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["sampler", "stage", "cpu_ms_per_pass"])
        for s in samplers:
            for stage in (*STAGES, "rest", "total"):
                w.writerow([s, stage, round(rows[s].get(stage, 0.0) * 1e3, 3)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
