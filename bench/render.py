"""Benchmark of the path tracer: throughput, and error against time for every sampling strategy.

1. Throughput on the bundled demo scene (2 worker threads for Embree, numba kernels): rays per second over
   whole passes (camera, bounce and shadow rays, shading included), and Embree alone on the same rays
   (closest-hit queries of camera rays), so the cost of shading is visible.
2. RMSE against a high-spp reference as a function of render time, for uniform, cosine, analytic, adaptive
   and every other registered strategy, at equal time (``--time`` seconds each, preparation excluded and
   reported separately). The reference is rendered once with a different seed (``--ref-spp``, analytic
   sampling) and cached under ``--out``.

3. With ``--cornell``: Mitsuba 3's Cornell box (exported to our format) against Mitsuba itself: RMSE against a
   high-spp Mitsuba ``scalar_rgb`` reference as a function of time, for us and for Mitsuba's ``scalar_rgb`` and
   ``llvm_ad_rgb`` variants (the llvm variant is probed in a subprocess: it needs Debian's libllvm19), and the
   time each takes to reach a few RMSE levels.

Prints a table; writes ``render_throughput.csv``, ``render_error.csv``/``.png`` (error vs time),
``render_compare.png`` (side by side), ``cornell_error.csv``/``.png`` under ``--out`` (default ``results/bench``).

    .venv/bin/python bench/render.py [--size 512] [--time 30] [--ref-spp 256] [--strategies a,b] [--out DIR]
    .venv/bin/python bench/render.py --cornell [--cornell-size 128] [--time 30]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from app.commands.render import demo_scene_path
from core.sampling import sampler_names
from core.scene import load_scene
from renderer.image_io import composite, image_errors, read_exr, write_error_curves, write_exr, write_png
from renderer.render import prepare


def throughput(scene, size: int, passes: int) -> dict:  # type: ignore[no-untyped-def]
    job = prepare(scene, sampler="cosine", width=size, height=size)
    job.tracer.render_pass(10_000, 1)  # warm-up (first-call costs)
    rays0 = job.tracer.stats.rays
    t0 = time.perf_counter()
    for k in range(passes):
        job.tracer.render_pass(k, 1)
    seconds = time.perf_counter() - t0
    rays = job.tracer.stats.rays - rays0
    cam = job.tracer.camera
    pix = np.arange(size * size)
    o, d = cam.rays(pix, np.random.default_rng(0).random((len(pix), 2)))
    t1 = time.perf_counter()
    for _ in range(5):
        job.world.accel.intersect(o, d)
    embree_s = (time.perf_counter() - t1) / 5
    one = job.world.accel
    one.threads, pool = 1, one._pool
    one._pool = None
    t2 = time.perf_counter()
    one.intersect(o, d)
    embree_1t = time.perf_counter() - t2
    one._pool, one.threads = pool, 2
    job.world.accel.close()
    return {
        "size": size,
        "passes": passes,
        "seconds": seconds,
        "rays": rays,
        "path_tracer_Mrays_s": rays / seconds / 1e6,
        "embree_2threads_Mrays_s": len(o) / embree_s / 1e6,
        "embree_1thread_Mrays_s": len(o) / embree_1t / 1e6,
        "seconds_per_spp": seconds / passes,
    }


def reference(scene, size: int, spp: int, out: Path, seed: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    h = hashlib.sha1(json.dumps([scene.model_dump(mode="json"), size, spp, seed], sort_keys=True).encode())
    files = [m.path for m in scene.meshes] + [m.measured for m in scene.materials if m.measured]
    if scene.environment is not None and getattr(scene.environment, "path", None):
        files.append(scene.environment.path)
    for rel in sorted(set(files)):  # a changed mesh, map or table invalidates the cached reference
        h.update(scene.resolve(rel).read_bytes())
    key = h.hexdigest()[:10]
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
    for r in records:
        if r["rmse"] <= level:
            return r["seconds"]
    return None


def cornell(args: argparse.Namespace, out: Path) -> int:
    import tempfile

    import mitsuba as mi

    from renderer.mitsuba_scene import cornell_dict, export_cornell_box

    size, bounces = args.cornell_size, 6
    ref_path = out / f"cornell_reference_{size}_{args.cornell_ref_spp}spp.exr"
    if ref_path.is_file():
        ref = read_exr(ref_path)
    else:
        t0 = time.perf_counter()
        ref = np.array(
            mi.render(mi.load_dict(cornell_dict(size, bounces)), spp=args.cornell_ref_spp, seed=99)
        )
        write_exr(
            ref_path, ref.astype(np.float32), {"spp": args.cornell_ref_spp, "renderer": "mitsuba scalar_rgb"}
        )
        print(f"reference (Mitsuba scalar_rgb, {args.cornell_ref_spp} spp): {time.perf_counter() - t0:.0f} s")
    curves: dict[str, list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        job = prepare(load_scene(export_cornell_box(Path(tmp), size, bounces)), sampler="cosine", seed=1)
        curves["brdf-studio (cosine)"] = [
            {"spp": f.spp, "seconds": f.elapsed, **image_errors(f.image, ref)}
            for f in job.passes(time_s=args.time)
        ]
        job.world.accel.close()
    variants = ["scalar_rgb"] + (["llvm_ad_rgb"] if _llvm_works() else [])
    if "llvm_ad_rgb" not in variants:
        print(
            "Mitsuba llvm_ad_rgb: unavailable here (needs Debian's libllvm19); compared with scalar_rgb only"
        )
    for variant in variants:
        recs = []
        mscene = mi.load_dict(cornell_dict(size, bounces, variant))
        mi.render(mscene, spp=1, seed=0)  # warm-up (llvm: kernel compilation)
        spp = 1
        while True:
            t0 = time.perf_counter()
            img = np.array(mi.render(mscene, spp=spp, seed=1), dtype=np.float64)
            el = time.perf_counter() - t0
            recs.append({"spp": spp, "seconds": el, **image_errors(img, ref)})
            if el > args.time or spp >= 4096:
                break
            spp *= 2
        curves[f"mitsuba {variant}"] = recs
    levels = (0.05, 0.03, 0.02, 0.01)
    print(f"\nCornell box {size}x{size}, {bounces} bounces: seconds to reach an RMSE against the reference")
    print(
        f"{'renderer':<24}"
        + "".join(f"{'RMSE ' + format(lv, 'g'):>12}" for lv in levels)
        + f"{'best RMSE':>12}"
    )
    for name, recs in curves.items():
        cells = "".join(
            f"{(format(t, '.2f') if (t := _time_to(recs, lv)) is not None else '-'):>12}" for lv in levels
        )
        print(f"{name:<24}{cells}{min(r['rmse'] for r in recs):>12.4g}")
    write_error_curves(out / "cornell_error", curves, title=f"Cornell box {size}x{size}")
    print(f"wrote {out / 'cornell_error.csv'}, {out / 'cornell_error.png'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", help="scene file (default: the bundled demo)")
    ap.add_argument("--size", type=int, default=512, help="image width and height (default 512)")
    ap.add_argument("--time", type=float, default=30.0, help="seconds of rendering per strategy (default 30)")
    ap.add_argument(
        "--ref-spp", type=int, default=256, help="samples per pixel of the reference (default 256)"
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
    ap.add_argument(
        "--material-sampler",
        action="append",
        default=[],
        metavar="S:MATERIAL=S2",
        help="under strategy S, sample MATERIAL with S2 instead (repeatable), e.g. 'adaptive:brushed steel=analytic'",
    )
    ap.add_argument("--out", default="results/bench", help="output folder")
    ap.add_argument("--cornell", action="store_true", help="only the Cornell box comparison with Mitsuba 3")
    ap.add_argument("--cornell-size", type=int, default=128)
    ap.add_argument("--cornell-ref-spp", type=int, default=2048)
    args = ap.parse_args(argv)
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
    run_strategies(scene, args, out, per_strategy, overrides)
    return 0


def report_throughput(scene, args: argparse.Namespace, out: Path) -> None:  # type: ignore[no-untyped-def]
    tp = throughput(scene, args.size, args.passes)
    print(
        f"throughput at {args.size}x{args.size}: path tracer {tp['path_tracer_Mrays_s']:.2f} M rays/s "
        f"({tp['seconds_per_spp']:.2f} s per spp); Embree alone {tp['embree_2threads_Mrays_s']:.1f} M rays/s "
        f"on 2 threads, {tp['embree_1thread_Mrays_s']:.1f} on 1"
    )
    (out / "render_throughput.csv").write_text(
        ",".join(tp) + "\n" + ",".join(f"{v:.6g}" for v in tp.values()) + "\n"
    )


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
            seed=1,
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
