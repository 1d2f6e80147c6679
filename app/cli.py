"""The ``brdf-studio`` command: subcommands for the library, the renderer and the desktop app.

Each subcommand lives in its own module under ``app/commands/`` with two functions,
``add_parser(subparsers) -> list[str]`` (the command names it adds) and ``run(args) -> int``; modules are found
by name, so adding a command is adding a file. Errors a user can cause (``BrdfStudioError``) print one
clear line and exit with its code; nothing the user does shows a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
from collections.abc import Sequence

from core.errors import BrdfStudioError


def _command_modules() -> list[str]:
    import pkgutil

    import app.commands

    return [
        f"app.commands.{m.name}"
        for m in pkgutil.iter_modules(app.commands.__path__)
        if not m.name.startswith("_")
    ]


EXIT_INTERNAL = 70


def build_parser() -> tuple[argparse.ArgumentParser, dict[str, object]]:
    parser = argparse.ArgumentParser(
        prog="brdf-studio",
        description="Explore, edit, sample and render with BRDFs (adaptive quadtree sampling, Montes 2008).",
    )
    parser.add_argument("--debug", action="store_true", help="show the full traceback of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    handlers: dict[str, object] = {}
    for name in _command_modules():
        module = importlib.import_module(name)
        for cmd in module.add_parser(sub):
            handlers[cmd] = module
    return parser, handlers


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser, handlers = build_parser()
    if argv and argv[0] not in handlers and not argv[0].startswith("-") and argv[0].endswith(".json"):
        argv = ["open", *argv]
    args = parser.parse_args(argv)
    if args.command is None:
        if "open" in handlers:
            args = parser.parse_args(["open"])
        else:
            parser.print_help()
            return 0
    try:
        return int(handlers[args.command].run(args) or 0)  # type: ignore[attr-defined]
    except BrdfStudioError as exc:
        print(f"brdf-studio {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("brdf-studio: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as exc:  # a bug, not bad input: say so plainly
        if args.debug or os.environ.get("BRDF_STUDIO_DEBUG"):
            traceback.print_exc()
        print(
            f"brdf-studio {args.command}: internal error: {type(exc).__name__}: {exc}\n"
            "(this is a bug; run with --debug for the traceback)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
