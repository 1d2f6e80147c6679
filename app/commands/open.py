"""``brdf-studio open [FILE.json]``: the desktop app (also what bare ``brdf-studio`` runs)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser("open", help="open the desktop app (on a project file, or the bundled demo scene)")
    p.add_argument("file", nargs="?", type=Path, help="a project (scene) JSON file")
    p.add_argument("--empty", action="store_true", help="start with a new project instead of the demo scene")
    p.add_argument(
        "--restore",
        choices=("ask", "yes", "no"),
        default=None,
        help="unsaved edits of a session that crashed: ask whether to restore them (default), restore them, "
        "or leave them",
    )
    p.add_argument("--quit-after", type=float, default=None, help=argparse.SUPPRESS)  # smoke tests
    return ["open"]


def run(args: argparse.Namespace) -> int:
    from app.application import run_app

    return run_app(args.file, empty=args.empty, quit_after=args.quit_after, restore=args.restore)
