"""``brdf-studio render``: path-trace a scene file, one strategy or several side by side.

::

    brdf-studio render SCENE.json [--sampler S] [--spp N | --time SEC] -o OUT.exr
                       [--compare uniform,adaptive] [--reference REF.exr] [--seed K] [--width W --height H]
                       [--ris M] [--n-max X] [--max-depth D] [--exposure EV]
    brdf-studio render --demo

Writes ``OUT.exr`` (linear HDR), ``OUT.png`` (tone-mapped sRGB) and ``OUT.json`` (settings, time, spp, versions).
With ``--compare`` every strategy gets ``OUT_<strategy>.exr/.png/.json`` at the same budget, plus a labelled
side-by-side ``OUT_compare.png``. With ``--reference``, the RMSE and relMSE of each strategy are printed and
recorded after every pass, and written as error-vs-time curves ``OUT_error.csv`` and ``OUT_error.png``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from core.errors import ParameterError


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "render", help="path-trace a scene file (progressive; several strategies side by side)"
    )
    p.add_argument("scene", nargs="?", help="scene file (JSON)")
    p.add_argument("--demo", action="store_true", help="render the bundled demo scene")
    p.add_argument(
        "--sampler", help="BRDF sampling strategy (default: the scene's); see 'brdf-studio models'"
    )
    p.add_argument("--n-max", type=float, help="the adaptive sampler's n_max (its one knob)")
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--spp", type=int, help="samples per pixel (equal-spp mode)")
    budget.add_argument("--time", type=float, metavar="SEC", help="seconds of rendering (equal-time mode)")
    p.add_argument("-o", "--output", help="output EXR (default: <scene name>.exr in the current folder)")
    p.add_argument("--compare", metavar="S1,S2,...", help="render each strategy with the same budget")
    p.add_argument(
        "--reference", metavar="REF.exr", help="reference image: report RMSE/relMSE and error curves"
    )
    p.add_argument("--seed", type=int, help="random seed (same seed, same image)")
    p.add_argument("--width", type=int, help="image width in pixels (default: the scene's)")
    p.add_argument("--height", type=int, help="image height in pixels (default: the scene's)")
    p.add_argument("--max-depth", type=int, help="maximum number of bounces")
    p.add_argument(
        "--ris",
        type=int,
        default=0,
        metavar="M",
        help="light from the sky by RIS with M candidates (default off)",
    )
    p.add_argument("--exposure", type=float, default=0.0, help="PNG exposure in stops (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return ["render"]


def demo_scene_path() -> Path:
    from importlib.resources import files

    return Path(str(files("resources") / "scenes" / "demo" / "demo.json"))


def _strategies(args: argparse.Namespace, default: str) -> list[str]:
    from core.sampling import sampler_names

    names = (
        [s.strip() for s in args.compare.split(",") if s.strip()]
        if args.compare
        else [args.sampler or default]
    )
    known = sampler_names()
    for s in names:
        if s not in known:
            raise ParameterError(f"unknown sampler '{s}'; known samplers: {', '.join(known)}")
    if len(set(names)) != len(names):
        raise ParameterError("--compare lists a strategy twice")
    return names


def _output_stem(args: argparse.Namespace, scene_path: Path) -> Path:
    out = Path(args.output) if args.output else Path(scene_path.stem + ".exr")
    if out.suffix.lower() != ".exr":
        raise ParameterError(f"the output must be an .exr file, got '{out}'")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise ParameterError(f"cannot write '{out}': folder '{out.parent}' does not exist")
    return out.with_suffix("")


def run(args: argparse.Namespace) -> int:
    from core.scene import load_scene
    from renderer.image_io import composite, image_errors, read_exr, write_error_curves, write_exr, write_png
    from renderer.image_io import write_sidecar as write_json
    from renderer.render import prepare

    if args.demo == bool(args.scene):
        raise ParameterError("give a scene file or --demo (one of them)")
    scene_path = demo_scene_path() if args.demo else Path(args.scene)
    scene = load_scene(scene_path)
    if args.spp is not None and args.spp < 1:
        raise ParameterError(f"--spp must be at least 1, got {args.spp}")
    if args.time is not None and not args.time > 0:
        raise ParameterError(f"--time must be positive, got {args.time}")
    for name in ("width", "height", "max_depth"):
        v = getattr(args, name)
        if v is not None and v < 1:
            raise ParameterError(f"--{name.replace('_', '-')} must be at least 1, got {v}")
    if args.ris < 0:
        raise ParameterError(f"--ris must be 0 (off) or a positive number of candidates, got {args.ris}")
    if args.seed is not None and args.seed < 0:
        raise ParameterError(f"--seed must be non-negative, got {args.seed}")
    strategies = _strategies(args, scene.render.sampler)
    stem = _output_stem(args, scene_path)
    reference = read_exr(args.reference) if args.reference else None
    spp, time_s = args.spp, args.time
    if spp is None and time_s is None:
        spp, time_s = (None, scene.render.time_s) if scene.render.time_s else (scene.render.spp, None)
    options: dict[str, Any] = dict(scene.render.sampler_options)
    if args.n_max is not None:
        options["n_max"] = args.n_max

    from tqdm import tqdm

    images, curves, summary = [], {}, []
    for strategy in strategies:
        bar = tqdm(total=1, desc=f"{strategy}: compiling", unit="step", disable=args.quiet, file=sys.stderr)

        def on_step(what: str, k: int, n: int, bar=bar, strategy=strategy) -> None:
            bar.total = max(1, n)
            bar.n = k
            bar.set_description(f"{strategy}: prepare {what}")
            bar.refresh()

        job = prepare(
            scene,
            sampler=strategy,
            sampler_options=options,
            width=args.width,
            height=args.height,
            seed=args.seed,
            max_depth=args.max_depth,
            on_step=on_step,
            ris_candidates=args.ris,
        )
        bar.close()
        if reference is not None:
            h, w = reference.shape[:2]
            if (job.tracer.width, job.tracer.height) != (w, h):
                raise ParameterError(
                    f"the reference is {w}x{h} but the render is {job.tracer.width}x{job.tracer.height}; "
                    "use --width/--height"
                )
        total = spp if spp is not None else time_s
        unit = "spp" if spp is not None else "s"
        bar = tqdm(total=total, desc=f"{strategy}: render", unit=unit, disable=args.quiet, file=sys.stderr)
        records = []
        for frame in job.passes(spp=spp, time_s=time_s):
            bar.n = frame.spp if spp is not None else min(time_s or 0.0, round(frame.elapsed, 2))
            bar.set_postfix(spp=frame.spp, refresh=False)
            bar.refresh()
            if reference is not None:
                records.append(
                    {"spp": frame.spp, "seconds": frame.elapsed, **image_errors(frame.image, reference)}
                )
        bar.close()
        image = job.film.image()
        info = job.info()
        if reference is not None:
            info["errors"] = records[-1] if records else None
            curves[strategy] = records
        path = stem if len(strategies) == 1 else stem.with_name(f"{stem.name}_{strategy}")
        write_exr(path.with_suffix(".exr"), image, {"spp": job.film.spp, "sampler": strategy})
        write_png(path.with_suffix(".png"), image, args.exposure)
        write_json(path.with_suffix(".json"), info)
        images.append(image)
        summary.append((strategy, job, records[-1] if records else None, path.with_suffix(".exr")))
        job.world.accel.close()

    print(
        f"{'strategy':<14}{'spp':>6}{'seconds':>9}{'Mrays/s':>9}{'prepare s':>10}{'RMSE':>12}{'relMSE':>12}  output"
    )
    for strategy, job, err, out in summary:
        rps = job.tracer.stats.rays / job.elapsed / 1e6 if job.elapsed > 0 else 0.0
        rmse = f"{err['rmse']:.5g}" if err else "-"
        rel = f"{err['relmse']:.5g}" if err else "-"
        rep = job.prepare_report
        prep = rep["compile_seconds"] + rep["geometry_seconds"] + rep.get("warm_up_seconds", 0.0)
        print(
            f"{strategy:<14}{job.film.spp:>6}{job.elapsed:>9.2f}{rps:>9.2f}{prep:>10.2f}{rmse:>12}{rel:>12}  {out}"
        )
        for mname, minfo in job.prepare_report["materials"].items():
            if minfo.get("note"):
                print(f"    note: material '{mname}': {minfo['note']}")
            if minfo.get("memory_bytes"):
                print(
                    f"    tables: material '{mname}' ({minfo['model']}, {minfo['sampler']}): "
                    f"{minfo['memory_bytes'] / 1024:.1f} KB, built in {minfo.get('build_seconds', 0.0):.2f} s"
                )
    if len(strategies) > 1:
        labels = [f"{s} {j.film.spp}SPP {j.elapsed:.1f}S" for s, j, _, _ in summary]
        out = stem.with_name(f"{stem.name}_compare.png")
        write_png(out, composite(images, labels, args.exposure))
        print(f"side by side: {out}")
    if curves:
        csv_path, png_path = write_error_curves(
            stem.with_name(f"{stem.name}_error"), curves, title=scene.source
        )
        print(f"error vs time: {csv_path}, {png_path}")
    return 0
