"""One honest line while numba compiles a command's kernels, which happens on a machine's first runs only.

numba compiles a kernel the first time a process calls it and none is in its disk cache (``make setup`` or
``brdf-studio setup`` compiles them all ahead of time); later runs load it in milliseconds. A command that
meets uncompiled kernels would otherwise sit silent, or show a progress bar whose rate and estimate count
the compile as work (``96 s/step``). :class:`CompileNotice` listens to numba's ``numba:compile`` event, which
fires only when a function is really compiled: at the first one it prints ``compiling kernels for this
machine (first run only) ...`` above any progress bar, and when the command ends, how long compiling took.
Nothing is printed when every kernel came from the cache.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from typing import Any, TextIO

START = "compiling kernels (once: later runs load them from the cache) ..."


class CompileNotice:
    """Prints :data:`START` at the first outermost compile and, at :meth:`close`, the compiling's seconds
    (summed over threads; a callee compiled inside its caller is counted once)."""

    def __init__(self, command: str, stream: TextIO | None = None) -> None:
        self.command = command
        self.stream = stream
        self.compiles = 0
        self.seconds = 0.0
        self._depth: dict[int, tuple[int, float]] = {}
        self._lock = threading.Lock()
        self._listener: Any = None

    def install(self) -> CompileNotice:
        from numba.core import event

        notice = self

        class Listener(event.Listener):
            def on_start(self, ev: Any) -> None:
                notice._start()

            def on_end(self, ev: Any) -> None:
                notice._end()

        self._listener = Listener()
        event.register("numba:compile", self._listener)
        return self

    def _say(self, text: str) -> None:
        from tqdm import tqdm

        with contextlib.suppress(OSError, ValueError):  # a closed or broken stderr: nothing to tell
            tqdm.write(f"brdf-studio {self.command}: {text}", file=self.stream or sys.stderr)

    def _start(self) -> None:
        tid = threading.get_ident()
        with self._lock:
            depth, start = self._depth.get(tid, (0, 0.0))
            first = depth == 0 and self.compiles == 0 and not any(d for d, _ in self._depth.values())
            self._depth[tid] = (depth + 1, time.monotonic() if depth == 0 else start)
        if first:
            self._say(START)

    def _end(self) -> None:
        tid = threading.get_ident()
        with self._lock:
            depth, start = self._depth.pop(tid, (1, time.monotonic()))
            if depth > 1:
                self._depth[tid] = (depth - 1, start)
                return
            self.compiles += 1
            self.seconds += time.monotonic() - start

    def close(self) -> None:
        """Stop listening; say how long compiling took, if anything was compiled."""
        if self._listener is not None:
            from numba.core import event

            event.unregister("numba:compile", self._listener)
            self._listener = None
        if self.compiles:
            s = "" if self.compiles == 1 else "s"
            self._say(
                f"compiled {self.compiles} kernel{s} in {self.seconds:.0f} s (cached: later runs load them)"
            )
