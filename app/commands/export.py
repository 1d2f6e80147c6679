"""``brdf-studio export``: write any BRDF (an analytic model with parameters, or a measured file) as a
measured file: MERL ``.binary`` or RGL ``.bsdf``, by the output's suffix."""

from __future__ import annotations

import argparse
from pathlib import Path

from app.commands._args import check_output
from app.commands.eval import add_brdf_arguments, brdf_from_args
from core.measured import SUFFIXES, format_of, load_measured, write_measured


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "export",
        help="write a BRDF as a measured file (.binary or .bsdf)",
        description="Tabulate a BRDF into a measured format chosen by the output's suffix "
        f"({', '.join(SUFFIXES)}); the file is read back and checked.",
    )
    add_brdf_arguments(p)
    p.add_argument("-o", "--out", required=True, type=Path, metavar="FILE", help="output file")
    return ["export"]


def run(args: argparse.Namespace) -> int:
    fmt = format_of(args.out)  # a clear error for an unknown suffix before any work
    check_output(args.out)
    brdf = brdf_from_args(args)
    write_measured(args.out, brdf)
    back = load_measured(args.out)
    print(
        f"wrote {args.out} ({fmt.label}, {args.out.stat().st_size} bytes): {brdf.key()} -> {back.model.name}"
    )
    return 0
