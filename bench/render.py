"""Benchmark of the path tracer: throughput, and error against time for every sampling strategy.

1. Throughput on the bundled demo scene (two threads): seconds per spp and rays per second over whole passes
   (camera, bounce and shadow rays, shading included), against Embree alone on the very rays one pass traced
   (recorded, then traced again with the same queries), so the cost of everything but Embree is visible.
2. RMSE against a high-spp reference as a function of render time, for uniform, cosine, analytic, adaptive
   and every other registered strategy, at equal time (``--time`` seconds each, preparation excluded and
   reported separately). The reference is rendered once with a different seed (``--ref-spp``, analytic
   sampling; default 8192: ~9 minutes at 512x512 on two cores, once) and cached under ``--out``. Its own
   noise is in every RMSE measured against it; estimated from ``analytic``'s row (the estimator that
   rendered it), it is printed with each strategy's RMSE without it (``render_equal_time.csv``).

3. With ``--cornell``: Mitsuba 3's Cornell box (exported to our format, 256x256, paths of 8 segments) against
   Mitsuba itself, side by side in one run: RMSE against a high-spp Mitsuba reference (``llvm_ad_rgb``, cached)
   as a function of time, for us and for Mitsuba's ``llvm_ad_rgb`` (probed in a subprocess: it needs Debian's
   libllvm19) and ``scalar_rgb`` variants, the time each takes to reach a few RMSE levels (log-log interpolated
   between measurements), and our time over Mitsuba's. The scene's own sample generator is Mitsuba's
   ``independent``; since ours places pixel and light samples by Owen-scrambled Sobol points, Mitsuba llvm also
   runs with its low-discrepancy ``ldsampler`` and ``multijitter`` (``--mitsuba-samplers``), for a comparison of
   like with like, and the last row of ratios is ours over the fastest Mitsuba configuration at each level.

Prints a table; writes ``render_throughput.csv``, ``render_error.csv``/``.png`` (error vs time),
``render_compare.png`` (side by side), ``render_equal_time.csv`` (the equal-time table),
``cornell_error.csv``/``.png`` and ``cornell_throughput.csv`` (our whole passes on the Cornell box against
Embree alone on the same rays, ``2 --passes`` passes) under ``--out`` (default ``results/bench``).

    .venv/bin/python bench/render.py [--size 512] [--time 30] [--ref-spp 8192] [--strategies a,b] [--out DIR]
    .venv/bin/python bench/render.py --skip-strategies --throughput-samplers uniform,cosine,analytic,adaptive_warp
    .venv/bin/python bench/render.py --cornell [--cornell-size 256] [--time 30]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from app.commands.render import demo_scene_path
from core.sampling import sampler_names
from core.scene import load_scene
from renderer.image_io import composite, image_errors, read_exr, write_error_curves, write_exr, write_png
from renderer.render import prepare


def _record_rays(accel):  # type: ignore[no-untyped-def]
    """Wrap ``accel``'s queries so that every batch of rays the path tracer asks about is kept (inputs
    copied) for :func:`_embree_alone`; returns the list they go to."""
    batches: list[tuple] = []
    trace, occluded = accel.trace, accel.occluded

    def rec_trace(o32, d32, prim, t, u, v, **kw):  # type: ignore[no-untyped-def]
        batches.append(("trace", o32.copy(), d32.copy()))
        return trace(o32, d32, prim, t, u, v, **kw)

    def rec_occluded(o, d, t_max=None, **kw):  # type: ignore[no-untyped-def]
        batches.append(("occluded", o.copy(), d.copy(), None if t_max is None else t_max.copy()))
        return occluded(o, d, t_max, **kw)

    accel.trace, accel.occluded = rec_trace, rec_occluded
    return batches


def _embree_alone(accel, batches: list[tuple]) -> float:  # type: ignore[no-untyped-def]
    """Seconds Embree alone takes for the recorded batches (same queries), each batch in chunks over all the
    accelerator's threads (the path tracer may have traced them on one thread each, several at once)."""
    t0 = time.perf_counter()
    for b in batches:
        if b[0] == "trace":
            n = len(b[1])
            accel.trace(b[1], b[2], np.empty(n, np.int32), *(np.empty(n, np.float32) for _ in range(3)))
        else:
            accel.occluded(b[1], b[2], b[3])
    return time.perf_counter() - t0


def throughput(scene, size: int, passes: int, sampler: str = "cosine") -> dict:  # type: ignore[no-untyped-def]
    """Whole passes against Embree alone on the very rays those passes traced (camera, bounce and shadow
    rays), one after the other in one process."""
    job = prepare(scene, sampler=sampler, width=size, height=size)
    tracer, accel = job.tracer, job.world.accel
    spp = job.batch
    tracer.render_pass(10_000, spp)  # warm-up (first-call costs)
    rays0 = tracer.stats.rays
    t0 = time.perf_counter()
    for k in range(passes):
        tracer.render_pass(k, spp)
    seconds = time.perf_counter() - t0
    rays = tracer.stats.rays - rays0
    trace, occluded = accel.trace, accel.occluded
    batches = _record_rays(accel)
    tracer.render_pass(0, spp)
    accel.trace, accel.occluded = trace, occluded
    recorded = sum(len(b[1]) for b in batches)
    embree_s = min(_embree_alone(accel, batches) for _ in range(3))
    accel.close()
    pass_s = seconds / passes
    return {
        "size": size,
        "sampler": sampler,
        "passes": passes,
        "spp_per_pass": spp,
        "seconds": seconds,
        "rays": rays,
        "rays_recorded": recorded,
        "path_tracer_Mrays_s": rays / seconds / 1e6,
        "embree_alone_Mrays_s": recorded / embree_s / 1e6,
        "share_of_embree": (rays / seconds) / (recorded / embree_s),
        "seconds_per_spp": pass_s / spp,
    }


def seconds_per_spp(scene_path: str, size: int, sampler: str, passes: int) -> dict:
    """Seconds per spp of whole passes (preparation and one warm-up pass excluded), through the API every
    version of the renderer has (``prepare``, ``tracer.render_pass``): what ``--baseline`` runs in an older
    checkout."""
    job = prepare(load_scene(scene_path), sampler=sampler, width=size, height=size, seed=1)
    spp = max(1, int(getattr(job, "batch", 1)))
    job.tracer.render_pass(10_000, spp)
    t0 = time.perf_counter()
    for k in range(passes):
        job.tracer.render_pass(k, spp)
    seconds = time.perf_counter() - t0
    job.world.accel.close()
    return {"sampler": sampler, "seconds_per_spp": seconds / (passes * spp)}


def compare_seconds_per_spp(
    rev: str, scene_path: str, size: int, samplers: list[str], passes: int, rounds: int = 3
) -> dict[str, tuple[float, float]]:
    """:func:`seconds_per_spp` of every strategy here and in a checkout of git revision ``rev`` (a temporary
    worktree with its own numba cache folder), each in its own process, alternating A B A B for ``rounds``
    rounds so that both see the same machine; the fastest round of each: ``{sampler: (ours, rev's)}``."""
    import os
    import subprocess
    import tempfile

    root = Path(__file__).resolve().parent.parent
    out: dict[str, tuple[float, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "baseline"
        subprocess.run(["git", "-C", str(root), "worktree", "add", "--detach", str(tree), rev], check=True,
                       capture_output=True)  # fmt: skip
        try:
            cache = Path.home() / ".cache" / "brdf-studio" / f"numba-baseline-{rev}"
            envs = {
                "ours": (dict(os.environ, PYTHONPATH=str(root)), root),
                "base": (dict(os.environ, PYTHONPATH=str(tree), BRDF_STUDIO_NUMBA_CACHE=str(cache)), tree),
            }
            for s in samplers:
                times: dict[str, list[float]] = {"ours": [], "base": []}
                for _ in range(rounds):
                    for side, (env, cwd) in envs.items():
                        arg = json.dumps([scene_path, size, s, passes])
                        r = subprocess.run([sys.executable, __file__, "--measure-spp", arg], env=env, cwd=str(cwd),
                                           capture_output=True, text=True, check=False)  # fmt: skip
                        if r.returncode != 0:
                            print(f"{side} {s}: failed\n{r.stderr[-2000:]}", file=sys.stderr)
                            continue
                        times[side].append(json.loads(r.stdout.strip().splitlines()[-1])["seconds_per_spp"])
                if times["ours"] and times["base"]:
                    out[s] = (min(times["ours"]), min(times["base"]))
                    print(f"  {s}: {out[s][0]:.3f} s/spp against {out[s][1]:.3f} ({rev})", file=sys.stderr)
        finally:
            subprocess.run(["git", "-C", str(root), "worktree", "remove", "--force", str(tree)], check=False,
                           capture_output=True)  # fmt: skip
    return out


def reference(scene, size: int, spp: int, out: Path, seed: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    from core.scene import scene_digest  # here: --baseline runs this file against older sources, without it

    key = scene_digest(scene, size, spp, seed)[:10]  # a changed mesh, map or table invalidates the reference
    path = out / f"render_reference_{size}_{spp}spp_{key}.exr"
    if path.is_file():
        print(f"reference: cached {path}")
        return read_exr(path)
    job = prepare(scene, sampler="analytic", width=size, height=size, seed=seed)
    t0 = time.perf_counter()
    for frame in job.passes(spp=spp):
        if frame.spp % 16 == 0:
            print(f"  reference {frame.spp}/{spp} spp, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    write_exr(path, job.film.image(), {"spp": spp, "sampler": "analytic", "seed": seed})
    job.world.accel.close()
    print(f"reference: {spp} spp in {time.perf_counter() - t0:.0f} s -> {path}")
    return job.film.image()


def reference_mse(analytic_mse: float, analytic_spp: int, ref_spp: int) -> float:
    """The reference's own MSE, estimated from the equal-time row of the strategy that rendered it (an
    independent seed): that row's MSE is ``v / spp + v / ref_spp`` for the estimator's variance ``v`` of one
    sample per pixel, so the reference's share is ``v / ref_spp``. Every strategy's RMSE against the
    reference includes it; where it is a large part (the best strategies against a reference of a few
    thousand spp) it hides their differences."""
    return analytic_mse / (ref_spp / analytic_spp + 1.0)


def _llvm_works() -> bool:
    import subprocess

    code = (
        "import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); d = mi.cornell_box(); "
        "d['sensor']['film'].update(width=8, height=8); mi.render(mi.load_dict(d), spp=1)"
    )
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=300)
    except subprocess.TimeoutExpired:
        return False
    return r.returncode == 0


def _time_to(records: list[dict], level: float) -> float | None:
    """Seconds to reach RMSE ``level``: interpolated (log-log) between the last record above it and the
    first at or below it; ``None`` if never reached."""
    prev = None
    for r in records:
        if r["rmse"] <= level:
            if prev is None or prev["rmse"] <= r["rmse"] or prev["seconds"] <= 0:
                return r["seconds"]
            x = (np.log(prev["rmse"]) - np.log(level)) / (np.log(prev["rmse"]) - np.log(r["rmse"]))
            return float(
                np.exp(np.log(prev["seconds"]) + x * (np.log(r["seconds"]) - np.log(prev["seconds"])))
            )
        prev = r
    return None


def _mitsuba_spp(sampler: str | None, spp: int) -> int:
    """The samples per pixel Mitsuba renders when asked for ``spp``: its ``ldsampler`` rounds up to a square
    power of two (4, 16, 64, ...), the other samplers take the count as asked."""
    if sampler != "ldsampler":
        return spp
    k = 4
    while k < spp:
        k *= 4
    return k


BEST_MITSUBA = "best mitsuba"
"""The row of :func:`ratio_rows` against the fastest Mitsuba configuration at each RMSE level."""


def ratio_rows(curves: dict[str, list[dict]], ours: str, levels: Sequence[float]) -> list[dict]:
    """Our seconds to each RMSE level over each Mitsuba configuration's (the curves named ``mitsuba ...``),
    then over the fastest of them at that level (``against`` = :data:`BEST_MITSUBA`; a level no
    configuration reached is ``None``). Below 1 we are ahead."""
    mitsuba = {n.removeprefix("mitsuba "): recs for n, recs in curves.items() if n.startswith("mitsuba ")}
    rows = []
    for variant, recs in [*mitsuba.items(), (BEST_MITSUBA, None)]:
        ratios = []
        for lv in levels:
            a = _time_to(curves[ours], lv)
            if recs is None:
                reached = [t for r in mitsuba.values() if (t := _time_to(r, lv)) is not None]
                b = min(reached) if reached else None
            else:
                b = _time_to(recs, lv)
            ratios.append(a / b if a is not None and b is not None else None)
        rows.append(
            {"against": variant, **{f"ratio_{lv:g}": r for lv, r in zip(levels, ratios, strict=True)}}
        )
    return rows


def cornell(args: argparse.Namespace, out: Path) -> int:
    """Mitsuba 3's own Cornell box, rendered by us and by Mitsuba (``llvm_ad_rgb`` when it works, and
    ``scalar_rgb``) in one run against one high-spp Mitsuba reference; seconds to reach each RMSE level and
    our time over Mitsuba's."""
    import tempfile

    import mitsuba as mi

    from renderer.mitsuba_scene import cornell_dict, export_cornell_box

    size, bounces = args.cornell_size, args.cornell_bounces
    llvm = _llvm_works()
    ref_variant = "llvm_ad_rgb" if llvm else "scalar_rgb"
    ref_path = out / f"cornell_reference_{size}_{bounces}b_{args.cornell_ref_spp}spp.exr"
    if ref_path.is_file():
        ref = read_exr(ref_path)
    else:
        t0 = time.perf_counter()
        ref = np.array(
            mi.render(
                mi.load_dict(cornell_dict(size, bounces, ref_variant)), spp=args.cornell_ref_spp, seed=99
            ),
            dtype=np.float64,
        )
        write_exr(
            ref_path,
            ref.astype(np.float32),
            {"spp": args.cornell_ref_spp, "renderer": f"mitsuba {ref_variant}"},
        )
        print(
            f"reference (Mitsuba {ref_variant}, {args.cornell_ref_spp} spp): {time.perf_counter() - t0:.0f} s"
        )
    curves: dict[str, list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        scene_path = export_cornell_box(Path(tmp), size, bounces)
        job = prepare(load_scene(scene_path), sampler="cosine", seed=1)
        ours = "brdf-studio (cosine)"
        curves[ours] = [
            {"spp": f.spp, "seconds": f.elapsed, **image_errors(f.image, ref)}
            for f in job.passes(time_s=args.time)
        ]
        job.world.accel.close()
        # our whole passes against Embree alone on the same rays, on this scene (the yardstick)
        tp = throughput(load_scene(scene_path), size, args.passes * 2)
    print(
        f"brdf-studio whole passes on the Cornell box: {tp['path_tracer_Mrays_s']:.2f} M rays/s against Embree "
        f"alone {tp['embree_alone_Mrays_s']:.2f} on the same rays: share {tp['share_of_embree']:.2f} "
        f"({tp['seconds_per_spp']:.3f} s per spp)"
    )
    with open(out / "cornell_throughput.csv", "w") as fh:
        fh.write(",".join(tp) + "\n" + ",".join(format(v, ".6g") if isinstance(v, float) else str(v)
                                                 for v in tp.values()) + "\n")  # fmt: skip
    variants = (["llvm_ad_rgb"] if llvm else []) + ([] if args.skip_scalar else ["scalar_rgb"])
    if not llvm:
        print("Mitsuba llvm_ad_rgb: unavailable here (needs Debian's libllvm19)")
    runs = [(v, None) for v in variants] + [("llvm_ad_rgb", smp) for smp in args.mitsuba_samplers if llvm]
    for variant, smp in runs:
        recs = []
        mscene = mi.load_dict(cornell_dict(size, bounces, variant, smp))
        mi.render(mscene, spp=1, seed=0)  # warm-up (llvm: kernel compilation)
        spp = 1
        while True:
            if recs and recs[-1]["spp"] == _mitsuba_spp(smp, spp):  # ldsampler renders this count already
                spp *= 2
                continue
            # each spp count timed twice, the faster kept: a new count may cost Dr.Jit a kernel compile,
            # which a user rendering many images pays once (our kernels are compiled at setup)
            times = []
            for seed in (1, 2):
                t0 = time.perf_counter()
                img = np.array(mi.render(mscene, spp=spp, seed=seed), dtype=np.float64)
                times.append(time.perf_counter() - t0)
            el = min(times)
            recs.append({"spp": _mitsuba_spp(smp, spp), "seconds": el, **image_errors(img, ref)})
            if el > args.time or spp >= 8192:
                break
            spp *= 2
        curves[f"mitsuba {variant}" + (f" {smp}" if smp else "")] = recs
    levels = (0.05, 0.03, 0.02, 0.015, 0.01)
    print(
        f"\nCornell box {size}x{size}, {bounces + 1} segments: seconds to reach an RMSE against the reference"
    )
    print(
        f"{'renderer':<32}"
        + "".join(f"{'RMSE ' + format(lv, 'g'):>12}" for lv in levels)
        + f"{'best RMSE':>12}"
    )
    for name, recs in curves.items():
        cells = "".join(
            f"{(format(t, '.2f') if (t := _time_to(recs, lv)) is not None else '-'):>12}" for lv in levels
        )
        print(f"{name:<32}{cells}{min(r['rmse'] for r in recs):>12.4g}")
    rows = ratio_rows(curves, ours, levels)
    for r in rows:
        print(
            f"{'ours / ' + r['against']:<32}"
            + "".join(
                f"{(format(x, '.2f') if x else '-'):>12}" for x in (r[f"ratio_{lv:g}"] for lv in levels)
            )
        )
    write_error_curves(out / "cornell_error", curves, title=f"Cornell box {size}x{size}")
    with open(out / "cornell_ratio.csv", "w") as fh:
        fh.write("against," + ",".join(f"ratio_{lv:g}" for lv in levels) + "\n")
        for r in rows:
            fh.write(
                r["against"]
                + ","
                + ",".join("" if r[f"ratio_{lv:g}"] is None else f"{r[f'ratio_{lv:g}']:.4g}" for lv in levels)
                + "\n"
            )
    print(f"wrote {out / 'cornell_error.csv'}, {out / 'cornell_error.png'}, {out / 'cornell_ratio.csv'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", help="scene file (default: the bundled demo)")
    ap.add_argument("--size", type=int, default=512, help="image width and height (default 512)")
    ap.add_argument("--time", type=float, default=30.0, help="seconds of rendering per strategy (default 30)")
    ap.add_argument(
        "--ref-spp", type=int, default=8192, help="samples per pixel of the reference (default 8192)"
    )
    ap.add_argument("--strategies", help="comma-separated (default: every registered strategy)")
    ap.add_argument("--passes", type=int, default=4, help="passes for the throughput measurement")
    ap.add_argument(
        "--sampler-options",
        action="append",
        default=[],
        metavar="S:k=v,...",
        help="options for one strategy, e.g. adaptive:theta_step=5,phi_bins=8 (repeatable)",
    )
    ap.add_argument("--skip-throughput", action="store_true")
    ap.add_argument("--skip-strategies", action="store_true", help="only the throughput table")
    ap.add_argument(
        "--baseline",
        metavar="GIT_REV",
        help="also time every throughput strategy in a checkout of GIT_REV, side by side (seconds per spp)",
    )
    ap.add_argument("--rounds", type=int, default=3, help="A B rounds of --baseline (the fastest is kept)")
    ap.add_argument(
        "--seed", type=int, default=1, help="seed of the strategies' equal-time renders (default 1)"
    )
    ap.add_argument("--measure-spp", help=argparse.SUPPRESS)
    ap.add_argument(
        "--material-sampler",
        action="append",
        default=[],
        metavar="S:MATERIAL=S2",
        help="under strategy S, sample MATERIAL with S2 instead (repeatable), e.g. 'adaptive:brushed steel=analytic'",
    )
    ap.add_argument("--out", default="results/bench", help="output folder")
    ap.add_argument("--cornell", action="store_true", help="only the Cornell box comparison with Mitsuba 3")
    ap.add_argument("--cornell-size", type=int, default=256)
    ap.add_argument("--cornell-bounces", type=int, default=7, help="bounces (default 7: paths of 8 segments)")
    ap.add_argument("--cornell-ref-spp", type=int, default=8192)
    ap.add_argument("--skip-scalar", action="store_true", help="Cornell box: leave out Mitsuba's scalar_rgb")
    ap.add_argument(
        "--mitsuba-samplers",
        type=lambda v: [x for x in v.split(",") if x],
        default=["ldsampler", "multijitter"],
        help="Cornell box: also Mitsuba llvm with these sample generators (default ldsampler,multijitter; "
        "'' for none); the ratios end with ours over the fastest Mitsuba at each level",
    )
    ap.add_argument(
        "--throughput-samplers", default="cosine", help="comma-separated strategies for the throughput table"
    )
    args = ap.parse_args(argv)
    if args.measure_spp:  # the subprocess of --baseline (imports whichever checkout PYTHONPATH names)
        print(json.dumps(seconds_per_spp(*json.loads(args.measure_spp))))
        return 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.cornell:
        return cornell(args, out)
    scene = load_scene(args.scene or demo_scene_path())

    per_strategy: dict[str, dict] = {}
    for item in args.sampler_options:
        name, _, kv = item.partition(":")
        opts = per_strategy.setdefault(name, {})
        for pair in filter(None, kv.split(",")):
            k, _, v = pair.partition("=")
            try:
                opts[k] = int(v) if v.lstrip("-").isdigit() else float(v)
            except ValueError:
                opts[k] = v
    overrides: dict[str, dict[str, str]] = {}
    for item in args.material_sampler:
        strategy, _, rest = item.partition(":")
        mname, _, s2 = rest.rpartition("=")
        overrides.setdefault(strategy, {})[mname] = s2
    if not args.skip_throughput:
        report_throughput(scene, args, out)
    if not args.skip_strategies:
        run_strategies(scene, args, out, per_strategy, overrides)
    return 0


def report_throughput(scene, args: argparse.Namespace, out: Path) -> None:  # type: ignore[no-untyped-def]
    samplers = args.throughput_samplers.split(",")
    rows = [throughput(scene, args.size, args.passes, s) for s in samplers]
    print(f"throughput at {args.size}x{args.size} (whole passes against Embree alone on the same rays)")
    print(f"{'strategy':<14}{'s per spp':>10}{'M rays/s':>10}{'Embree alone':>14}{'share':>8}")
    for tp in rows:
        print(
            f"{tp['sampler']:<14}{tp['seconds_per_spp']:>10.3f}{tp['path_tracer_Mrays_s']:>10.2f}"
            f"{tp['embree_alone_Mrays_s']:>14.2f}{tp['share_of_embree']:>8.2f}"
        )
    if args.baseline:
        path = str(Path(args.scene or demo_scene_path()).resolve())
        pairs = compare_seconds_per_spp(args.baseline, path, args.size, samplers, args.passes, args.rounds)
        print(
            f"\nseconds per spp at {args.size}x{args.size}, each side in its own process, A B A B x {args.rounds}"
        )
        print(f"{'strategy':<14}{'here':>10}{args.baseline[:10]:>12}{'speed-up':>10}")
        for tp in rows:
            if tp["sampler"] in pairs:
                here, base = pairs[tp["sampler"]]
                tp.update(here_seconds_per_spp=here, baseline_seconds_per_spp=base, speed_up=base / here)
                print(f"{tp['sampler']:<14}{here:>10.3f}{base:>12.3f}{base / here:>10.2f}")
    keys = list(dict.fromkeys(k for tp in rows for k in tp))
    with open(out / "render_throughput.csv", "w") as fh:
        fh.write(",".join(keys) + "\n")
        for tp in rows:
            fh.write(",".join(_cell(tp.get(k, "")) for k in keys) + "\n")


def _cell(v) -> str:  # type: ignore[no-untyped-def]
    return v if isinstance(v, str) else f"{v:.6g}"


def run_strategies(  # type: ignore[no-untyped-def]
    scene,
    args: argparse.Namespace,
    out: Path,
    per_strategy: dict[str, dict],
    overrides: dict[str, dict[str, str]],
) -> None:
    ref = reference(scene, args.size, args.ref_spp, out, seed=987_654)
    strategies = args.strategies.split(",") if args.strategies else sampler_names()
    curves, images, labels, rows = {}, [], [], []
    tables: dict[str, dict] = {}
    for s in strategies:
        t0 = time.perf_counter()
        options = {**scene.render.sampler_options, **per_strategy.get(s, {})}
        job = prepare(
            scene,
            sampler=s,
            sampler_options=options,
            width=args.size,
            height=args.size,
            seed=args.seed,
            material_samplers=overrides.get(s),
            warm_up_sweep=True,  # every table built before the clock starts: equal time means equal rendering
        )
        prep = time.perf_counter() - t0
        recs = []
        for frame in job.passes(time_s=args.time):
            recs.append({"spp": frame.spp, "seconds": frame.elapsed, **image_errors(frame.image, ref)})
        curves[s] = recs
        img = job.film.image()
        images.append(img)
        labels.append(f"{s} {job.film.spp}spp")
        mem = sum(m.get("memory_bytes", 0) or 0 for m in job.prepare_report["materials"].values())
        tables[s] = job.prepare_report["materials"]
        notes = [m["note"] for m in job.prepare_report["materials"].values() if m.get("note")]
        rows.append(
            (s, job.film.spp, job.elapsed, prep, mem, recs[-1]["rmse"], recs[-1]["relmse"], len(notes))
        )
        job.world.accel.close()
        print(
            f"  {s}: {job.film.spp} spp in {job.elapsed:.1f} s, RMSE {recs[-1]['rmse']:.4g}", file=sys.stderr
        )

    base = {r[0]: r[5] for r in rows}.get("uniform")
    print(f"\nequal time ({args.time:g} s of rendering each) on {scene.source} at {args.size}x{args.size}")
    print(f"{'strategy':<14}{'spp':>6}{'render s':>10}{'prepare s':>10}{'tables KB':>10}{'RMSE':>11}{'relMSE':>11}"
          f"{'RMSE/unif':>10}  fallbacks")  # fmt: skip
    for s, spp, el, prep, mem, rmse, rel, nf in rows:
        ratio = f"{rmse / base:.3f}" if base else "-"
        print(
            f"{s:<14}{spp:>6}{el:>10.1f}{prep:>10.1f}{mem / 1024:>10.1f}{rmse:>11.4g}{rel:>11.4g}{ratio:>10}  {nf}"
        )
    analytic = next((r for r in rows if r[0] == "analytic"), None)
    ref_mse = reference_mse(analytic[5] ** 2, analytic[1], args.ref_spp) if analytic else None
    table = []
    for s, spp, _, _, _, rmse, _, _ in rows:
        own = math.sqrt(max(rmse**2 - ref_mse, 0.0)) if ref_mse is not None else float("nan")
        table.append({"strategy": s, "spp": spp, "rmse": rmse, "rmse_over_uniform": rmse / base if base else "",
                      "reference_rmse_estimate": math.sqrt(ref_mse) if ref_mse is not None else "",
                      "rmse_without_reference": own})  # fmt: skip
    if ref_mse is not None:
        own_base = next((r["rmse_without_reference"] for r in table if r["strategy"] == "uniform"), None)
        print(f"the reference's own RMSE, from analytic's row (the same estimator at {args.ref_spp} spp): "
              f"{math.sqrt(ref_mse):.3g}; every RMSE above includes it. Without it:")  # fmt: skip
        for r in table:
            ratio = f"{r['rmse_without_reference'] / own_base:.3f}" if own_base else "-"
            print(f"  {r['strategy']:<14}{r['rmse_without_reference']:>11.4g}{ratio:>10}")
    with open(out / "render_equal_time.csv", "w") as fh:
        fh.write(",".join(table[0]) + "\n")
        for r in table:
            fh.write(",".join(_cell(v) for v in r.values()) + "\n")
    write_error_curves(out / "render_error", curves, title=f"{scene.source} {args.size}x{args.size}")
    write_png(out / "render_compare.png", composite(images, labels))
    for s, opts in per_strategy.items():
        print(f"options of {s}: {opts}")
    for s, ov in overrides.items():
        print(f"under {s}: " + ", ".join(f"'{m}' sampled with {s2}" for m, s2 in ov.items()))
    for s, mats in tables.items():
        for name, info in mats.items():
            if info.get("memory_bytes"):
                extra = f", trees {info['trees']}" if "trees" in info else ""
                print(
                    f"  {s} tables for '{name}' ({info.get('model')}): {info['memory_bytes'] / 1024:.0f} KB, "
                    f"build {info.get('build_seconds', 0.0):.1f} s{extra}"
                )
    print(f"wrote {out / 'render_error.csv'}, {out / 'render_error.png'}, {out / 'render_compare.png'}")


if __name__ == "__main__":
    sys.exit(main())
