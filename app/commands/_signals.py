"""Ctrl-C and SIGTERM on the command line: recorded, and cooperative where there is work to save.

By default Ctrl-C raises ``KeyboardInterrupt`` at once (nothing is lost: every output is written atomically)
and is *recorded*, so that an error it causes on its way out (an import cut in half, a thread join refused) is
reported as the interrupt (exit 130), never as an internal error. While a render is prepared, :func:`deferred`
holds the first signal until a safe point (the next preparation step; numba's cache is loaded through ctypes
callbacks, where an exception would only be printed). While its passes run, :func:`cooperative` turns the
first Ctrl-C (or SIGTERM) into a request: the pass in flight finishes, what was rendered is saved, and the
command exits with 130 (143 for SIGTERM). A second Ctrl-C stops at once in either.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any


@dataclass
class Interrupts:
    """What arrived during this command: ``seen`` any SIGINT/SIGTERM; ``signum`` the first."""

    seen: bool = False
    signum: int = 0
    count: int = 0
    stop: threading.Event = field(default_factory=threading.Event)
    """Set by the first signal while a :func:`cooperative` block runs: finish the pass, then stop."""
    saving: bool = False
    """True inside a :func:`cooperative` block."""
    deferring: bool = False
    """True inside a :func:`deferred` block."""
    installed: bool = False
    """True while :func:`recorded` has its handler installed."""

    @property
    def exit_code(self) -> int:
        return 128 + (self.signum or signal.SIGINT)


STATE = Interrupts()


def _handler(signum: int, frame: Any) -> None:
    STATE.seen = True
    STATE.count += 1
    STATE.signum = STATE.signum or signum
    STATE.stop.set()  # also when the exception below is swallowed (raised inside a __del__, it only prints)
    if (STATE.saving or STATE.deferring) and STATE.count == 1:
        return
    raise KeyboardInterrupt


def check() -> None:
    """Raise ``KeyboardInterrupt`` if a signal arrived whose exception was lost: one raised while a finalizer
    (``__del__``, a weakref callback) ran is printed and dropped by Python, so long commands call this at their
    checkpoints (between preparation steps, before the passes)."""
    reinstall()
    if STATE.seen:
        raise KeyboardInterrupt


def reinstall() -> None:
    """Put the handler back: a native library may have put its own in Python's place (LLVM, which numba
    loads, installs one for SIGINT that ends the process). Called at every checkpoint and after every pass."""
    if STATE.installed and threading.current_thread() is threading.main_thread():
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, _handler)


@contextmanager
def recorded() -> Iterator[Interrupts]:
    """Install the handler (SIGINT; SIGTERM too) for the duration of a command; a fresh :data:`STATE`."""
    global STATE
    STATE = Interrupts()
    if threading.current_thread() is not threading.main_thread():
        yield STATE
        return
    previous = {s: signal.signal(s, _handler) for s in (signal.SIGINT, signal.SIGTERM)}
    STATE.installed = True
    try:
        yield STATE
    finally:
        STATE.installed = False
        for s, h in previous.items():
            signal.signal(s, h)


@contextmanager
def deferred() -> Iterator[None]:
    """Within this block the first signal is only recorded; :func:`check` raises it at the block's safe
    points. For work that runs native code calling back into Python (numba loading its cache through llvmlite's
    ctypes callbacks): an exception raised there is printed as "Exception ignored" and dropped."""
    STATE.deferring = True
    try:
        yield
    finally:
        STATE.deferring = False
    check()


@contextmanager
def cooperative() -> Iterator[threading.Event]:
    """Within this block the first signal sets the returned event instead of raising."""
    STATE.saving = True
    try:
        yield STATE.stop
    finally:
        STATE.saving = False
