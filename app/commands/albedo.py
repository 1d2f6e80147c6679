"""``brdf-studio albedo``: directional albedo of a BRDF at chosen outgoing angles, with error estimates."""

from __future__ import annotations

import argparse
import json
import math

from app.commands.eval import add_brdf_arguments, brdf_from_args
from core.analysis import albedo
from core.errors import ParameterError


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "albedo",
        help="directional albedo rho(theta) with its error estimate",
        description=(
            "Directional albedo rho(theta_o) = integral of f_r cos(theta_i) over the hemisphere, per RGB channel, "
            "by adaptive Gauss-Kronrod cubature (see docs/analysis.md); each value comes with its stated error."
        ),
    )
    add_brdf_arguments(p)
    p.add_argument(
        "--theta",
        metavar="DEG",
        type=str,
        nargs="+",
        default=["0", "30", "60", "80"],
        help="outgoing polar angles in degrees, within [0, 90] (default: 0 30 60 80)",
    )
    p.add_argument("--phi", metavar="DEG", type=str, default="0", help="outgoing azimuth in degrees")
    p.add_argument(
        "--rtol",
        type=str,
        default=None,
        help="target relative error (default 1e-6; 1e-4 for a measured BRDF)",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    return ["albedo"]


def _number(text: str, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ParameterError(f"{what} must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise ParameterError(f"{what} must be finite, got {text!r}")
    return v


def run(args: argparse.Namespace) -> int:
    thetas = [_number(t, "--theta") for t in args.theta]
    for t in thetas:
        if not 0.0 <= t <= 90.0:
            raise ParameterError(f"--theta must be within [0, 90] degrees, got {t:g}")
    phi = _number(args.phi, "--phi")
    rtol = None if args.rtol is None else _number(args.rtol, "--rtol")
    if rtol is not None and not 0.0 < rtol < 1.0:
        raise ParameterError(f"--rtol must be within (0, 1), got {rtol:g}")
    brdf = brdf_from_args(args)
    results = [albedo(brdf, t, phi, rtol=rtol) for t in thetas]
    if args.json:
        print(json.dumps({"brdf": brdf.key(), "albedo": [r.to_dict() for r in results]}, indent=2))
        return 0
    print(f"directional albedo of {brdf.key()}")
    print(f"{'theta':>7}  {'R':>10} {'G':>10} {'B':>10}  {'error (max)':>11}  evals")
    for r in results:
        flag = "" if r.converged else "  (not converged: budget spent)"
        print(
            f"{r.theta_deg:7.2f}  {r.value[0]:10.6f} {r.value[1]:10.6f} {r.value[2]:10.6f}  "
            f"{max(r.error):11.1e}  {r.evaluations}{flag}"
        )
    return 0
