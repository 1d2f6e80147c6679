"""The app's helper processes (the render process, the snapshot process) leave Ctrl-C to the app.

Ctrl-C in a terminal sends SIGINT to the whole foreground process group: the app and the processes it started.
The app ends on it, its edits autosaved (:mod:`app.signal_watcher`); a helper process ends by itself when the
app has gone (it watches its pipe or its parent). With Python's default handler a helper would instead raise
``KeyboardInterrupt`` wherever it waits and print a traceback beside the app's one line. So a helper ignores
SIGINT from the first code of the app it runs: :func:`run` and :func:`initialize` take their target by name,
``"module:function"``, and import it only once SIGINT is ignored (importing a module of the renderer or the
samplers takes seconds). What runs before that is Python's own start and multiprocessing's (a fraction of a
second, once per helper, at its start).

This module imports nothing but the standard library: it is the first module of the app a helper loads.
"""

from __future__ import annotations

import importlib
import signal
from collections.abc import Callable
from typing import Any


def _resolve(target: str) -> Callable[..., Any]:
    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name)


def run(target: str, *args: Any) -> Any:
    """A process's target: SIGINT ignored, then ``target(*args)`` (``target`` as ``"module:function"``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    return _resolve(target)(*args)


def initialize(target: str, *args: Any) -> None:
    """A process pool's initializer: SIGINT ignored, then ``target(*args)``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _resolve(target)(*args)
