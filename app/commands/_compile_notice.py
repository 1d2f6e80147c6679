"""One honest line while numba compiles a command's kernels, which happens only when they are not cached yet.

numba compiles a kernel the first time a process calls it and none is in its disk cache (``make setup`` or
``brdf-studio setup`` compiles them all ahead of time); later runs load it in milliseconds. A command that
meets uncompiled kernels would otherwise sit silent, or show a progress bar whose rate and estimate count
the compile as work. :class:`CompileNotice` is the app's :class:`~app.render_session.NumbaClock` (numba's
``numba:compile`` event fires only when a function is really compiled) that also speaks: at the first
compile it prints :data:`START` above any progress bar, and when the command ends, how long compiling took.
Nothing is printed when every kernel came from the cache.
"""

from __future__ import annotations

import contextlib
import sys
from typing import TextIO

from app.render_session import NumbaClock

START = "compiling kernels (once: later runs load them from the cache) ..."
COMPILE = "numba:compile"


class CompileNotice(NumbaClock):
    """Prints :data:`START` at the first outermost compile and, at :meth:`close`, the compiling's seconds
    (summed over threads; a callee compiled inside its caller is counted once)."""

    def __init__(self, command: str, stream: TextIO | None = None) -> None:
        super().__init__()
        self.command = command
        self.stream = stream

    @property
    def seconds(self) -> float:
        return self.compile_s

    def _say(self, text: str) -> None:
        from tqdm import tqdm

        with contextlib.suppress(OSError, ValueError):  # a closed or broken stderr: nothing to tell
            tqdm.write(f"brdf-studio {self.command}: {text}", file=self.stream or sys.stderr)

    def _start(self, kind: str) -> None:
        with self._lock:
            first = kind == COMPILE and self.compiles == 0 and not any(k == COMPILE for k, _ in self._open)
        super()._start(kind)
        if first:
            self._say(START)

    def close(self) -> None:
        """Stop listening; say how long compiling took, if anything was compiled."""
        self.uninstall()
        if self.compiles:
            s = "" if self.compiles == 1 else "s"
            self._say(
                f"compiled {self.compiles} kernel{s} in {self.compile_s:.0f} s (cached: later runs load them)"
            )
