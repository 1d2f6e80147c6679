"""``brdf-studio fit``: fit an analytic model's parameters to a measured material (MERL ``.binary`` or RGL
``.bsdf``) by weighted least squares on ``f cos`` (:mod:`core.fit`); the fitted parameters can be written as
a scene-file material."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from app.commands._args import check_output, seed, whole
from app.commands.eval import checked_values, model_from_arg
from core.errors import ParameterError
from core.fit import METRICS, fit
from core.io import atomic_write_text
from core.measured import load_measured
from core.model_files import is_model_file

_positive_int = whole(1, 100)


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "fit",
        help="fit an analytic model to a measured material",
        description=(
            "Fit the parameters of an analytic model to a measured BRDF (MERL .binary or RGL .bsdf) by a weighted "
            "least squares on f cos(theta_i) under a log or cube-root metric (see core/fit.py). Prints the "
            "parameters, the residual and the time; --out writes the fitted material as JSON (a scene-file entry)."
        ),
    )
    p.add_argument("--measured", required=True, metavar="FILE", help="measured material (.binary or .bsdf)")
    p.add_argument(
        "--model",
        required=True,
        metavar="M",
        help="analytic model to fit (see 'brdf-studio models'), or a model file (.brdf, .py)",
    )
    p.add_argument("--metric", choices=METRICS, default="log", help="residual metric (default: log)")
    p.add_argument("--fix", nargs="+", default=[], metavar="K=V", help="parameters kept at given values")
    p.add_argument(
        "--starts", type=_positive_int, default=3, help="starting points (default 3: defaults + 2 random)"
    )
    p.add_argument("--seed", type=seed, default=1, help="seed of the random starting points")
    p.add_argument("--out", type=Path, metavar="FILE.json", help="write the fitted material here")
    p.add_argument("--name", default=None, help="name of the fitted material (default: MODEL fit of FILE)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    return ["fit"]


def _text(v: object) -> str:
    if isinstance(v, tuple):
        return ", ".join(f"{x:.6g}" for x in v)
    return f"{v:.6g}"  # type: ignore[str-format]


def material_model(model_name: str, out: Path | None) -> str:
    """How the written material names its model: a registered name as it is; a model file relative to the
    folder of ``out`` (a scene file beside it reads it from there), absolute when nothing is written."""
    if not is_model_file(model_name) or out is None:
        return model_name
    try:
        return Path(os.path.relpath(model_name, out.resolve().parent)).as_posix()
    except ValueError:  # another drive (Windows)
        return model_name


def run(args: argparse.Namespace) -> int:
    model = model_from_arg(args.model, args.command)
    if model.measured:
        raise ParameterError(
            f"'{args.model}' is a measured model; fit an analytic one (see 'brdf-studio models')"
        )
    if args.out is not None:
        check_output(args.out)
    fixed = checked_values(model, args.fix, "--fix")
    source = load_measured(args.measured)
    result = fit(source, model.name, args.metric, fixed=fixed, starts=args.starts, seed=args.seed)
    label = Path(args.model).stem if model.source is not None else args.model
    name = args.name or f"{label} fit of {Path(args.measured).stem}"
    material = result.material(name)
    material["model"] = material_model(model.name, args.out)
    if args.out is not None:
        atomic_write_text(args.out, json.dumps(material, indent=2) + "\n")
    if args.json:
        print(
            json.dumps(
                {
                    "material": material,
                    "metric": result.metric,
                    "residual": result.residual,
                    "relative_error": result.relative_error,
                    "seconds": result.seconds,
                    "evaluations": result.evaluations,
                    "points": result.points,
                }
            )
        )
        return 0
    print(f"fit of {args.model} to {args.measured} ({result.points} measurements, metric {result.metric})")
    width = max(len(p.name) for p in model.params)
    for p in model.params:
        value = result.params[p.name]
        note = " (fixed)" if p.name in fixed or p.kind == "bool" else ""
        print(f"  {p.name:<{width}}  {_text(value)}{note}")
    print(f"residual (weighted RMS, {result.metric} metric): {result.residual:.3e}")
    print(f"median relative error of f cos (weighted, above 1% of the peak): {result.relative_error:.3e}")
    print(f"time: {result.seconds:.2f} s, {result.evaluations} model evaluations over {result.points} points")
    if args.out is not None:
        print(f"wrote {args.out}")
    return 0
