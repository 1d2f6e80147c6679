"""``brdf-studio albedo``: directional albedo of a BRDF at chosen outgoing angles, with error estimates."""

from __future__ import annotations

import argparse
import json

from app.commands._args import add_list, azimuth, number, theta
from app.commands.eval import add_brdf_arguments, brdf_from_args
from core.analysis import albedo


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
    add_list(
        p,
        "--theta",
        item=theta,
        metavar="DEG",
        help="outgoing polar angles in degrees, within [0, 90] (default: 0 30 60 80)",
    )
    p.add_argument("--phi", metavar="DEG", type=azimuth, default=0.0, help="outgoing azimuth in degrees")
    p.add_argument(
        "--rtol",
        type=number(0.0, 1.0, lo_open=True, hi_open=True),
        default=None,
        help="target relative error in (0, 1) (default 1e-6; 1e-4 for a measured BRDF)",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    return ["albedo"]


def run(args: argparse.Namespace) -> int:
    thetas = args.theta or [0.0, 30.0, 60.0, 80.0]
    phi, rtol = args.phi, args.rtol
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
