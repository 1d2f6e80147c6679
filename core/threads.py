"""How many threads this process may use for its own parallel work.

One budget for every pool in ``core`` and ``renderer``: numba's configured thread count, which follows
``NUMBA_NUM_THREADS`` and otherwise the machine's cores. A process started with ``NUMBA_NUM_THREADS=1`` (a
Dask worker of the folder study: one worker per core) must not start a pool of ``os.cpu_count()`` threads
beside it, or two workers on two cores run four threads and the second worker buys little (without this
budget the folder study's 1-worker baseline runs at 1.3 cores).
"""

from __future__ import annotations

import numba


def thread_budget(cap: int = 8) -> int:
    """Threads a pool of this process may start: numba's thread count, at most ``cap``, at least 1."""
    return max(1, min(cap, int(numba.config.NUMBA_NUM_THREADS)))
