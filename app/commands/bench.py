"""``brdf-studio bench samplers``: the sampler study (precompute, memory, speed, error of L_r)."""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from app.commands._args import add_list, theta, whole
from core.brdf import get_model
from core.errors import ParameterError, UnknownNameError
from core.sampling import sampler_names
from core.sampling.base import current_sampler_name
from core.study import DEFAULT_SAMPLERS, StudyConfig, default_lights, materials, study_material, write_results

QUICK_MODELS = ("lambert", "phong", "ward")


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser("bench", help="run a benchmark study (samplers)")
    p.add_argument("study", choices=["samplers"], help="which study")
    add_list(p, "--models", metavar="M", help="models to include (default: all)")
    add_list(
        p, "--measured", split=False, nargs="*", default=None, metavar="FILE", help="MERL files to include"
    )
    add_list(p, "--samplers", metavar="S", help=f"strategies (default: {' '.join(DEFAULT_SAMPLERS)})")
    add_list(
        p, "--theta", "--thetas", item=theta, dest="thetas", metavar="DEG", help="angles in degrees, [0, 90]"
    )
    p.add_argument("--quick", action="store_true", help="a small smoke run (under a minute)")
    p.add_argument("--out", type=Path, default=Path("results/samplers"), help="results folder")
    p.add_argument("--materials", type=Path, metavar="DIR", help="every measured file of DIR, as Dask tasks")
    p.add_argument("--scheduler", metavar="ADDRESS", help="with --materials: an existing Dask scheduler")
    p.add_argument(
        "--workers",
        type=whole(1, 1_000_000),
        default=None,
        metavar="N",
        help="with --materials: local Dask workers (default 2; at most what the machine's cores and memory hold)",
    )
    return ["bench"]


def _check_cluster_options(args: argparse.Namespace) -> None:
    """``--scheduler`` and ``--workers`` belong to the folder study: refused without ``--materials`` (they
    would be ignored), and together (the scheduler's own workers run the tasks)."""
    if args.materials is None:
        for flag, value in (("--scheduler", args.scheduler), ("--workers", args.workers)):
            if value is not None:
                raise ParameterError(f"{flag} runs the folder study on Dask: it needs --materials DIR")
    elif args.scheduler is not None and args.workers is not None:
        raise ParameterError(
            "--workers starts a local cluster; with --scheduler the scheduler's workers run the tasks "
            "(give one or the other)"
        )


def _config(args: argparse.Namespace) -> StudyConfig:
    if args.quick:
        cfg = StudyConfig(thetas=(30.0,), counts=(16, 64, 256), batch=1 << 14, reference_samples=1 << 17)
    else:
        cfg = StudyConfig()
    if args.thetas:
        cfg.thetas = tuple(args.thetas)
    if args.samplers:
        args.samplers = [s if s == "ris" else current_sampler_name(s) for s in args.samplers]
        unknown = [s for s in args.samplers if s not in sampler_names() and s != "ris"]
        if unknown:
            raise UnknownNameError(
                f"unknown sampler(s) {', '.join(unknown)}; known: {', '.join(sampler_names())}, ris"
            )
        cfg.samplers = tuple(args.samplers)
    else:
        cfg.samplers = tuple(s for s in DEFAULT_SAMPLERS if s in sampler_names() or s == "ris")
    return cfg


def _measured_default() -> list[Path]:
    """The bundled synthetic MERL material(s)."""
    from resources.materials import demo_materials

    return [Path(m["measured"]) for m in demo_materials() if "measured" in m and Path(m["measured"]).exists()]


def run(args: argparse.Namespace) -> int:
    _check_cluster_options(args)
    cfg = _config(args)
    if args.materials is not None:  # the folder study on Dask (app/commands/_folder_study.py)
        from app.commands._folder_study import run_folder

        return run_folder(args, cfg)
    names = args.models or (QUICK_MODELS if args.quick else None)
    for n in names or ():
        get_model(n)  # a clear error for an unknown name before any work
    measured = args.measured if args.measured is not None else ([] if args.quick else _measured_default())
    mats = materials(names, measured)
    lights = default_lights()
    steps = len(mats) * len(cfg.thetas) * len(lights) * len(cfg.samplers)
    rows = []
    with tqdm(total=steps, desc="sampler study", unit="case", disable=None) as bar:
        for label, brdf in mats:
            bar.set_postfix_str(label)
            rows += study_material(label, brdf, cfg, lights, tick=bar.update)
    paths = write_results(rows, args.out)
    print(paths["markdown"].read_text())
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0
