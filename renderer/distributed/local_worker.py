"""The preload of a local cluster's workers (:func:`renderer.distributed.connect` with ``workers=N``).

A local cluster's worker processes are the command's helpers and share its terminal: a Ctrl-C reaches them
as it reaches the command. The command decides what a Ctrl-C does (it saves the passes done,
``app.commands.render``), so a worker ignores it; the command closes the cluster, which ends the workers.
"""

from __future__ import annotations

import signal
import threading
from typing import Any


def ignore_interrupts() -> None:
    """SIGINT ignored in this process (from its main thread; elsewhere nothing can be done)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def dask_setup(worker: Any) -> None:
    """Dask's preload hook: called in the worker process as the worker starts."""
    ignore_interrupts()
