"""``brdf-studio eval``: the value of a BRDF (analytic or measured) for one pair of directions.

Also holds the argument helpers every command that takes a BRDF shares (``--model``, ``--param``,
``--measured``) and the ``THETA,PHI`` angle parser.

``--model`` takes a registered name or a model file (``.brdf``, ``.py``; :mod:`core.model_files`), and
``--param`` the file's own parameter names. What a model file's load noticed without refusing it (values a
shader returns that a BRDF cannot, taken as 0) is printed on stderr, one ``notice:`` line each, and the
command goes on.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from app.commands._args import add_list, name
from core.brdf import BRDF, Model, get_model, parse_assignments
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.model_files.declarations import param_location


def add_brdf_arguments(p: argparse.ArgumentParser) -> None:
    """``--model M``, ``--param k=v ...`` (a list), ``--measured FILE``."""
    p.add_argument(
        "--model",
        type=name,
        metavar="M",
        help="a model name (see 'brdf-studio models') or a model file (.brdf, .py)",
    )
    add_list(
        p,
        "--param",
        split=False,
        metavar="K=V",
        default=[],
        help="model parameters (a list); a color takes one number or three (kd=0.2,0.5,0.8), a bool 0 or 1",
    )
    p.add_argument(
        "--measured",
        type=name,
        metavar="FILE",
        help="a measured file (MERL .binary, RGL .bsdf) instead of --model",
    )


def brdf_from_args(args: argparse.Namespace) -> BRDF:
    """The BRDF the ``--model/--param/--measured`` arguments describe (errors as BrdfStudioError)."""
    if args.measured is not None:
        if args.model is not None and args.model != "merl":
            raise ParameterError("give either --model or --measured, not both")
        if args.param:
            raise ParameterError("a measured BRDF (--measured) takes no --param")
        from core.measured import load_measured

        return load_measured(args.measured)
    if args.model is None:
        raise ParameterError("give --model M (see 'brdf-studio models') or --measured FILE")
    if args.model == "merl":
        raise ParameterError("a measured BRDF is read from a file: give --measured FILE")
    model = model_from_arg(args.model, getattr(args, "command", None))
    return bind_params(model, args.param)


_NOTICED: set[tuple[str, str]] = set()
"""The model files (path and content) whose notices this process has printed."""


def print_notices(model: Model, command: str | None) -> None:
    """A model file's notices (``model.source.findings``) on stderr, one line each, once per process."""
    source = model.source
    if source is None or (source.path, source.digest) in _NOTICED:
        return
    _NOTICED.add((source.path, source.digest))
    prefix = f"brdf-studio {command}: " if command else ""
    for finding in source.findings:
        print(f"{prefix}notice: {finding}", file=sys.stderr)


def model_from_arg(model_name: str, command: str | None = None) -> Model:
    """The model ``--model`` names, a registered model or a model file (whose notices are printed)."""
    model = get_model(model_name)
    print_notices(model, command)
    return model


def checked_values(
    model: Model, assignments: Mapping[str, Any] | Sequence[str] | None, option: str = "--param"
) -> dict[str, Any]:
    """``K=V`` assignments (``option``'s) as a dict, each name the model's and each value within its range.
    A model file's value outside its range names the line of the file that declares the parameter:
    ``path:line: --param n=5000: parameter 'n' of model 'x.brdf' = 5000 is outside its allowed range [1, 1000]``."""
    values = parse_assignments(assignments)
    for key, value in values.items():
        param = model.param(key)  # an unknown name: its message lists the model's parameters
        if model.source is None:
            continue
        try:
            param.validate(Path(model.source.path).name, value)
        except ParameterError as exc:
            raise ParameterError(
                f"{param_location(model.source, key)}: {option} {key}={value}: {exc}"
            ) from None
    return values


def bind_params(model: Model, assignments: Mapping[str, Any] | Sequence[str] | None) -> BRDF:
    """``model`` bound to ``--param`` assignments (:func:`checked_values`)."""
    return model.bind(checked_values(model, assignments))


def parse_angle(text: str, what: str) -> tuple[float, float]:
    """``"THETA,PHI"`` in degrees -> ``(theta, phi)``; theta within [0, 90], phi any finite angle."""
    parts = [s.strip() for s in str(text).split(",")]
    if len(parts) != 2:
        raise ParameterError(f"{what} must be THETA,PHI in degrees (e.g. 30,0), got {text!r}")
    try:
        theta, phi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ParameterError(f"{what} must be two numbers THETA,PHI in degrees, got {text!r}") from None
    if not (math.isfinite(theta) and math.isfinite(phi)):
        raise ParameterError(f"{what} must be finite angles, got {text!r}")
    if not 0.0 <= theta <= 90.0:
        raise ParameterError(f"{what}: theta must be within [0, 90] degrees, got {theta:g}")
    return theta, phi


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "eval",
        help="evaluate a BRDF for one pair of directions",
        description="Print f_r(wi, wo) as RGB (1/sr). Angles in degrees in the local frame (z = normal).",
    )
    add_brdf_arguments(p)
    p.add_argument("--wi", required=True, metavar="THETA,PHI", help="incident direction, degrees")
    p.add_argument("--wo", required=True, metavar="THETA,PHI", help="outgoing direction, degrees")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    return ["eval"]


def run(args: argparse.Namespace) -> int:
    wi_deg = parse_angle(args.wi, "--wi")
    wo_deg = parse_angle(args.wo, "--wo")
    brdf = brdf_from_args(args)
    rgb = [float(v) for v in brdf.eval(degrees_to_dir(*wo_deg), degrees_to_dir(*wi_deg))[0]]
    if args.json:
        print(json.dumps({"brdf": brdf.key(), "wi_deg": wi_deg, "wo_deg": wo_deg, "f_r": rgb}))
    else:
        print(f"{rgb[0]:.9g} {rgb[1]:.9g} {rgb[2]:.9g}")
    return 0
