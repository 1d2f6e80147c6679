"""The argument types and forms every command shares: one validation layer for the command line.

Every value is checked as it is parsed, against a stated range, and a bad one is one line naming the option,
the range and what was given (``brdf-studio render: error: argument --spp: must be a whole number in
[1, 1e+06], got '1e20'``), exit code 2, before any work starts.

Forms (the same in every command):

- a number: ``30``, ``1e6``, ``0.5``; a whole number may be written ``1e6`` but must be whole;
  ``nan`` and ``inf`` are never accepted;
- a list (``--theta``, ``--n-max``, ``--compare``, ``--models``, ``--samplers``, ``--param``,
  ``--material``, ``--measured``): values after the option, separated by spaces, and the option may be
  repeated: ``--theta 0 30 60`` and ``--theta 0 --theta 30 60`` are the same. Lists of numbers and of
  registered names may also be separated by commas (``--theta 0,30,60``, ``--compare uniform,adaptive_exact``);
  values that may hold commas themselves (``--param kd=0.2,0.5,0.8``, material names, file names) are not
  split.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

MAX_SEED = 2**32 - 1
MAX_SPP = 1_000_000
"""Samples per pixel one render may ask for (a Mitsuba reference takes a few thousand)."""
MAX_SECONDS = 7 * 24 * 3600.0
"""The longest time budget, one week; ``--until-cancelled`` renders until Ctrl-C instead."""
MAX_SIDE = 16384
"""Image width and height, as in the scene file's schema."""
MAX_DEPTH = 1000
"""Bounces, as in the scene file's schema."""
MAX_EXPOSURE = 64.0
"""Stops either way (2^64 is beyond any radiance a float32 image holds)."""


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser, with its errors as one line (the usage is one ``--help`` away); a number starting
    with '-' (``-inf``, ``-1e5``) is a value, never taken for an option."""

    def _parse_optional(self, arg_string: str) -> Any:
        # argparse takes an argument starting with '-' for an option unless it looks like -1 or -.5, so that
        # "--theta -inf" ended in "expected one argument"; a number of any form is a value, which the
        # option's type then checks ("must be a finite number in [0, 90], got '-inf'").
        if arg_string.startswith("-") and _is_number(arg_string):
            return None
        return super()._parse_optional(arg_string)

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: error: {message} (see '{self.prog} --help')", file=sys.stderr)
        sys.exit(2)


def _fmt(x: float) -> str:
    """``30``, ``0.5``, ``1e15`` (a power of ten as a user would type it), ``4294967295``."""
    if x == int(x) and abs(x) >= 1e6:
        exp = len(str(int(abs(x)))) - 1
        if abs(x) == 10**exp:
            return f"{'-' if x < 0 else ''}1e{exp}"
        return str(int(x))
    return f"{x:g}"


def number(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False) -> Callable[[str], float]:
    """A finite number within ``[lo, hi]`` (brackets per ``lo_open``/``hi_open``)."""
    text = f"{'(' if lo_open else '['}{_fmt(lo)}, {_fmt(hi)}{')' if hi_open else ']'}"

    def parse(value: str) -> float:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"must be a number in {text}, got {value!r}") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"must be a finite number in {text}, got {value!r}")
        if not ((v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)):
            raise argparse.ArgumentTypeError(f"must be a number in {text}, got {value!r}")
        return v

    parse.__name__ = "number"
    return parse


def whole(lo: int, hi: int) -> Callable[[str], int]:
    """A whole number within ``[lo, hi]``; ``1e6`` is read as 1000000, ``2.5`` is refused."""
    text = f"[{_fmt(lo)}, {_fmt(hi)}]"

    def parse(value: str) -> int:
        s = str(value).strip().replace("_", "")
        try:
            v = int(s)
        except ValueError:
            try:
                f = float(s)
            except ValueError:
                raise argparse.ArgumentTypeError(f"must be a whole number in {text}, got {value!r}") from None
            if not math.isfinite(f) or f != math.floor(f):
                raise argparse.ArgumentTypeError(f"must be a whole number in {text}, got {value!r}") from None
            v = int(f)
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"must be a whole number in {text}, got {value!r}")
        return v

    parse.__name__ = "whole number"
    return parse


def name(value: str) -> str:
    """A non-empty name (a model, a sampler, a material)."""
    v = str(value).strip()
    if not v:
        raise argparse.ArgumentTypeError("must not be empty")
    return v


theta = number(0.0, 90.0)
"""An outgoing polar angle in degrees."""
azimuth = number(-360.0, 360.0)
seed = whole(0, MAX_SEED)
exposure = number(-MAX_EXPOSURE, MAX_EXPOSURE)


class ListAction(argparse.Action):
    """``nargs="+"`` that also splits each value on commas and extends over repeated uses."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        items = list(getattr(namespace, self.dest, None) or [])
        convert = getattr(self, "item_type", None) or (lambda v: v)
        split = getattr(self, "split_commas", True)
        for raw in [values] if isinstance(values, str) else list(values or []):
            parts = [p.strip() for p in str(raw).split(",")] if split else [str(raw).strip()]
            if not any(parts):
                parser.error(f"argument {option_string}: lists no value, got {raw!r}")
            for p in parts:
                if not p:
                    continue
                try:
                    items.append(convert(p))
                except argparse.ArgumentTypeError as exc:
                    parser.error(f"argument {option_string}: {exc}")
        setattr(namespace, self.dest, items)


def add_list(
    p: argparse.ArgumentParser | argparse._ArgumentGroup,
    *flags: str,
    item: Callable[[str], Any] = name,
    split: bool = True,
    **kw: Any,
) -> argparse.Action:
    """A list option in the one form every command uses (see the module docstring); ``split=False`` for
    values that may hold commas."""
    action = p.add_argument(*flags, nargs=kw.pop("nargs", "+"), action=ListAction, **kw)
    action.item_type = item  # type: ignore[attr-defined]
    action.split_commas = split  # type: ignore[attr-defined]
    return action


def output_stem(path: str | Path, extensions: Sequence[str]) -> Path:
    """``path`` without its extension if it is one of ``extensions`` (case-insensitive), else unchanged:
    ``out_t1.1.exr -> out_t1.1``, ``shot.final -> shot.final``. Only a known extension is ever removed."""
    p = Path(path)
    if p.suffix.lower() in {e.lower() for e in extensions}:
        return p.with_name(p.name[: -len(p.suffix)])
    return p


def with_extension(stem: Path, ext: str) -> Path:
    """``stem`` + ``ext`` without :meth:`Path.with_suffix` (which would replace ``.1`` in ``out_t1.1``)."""
    return stem.with_name(stem.name + ext)


def check_output(path: str | Path) -> Path:
    """An output path that can be written: not a folder, in a folder that exists and takes new files (checked
    before any work, so a long computation does not end on an unwritable name); :class:`~core.errors.OutputError`
    otherwise."""
    from core.errors import OutputError

    p = Path(path)
    if not str(path).strip():
        raise OutputError("the output needs a file name")
    if p.is_dir():
        raise OutputError(f"cannot write '{p}': it is a folder")
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"cannot write '{p}': folder '{folder}' does not exist")
    try:  # a probe as the atomic write will do it: permissions, a read-only disk, /proc or /sys
        fd, probe = tempfile.mkstemp(prefix=f".{p.name[:64]}.", suffix=".probe", dir=folder)
    except OSError as exc:  # (/proc says "No such file or directory": no reason is better than that one)
        why = f" ({exc.strerror})" if exc.strerror and exc.errno != errno.ENOENT else ""
        raise OutputError(f"cannot write '{p}': folder '{folder}' is not writable{why}") from None
    os.close(fd)
    os.unlink(probe)
    return p


def check_environment() -> None:
    """The variables that configure every command, checked before one runs: ``BRDF_STUDIO_CACHE`` and
    ``BRDF_STUDIO_NUMBA_CACHE`` name folders that can be written, ``BRDF_STUDIO_EMBREE`` one of its backends.
    A bad one is a :class:`~core.errors.BrdfStudioError` naming the variable (one line, exit code 2)."""
    from core import _numba_cache, cache

    cache.check_environment()
    _numba_cache.check_environment()
    if os.environ.get("BRDF_STUDIO_EMBREE"):  # the renderer is imported only to check a value that is set
        from renderer.accel import backend_from_environment

        backend_from_environment()
