"""``brdf-studio render``: path-trace a scene file, one strategy or several side by side.

::

    brdf-studio render SCENE.json [--sampler S] [--spp N | --time SEC | --until-cancelled] -o OUT.exr
                       [--compare uniform,adaptive_exact] [--reference REF.exr] [--seed K] [--width W --height H]
                       [--ris M] [--n-max X] [--max-depth D] [--exposure EV]
    brdf-studio render --demo
    brdf-studio render SCENE.json --spp 4096 --scheduler tcp://HOST:8786   (or --workers N: a local cluster)

Writes ``OUT.exr`` (linear HDR), ``OUT.png`` (tone-mapped sRGB) and ``OUT.json`` (settings, time, spp, versions).
With ``--compare`` every strategy gets ``OUT_<strategy>.exr/.png/.json`` at the same budget, plus a labelled
side-by-side ``OUT_compare.png``. With ``--reference``, the RMSE and relMSE of each strategy are printed and
recorded after every pass, and written as error-vs-time curves ``OUT_error.csv`` and ``OUT_error.png``.

Output names keep every dot of ``OUT`` but a final ``.exr`` (``-o shot.final.exr`` writes ``shot.final.png``
beside it, never ``shot.png``). Every argument is range-checked before the scene is read, the memory the
render needs before it is prepared (``renderer.render.band_plan``): a render whose whole film does not fit the
memory budget (16384x16384 on most machines) is rendered in bands of rows, each with all its samples, streamed
to the EXR and PNG (``--spp`` only: no ``--time``, ``--until-cancelled``, ``--compare`` or ``--reference``,
which need the whole image; interrupted, it saves nothing and leaves the previous outputs). Ctrl-C (or SIGTERM) while passes run
finishes the pass in flight and saves the image of the passes done, then exits with 130 (143); a second
Ctrl-C stops at once, still saving what the completed passes hold.

With ``--scheduler ADDRESS`` (a running Dask scheduler) or ``--workers N`` (a local cluster of N processes) the
passes run on Dask workers (:mod:`renderer.distributed`, ``docs/distributed.md``): the same image, bit for
bit, with the same progress, budgets, Ctrl-C and sidecar (which adds the cluster's part). A scheduler that
does not answer within seconds is refused with one line.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path
from typing import Any

from app.commands import _args, _signals
from app.commands._args import add_list, exposure, name, number, output_stem, seed, whole, with_extension
from app.commands._bands import check_band_request, check_finite, render_in_bands
from core.errors import OutputError, ParameterError

MAX_RIS = 1024
"""Candidates per sky sample; the memory budget of a pass bounds it further for large images."""
PREPARE_BAR = "{desc}{n_fmt}/{total_fmt} [{elapsed}]"
"""The preparation's progress: its steps and the time so far (a rate or an estimate would count a first run's
compiling as the steps' work; :mod:`app.commands._compile_notice` says when compiling happens)."""
MAX_LOCAL_WORKERS = 256
"""Worker processes of a local cluster (``--workers``)."""


def _seconds(value: str) -> float:
    """A time budget in seconds: finite, in (0, one week]."""
    try:
        v = float(value)
    except ValueError:
        v = math.nan
    if math.isinf(v) and v > 0:
        raise argparse.ArgumentTypeError(
            f"must be a finite number of seconds in (0, {_args.MAX_SECONDS:g}], got {value!r}; "
            "to render until Ctrl-C, use --until-cancelled"
        )
    return number(0.0, _args.MAX_SECONDS, lo_open=True)(value)


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "render", help="path-trace a scene file (progressive; several strategies side by side)"
    )
    p.add_argument("scene", nargs="?", help="scene file (JSON)")
    p.add_argument("--demo", action="store_true", help="render the bundled demo scene")
    p.add_argument(
        "--sampler", type=name, help="BRDF sampling strategy (default: the scene's); see 'brdf-studio models'"
    )
    p.add_argument(
        "--n-max",
        type=number(1.0, 1000.0, lo_open=True),
        help="the adaptive sampler's n_max, (1, 1000] (its one knob)",
    )
    budget = p.add_mutually_exclusive_group()
    budget.add_argument(
        "--spp",
        type=whole(1, _args.MAX_SPP),
        help=f"samples per pixel, [1, {_args.MAX_SPP}] (equal-spp mode)",
    )
    budget.add_argument(
        "--time", type=_seconds, metavar="SEC", help="seconds of rendering, up to a week (equal-time mode)"
    )
    budget.add_argument(
        "--until-cancelled",
        action="store_true",
        help="render until Ctrl-C, then save what was rendered (exit code 130)",
    )
    p.add_argument("-o", "--output", help="output EXR (default: <scene name>.exr in the current folder)")
    add_list(
        p, "--compare", metavar="S", help="render each strategy with the same budget (uniform,adaptive_exact)"
    )
    p.add_argument(
        "--reference", metavar="REF.exr", help="reference image: report RMSE/relMSE and error curves"
    )
    p.add_argument("--seed", type=seed, help="random seed (same seed, same image)")
    side = whole(1, _args.MAX_SIDE)
    p.add_argument(
        "--width", type=side, help=f"image width in pixels, [1, {_args.MAX_SIDE}] (default: the scene's)"
    )
    p.add_argument(
        "--height", type=side, help=f"image height in pixels, [1, {_args.MAX_SIDE}] (default: the scene's)"
    )
    p.add_argument(
        "--max-depth",
        type=whole(1, _args.MAX_DEPTH),
        help=f"maximum number of bounces, [1, {_args.MAX_DEPTH}]",
    )
    p.add_argument(
        "--ris",
        type=whole(0, MAX_RIS),
        default=0,
        metavar="M",
        help=f"light from the sky by RIS with M candidates, [0, {MAX_RIS}] (default 0: off)",
    )
    p.add_argument(
        "--exposure",
        type=exposure,
        default=0.0,
        help=f"PNG exposure in stops, [-{_args.MAX_EXPOSURE:g}, {_args.MAX_EXPOSURE:g}] (default 0)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    cluster = p.add_mutually_exclusive_group()
    cluster.add_argument(
        "--scheduler",
        type=_scheduler,
        metavar="ADDRESS",
        help="render on the Dask scheduler at ADDRESS (tcp://HOST:PORT)",
    )
    cluster.add_argument(
        "--workers",
        type=whole(1, MAX_LOCAL_WORKERS),
        metavar="N",
        help=f"render on a local Dask cluster of N worker processes, [1, {MAX_LOCAL_WORKERS}]",
    )
    return ["render"]


def _scheduler(value: str) -> str:
    """A Dask scheduler address (``tcp://HOST:PORT``), checked for its form before anything is read."""
    from renderer.distributed.cluster import check_address

    try:
        return check_address(value)
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def demo_scene_path() -> Path:
    from importlib.resources import files

    return Path(str(files("resources") / "scenes" / "demo" / "demo.json"))


def _strategies(args: argparse.Namespace, default: str) -> list[str]:
    from core.sampling import sampler_names
    from core.sampling.base import current_sampler_name

    if args.compare and args.sampler:
        raise ParameterError("give --sampler or --compare, not both")
    names = [current_sampler_name(s) for s in (args.compare if args.compare else [args.sampler or default])]
    known = sampler_names()
    for s in names:
        if s not in known:
            raise ParameterError(f"unknown sampler '{s}'; known samplers: {', '.join(known)}")
    if len(set(names)) != len(names):
        raise ParameterError("--compare lists a strategy twice")
    return names


def strategy_options(strategy: str, scene_options: dict[str, Any], n_max: float | None) -> dict[str, Any]:
    """The options a strategy gets: those of the scene's ``sampler_options`` it declares (the scene file's
    are checked against its own ``sampler`` when it is read), and ``--n-max`` if it takes one."""
    from core.sampling.base import sampler_option_set

    declared = sampler_option_set(strategy)
    options = {k: v for k, v in scene_options.items() if k in declared}
    if n_max is not None and "n_max" in declared:
        options["n_max"] = n_max
    return options


def _output_stem(args: argparse.Namespace, scene_path: Path) -> Path:
    if args.output is not None and not args.output.strip():
        raise ParameterError("-o needs a file name (OUT.exr)")
    out = Path(args.output) if args.output is not None else Path(scene_path.stem + ".exr")
    if out.suffix.lower() != ".exr":
        raise ParameterError(f"the output must be an .exr file, got '{out}'")
    if out.is_dir():
        raise OutputError(f"cannot write '{out}': it is a folder")
    folder = out.parent if str(out.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"cannot write '{out}': folder '{out.parent}' does not exist")
    try:  # before any work: an unwritable folder is found now, not after an hour of rendering
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise OutputError(f"cannot write '{out}': {exc.strerror or exc}") from None
    stem = output_stem(out, (".exr",))
    if args.output is None and with_extension(stem, ".json").resolve() == scene_path.resolve():
        stem = stem.with_name(stem.name + "_render")  # the default's sidecar would be the scene file itself
    return stem


def _check_collisions(stem: Path, strategies: list[str], protected: list[Path]) -> None:
    """No output may overwrite an input (the scene file, the reference image)."""
    stems = [stem] if len(strategies) == 1 else [stem.with_name(f"{stem.name}_{s}") for s in strategies]
    outputs = [with_extension(s, ext) for s in stems for ext in (".exr", ".png", ".json")]
    outputs += [with_extension(stem, x) for x in ("_compare.png", "_error.csv", "_error.png")]
    inputs = {p.resolve(): p for p in protected}
    for out in outputs:
        if out.resolve() in inputs:
            raise ParameterError(
                f"'{out}' would overwrite the input '{inputs[out.resolve()]}'; choose another -o"
            )


def run(args: argparse.Namespace) -> int:
    if args.scene is None and args.compare and args.compare[-1].lower().endswith(".json"):
        args.scene = args.compare.pop()  # "--compare a,b scene.json": the list took the scene
    if args.demo == bool(args.scene):
        raise ParameterError("give a scene file or --demo (one of them)")
    scene_path = demo_scene_path() if args.demo else Path(args.scene)
    stem = _output_stem(args, scene_path)
    # a scheduler first: one that does not answer is refused in seconds, before the scene is read; a local
    # cluster starts once the scene and the request are checked
    cluster = _connect(args) if args.scheduler else None
    try:
        return _checked_render(args, scene_path, stem, cluster)
    finally:
        if cluster is not None:
            cluster.close()


def _checked_render(args: argparse.Namespace, scene_path: Path, stem: Path, cluster) -> int:  # type: ignore[no-untyped-def]
    from core.scene import load_scene
    from renderer.image_io import read_exr
    from renderer.render import band_plan

    scene = load_scene(scene_path)
    strategies = _strategies(args, scene.render.sampler)
    _check_collisions(stem, strategies, [scene_path] + ([Path(args.reference)] if args.reference else []))
    options = {s: strategy_options(s, dict(scene.render.sampler_options), args.n_max) for s in strategies}
    if args.n_max is not None and not any("n_max" in o for o in options.values()):
        raise ParameterError(
            f"--n-max is an option of the adaptive samplers; no strategy rendered here ({', '.join(strategies)}) takes it"
        )
    reference = read_exr(args.reference) if args.reference else None
    spp, time_s = args.spp, args.time
    if args.until_cancelled:
        time_s = math.inf
    elif spp is None and time_s is None:
        spp, time_s = (None, scene.render.time_s) if scene.render.time_s else (scene.render.spp, None)

    width = args.width or scene.render.width
    height = args.height or scene.render.height
    # the budget (also in prepare()), here before any progress bar is drawn: None renders the whole film
    rows = band_plan(width, height, args.ris)
    if rows is not None:
        check_band_request(args, time_s, strategies, width, height)
        if args.scheduler or args.workers:
            raise ParameterError(
                f"a {width}x{height} render is rendered in bands of rows, on this machine; "
                "--scheduler and --workers are for renders whose film fits in memory"
            )
    if cluster is None and args.workers:
        cluster = _connect(args)
        try:
            return _render(args, scene, stem, strategies, options, reference, spp, time_s, rows, cluster)
        finally:
            cluster.close()
    return _render(args, scene, stem, strategies, options, reference, spp, time_s, rows, cluster)


def _connect(args: argparse.Namespace):  # type: ignore[no-untyped-def]
    """The Dask cluster of ``--scheduler``/``--workers``, or None (this machine)."""
    if not (args.scheduler or args.workers):
        return None
    from renderer.distributed import connect

    with _signals.deferred():
        cluster = connect(args.scheduler, args.workers)
    if not args.quiet:
        print(f"rendering on {cluster.state().describe()}", file=sys.stderr)
    return cluster


def _render(args, scene, stem, strategies, options, reference, spp, time_s, rows, cluster) -> int:  # type: ignore[no-untyped-def]
    from tqdm import tqdm

    from renderer.image_io import composite, image_errors, write_error_curves, write_exr, write_png
    from renderer.image_io import write_sidecar as write_json
    from renderer.render import prepare

    images, curves, summary = [], {}, []
    interrupted = False
    for strategy in strategies:
        bar = tqdm(
            total=1,
            desc=f"{strategy}: prepare: ",  # set_description adds the ": " itself
            bar_format=PREPARE_BAR,
            disable=args.quiet,
            file=sys.stderr,
        )

        def on_step(what: str, k: int, n: int, bar=bar, strategy=strategy) -> None:
            _signals.check()
            bar.total = max(1, n)
            bar.n = k
            bar.set_description(f"{strategy}: prepare {what}", refresh=False)
            bar.refresh()

        settings = dict(
            sampler=strategy,
            sampler_options=options[strategy],
            width=args.width,
            height=args.height,
            seed=args.seed,
            max_depth=args.max_depth,
            on_step=on_step,
            ris_candidates=args.ris,
        )
        with _signals.deferred():  # a Ctrl-C here stops at the next step (and after the last)
            if cluster is not None:
                from renderer.distributed import prepare_distributed

                job = prepare_distributed(cluster, scene, **settings)
            else:
                job = prepare(scene, bands=rows is not None, **settings)
        bar.close()
        try:
            _signals.check()  # a Ctrl-C during preparation whose exception a finalizer swallowed
            if reference is not None:
                h, w = reference.shape[:2]
                if job.size != (w, h):
                    raise ParameterError(
                        f"the reference is {w}x{h} but the render is {job.size[0]}x{job.size[1]}; "
                        "use --width/--height"
                    )
            if rows is not None:
                assert spp is not None  # check_band_request
                if render_in_bands(job, strategy, spp, rows, stem, args.exposure, args.quiet):
                    summary.append((strategy, job, None, with_extension(stem, ".exr")))
                interrupted = _signals.STATE.seen
                break
            records = _render_passes(job, strategy, spp, time_s, reference, args.quiet, image_errors)
            interrupted = _signals.STATE.seen
            image = job.film.image()
            if job.film.spp == 0:  # interrupted before the first pass ended: nothing to save
                break
            check_finite(image, strategy)
            info = job.info()
            if interrupted:
                info["interrupted"] = True
            if reference is not None:
                info["errors"] = records[-1] if records else None
                curves[strategy] = records
            path = stem if len(strategies) == 1 else stem.with_name(f"{stem.name}_{strategy}")
            with _signals.cooperative():  # a Ctrl-C now is recorded: the three files are written together
                write_exr(with_extension(path, ".exr"), image, {"spp": job.film.spp, "sampler": strategy})
                write_png(with_extension(path, ".png"), image, args.exposure)
                write_json(with_extension(path, ".json"), info)
            interrupted = interrupted or _signals.STATE.seen
            images.append(image)
            summary.append((strategy, job, records[-1] if records else None, with_extension(path, ".exr")))
        finally:
            job.close()
        if interrupted:
            break

    _print_summary(summary)
    if len(images) > 1:
        labels = [f"{s} {j.film.spp}SPP {j.elapsed:.1f}S" for s, j, _, _ in summary]
        out = stem.with_name(f"{stem.name}_compare.png")
        write_png(out, composite(images, labels, args.exposure))
        print(f"side by side: {out}")
    if curves:
        csv_path, png_path = write_error_curves(
            # ".csv" given here, so that its with_suffix() replaces that, not a dot of the stem (out_t1.1)
            stem.with_name(f"{stem.name}_error.csv"),
            curves,
            title=scene.source,
        )
        print(f"error vs time: {csv_path}, {png_path}")
    if interrupted or _signals.STATE.seen:
        nothing = (
            "nothing (a render in bands is saved when its last band is done; earlier outputs are intact)"
            if rows is not None
            else "nothing (no pass had finished)"
        )
        saved = ", ".join(str(out) for _, _, _, out in summary) or nothing
        print(f"brdf-studio render: interrupted; saved {saved}", file=sys.stderr)
        return _signals.STATE.exit_code
    return 0


def _render_passes(job, strategy, spp, time_s, reference, quiet, image_errors) -> list[dict]:  # type: ignore[no-untyped-def]
    """Passes to the budget (``time_s = inf``: until cancelled); the first Ctrl-C/SIGTERM ends them after
    the pass in flight, a second one at once (the film keeps every completed pass either way)."""
    from tqdm import tqdm

    forever = time_s is not None and math.isinf(time_s)
    total = None if forever else (spp if spp is not None else time_s)
    unit = "spp" if spp is not None or forever else "s"
    bar = tqdm(total=total, desc=f"{strategy}: render", unit=unit, disable=quiet, file=sys.stderr)
    records: list[dict] = []
    try:
        with _signals.cooperative() as stop:
            for frame in job.passes(spp=spp, time_s=time_s, cancel=stop):
                _signals.reinstall()
                bar.n = (
                    frame.spp if spp is not None or forever else min(time_s or 0.0, round(frame.elapsed, 2))
                )
                state = getattr(job, "state", None)  # a render on a cluster: its workers and tasks
                if state is not None:
                    bar.set_postfix(spp=frame.spp, workers=state.workers, tasks=state.running, refresh=False)
                else:
                    bar.set_postfix(spp=frame.spp, refresh=False)
                bar.refresh()
                if reference is not None:
                    records.append(
                        {"spp": frame.spp, "seconds": frame.elapsed, **image_errors(frame.image, reference)}
                    )
    except KeyboardInterrupt:
        pass  # a second Ctrl-C: stop now, save the completed passes
    finally:
        bar.close()
    return records


def _print_summary(summary: list) -> None:  # type: ignore[type-arg]
    from app.sampling_data import table_origin

    print(
        f"{'strategy':<14}{'spp':>6}{'seconds':>9}{'Mrays/s':>9}{'prepare s':>10}{'RMSE':>12}{'relMSE':>12}  output"
    )
    for strategy, job, err, out in summary:
        rps = job.rays / job.elapsed / 1e6 if job.elapsed > 0 else 0.0
        rmse = f"{err['rmse']:.5g}" if err else "-"
        rel = f"{err['relmse']:.5g}" if err else "-"
        rep = job.prepare_report
        prep = rep["seconds"]
        print(
            f"{strategy:<14}{job.spp:>6}{job.elapsed:>9.2f}{rps:>9.2f}{prep:>10.2f}{rmse:>12}{rel:>12}  {out}"
        )
        for mname, minfo in job.prepare_report["materials"].items():
            if minfo.get("note"):
                print(f"    note: material '{mname}': {minfo['note']}")
            if minfo.get("memory_bytes"):
                print(
                    f"    tables: material '{mname}' ({minfo['model']}, {minfo['sampler']}): "
                    f"{minfo['memory_bytes'] / 1024:.1f} KB, {table_origin(minfo)}"
                )
