"""The ``brdf-studio`` command: subcommands for the library, the renderer and the desktop app.

Each subcommand lives in its own module under ``app/commands/`` with two functions,
``add_parser(subparsers) -> list[str]`` (the command names it adds) and ``run(args) -> int``; modules are found
by name, so adding a command is adding a file. Errors a user can cause (``BrdfStudioError``, and bad
arguments, checked as they are parsed by the types of ``app/commands/_args.py``) print one clear line and exit
with code 2; nothing the user does shows a traceback. Ctrl-C exits with 130 (a render first saves what it
rendered); whatever an interrupt breaks on its way out is reported as the interrupt, not as a bug.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
import traceback
import warnings
from collections.abc import Iterator, Sequence

from app.commands import _signals as signals
from app.commands._args import OneLineParser
from app.commands._signals import recorded

# Nothing here imports core (numba) at module level: a Ctrl-C during those imports, in main(), is an interrupt.


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
    parser = OneLineParser(
        prog="brdf-studio",
        description="Explore, edit, sample and render with BRDFs (adaptive quadtree sampling, Montes 2008).",
    )
    parser.add_argument("--debug", action="store_true", help="show the full traceback of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    parser.commands = sub.choices  # type: ignore[attr-defined]
    handlers: dict[str, object] = {}
    for name in _command_modules():
        module = importlib.import_module(name)
        for cmd in module.add_parser(sub):
            handlers[cmd] = module
    return parser, handlers


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; the exit code (0, 1 for a failed check, 2 for bad input, 130/143 interrupted)."""
    with recorded():
        try:
            return _main(list(sys.argv[1:] if argv is None else argv))
        except KeyboardInterrupt:  # while the commands were imported or the arguments parsed
            print("brdf-studio: interrupted", file=sys.stderr)
            return signals.STATE.exit_code


def _main(argv: list[str]) -> int:
    parser, handlers = build_parser()
    if argv and argv[0] not in handlers and not argv[0].startswith("-") and argv[0].endswith(".json"):
        argv = ["open", *argv]
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:  # named by the command's own parser: "brdf-studio eval: error: unrecognized arguments: ..."
            command = parser.commands.get(args.command, parser)  # type: ignore[attr-defined]
            command.error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # a bad argument (one line printed) or --help: the same code in-process
        return exc.code if isinstance(exc.code, int) else 2
    if args.command is None:
        if "open" in handlers:
            args = parser.parse_args(["open"])
        else:
            parser.print_help()
            return 0
    return _run(handlers[args.command], args)


@contextlib.contextmanager
def _notices(command: str) -> Iterator[None]:
    """Print each :class:`~core.errors.FormerSamplerName` notice (a former sampler name, and the current
    one to use) as one ``notice:`` line on stderr, once per message; other warnings as usual."""
    from core.errors import FormerSamplerName

    shown = warnings.showwarning
    printed: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None):  # noqa: ANN001, ANN202
        if not issubclass(category, FormerSamplerName):
            return shown(message, category, filename, lineno, file, line)
        if str(message) not in printed:
            printed.add(str(message))
            print(f"brdf-studio {command}: notice: {message}", file=sys.stderr)
        return None

    with warnings.catch_warnings():
        warnings.simplefilter("always", FormerSamplerName)
        warnings.showwarning = show
        yield


def _run(handler: object, args: argparse.Namespace) -> int:
    from app.commands._args import check_environment
    from core.errors import BrdfStudioError

    notice = None
    try:
        check_environment()
        if args.command not in ("open", "setup") and not getattr(args, "quiet", False):
            from app.commands._compile_notice import CompileNotice

            notice = CompileNotice(args.command)
            notice.install()
        with _notices(args.command):
            return int(handler.run(args) or 0)  # type: ignore[attr-defined]
    except BrdfStudioError as exc:
        text = "; ".join(line for line in str(exc).splitlines() if line.strip())  # one line, always
        print(f"brdf-studio {args.command}: error: {text}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"brdf-studio {args.command}: interrupted", file=sys.stderr)
        return signals.STATE.exit_code
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except RecursionError:
        print(f"brdf-studio {args.command}: error: the input is nested too deeply to read", file=sys.stderr)
        return 2
    except MemoryError:  # a budget estimate fell short: still the user's request, not a crash
        print(
            f"brdf-studio {args.command}: error: not enough memory for this request; ask for less "
            "(fewer samples, a smaller image)",
            file=sys.stderr,
        )
        return 2
    except Exception as exc:
        if signals.STATE.seen:
            print(f"brdf-studio {args.command}: interrupted", file=sys.stderr)
            return signals.STATE.exit_code
        # a bug, not bad input: say so plainly
        if args.debug or os.environ.get("BRDF_STUDIO_DEBUG"):
            traceback.print_exc()
        print(
            f"brdf-studio {args.command}: internal error: {type(exc).__name__}: {exc}\n"
            "(this is a bug; run with --debug for the traceback)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL
    finally:
        if notice is not None:
            notice.close()


if __name__ == "__main__":
    sys.exit(main())
