"""A local Dask cluster in a process of its own, for a process that cannot start worker processes itself (a
daemonic one: the app's render process). :func:`renderer.distributed.connect` starts it::

    python -m renderer.distributed.local_cluster N

It starts a local cluster of ``N`` workers (:func:`renderer.distributed.cluster.start_local`), prints its
scheduler's address on a line of its own, and closes the cluster and ends when its standard input closes:
when the process that started it closes it, or goes away. It ignores Ctrl-C, as its workers do.
"""

from __future__ import annotations

import sys

from renderer.distributed.cluster import ClusterError, start_local
from renderer.distributed.local_worker import ignore_interrupts


def main(argv: list[str] | None = None) -> int:
    ignore_interrupts()
    args = sys.argv[1:] if argv is None else argv
    try:
        cluster = start_local(int(args[0]))
    except (ClusterError, ValueError, IndexError) as exc:
        print(str(exc).splitlines()[0] if str(exc) else type(exc).__name__, flush=True)
        return 2
    try:
        print(cluster.scheduler_address, flush=True)
        sys.stdin.buffer.read()  # until end of file
    finally:
        cluster.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
