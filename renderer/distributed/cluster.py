"""The Dask cluster a render runs on: an existing scheduler, or a local cluster of worker processes.

:func:`connect` gives a :class:`RenderCluster` either way. A scheduler whose port does not take a connection
within :data:`REACH_TIMEOUT` seconds, or that does not answer as a scheduler within :data:`CONNECT_TIMEOUT`
seconds, is a :class:`ClusterError` (one line, naming the address). A local cluster's workers are
single-threaded processes with numba kept to one thread each, so that ``n`` workers use ``n`` cores and
nothing is oversubscribed; they ignore Ctrl-C (:mod:`renderer.distributed.local_worker`: the command that
started them decides what it does, and closes them). A worker of an existing cluster renders with as many
threads as Dask gives it (``dask worker --nthreads``). A daemonic process (the app's render process), which
cannot start processes through ``multiprocessing``, gets its local cluster in a process of its own
(:mod:`renderer.distributed.local_cluster`).

Nothing here imports Dask at module level: the imports are inside the functions.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import re
import select
import subprocess
import sys
from dataclasses import dataclass
from typing import Any

from core.errors import BrdfStudioError, ParameterError

REACH_TIMEOUT = 4.0
"""Seconds a TCP scheduler's host has to accept a connection (a refused port is refused at once)."""
CONNECT_TIMEOUT = 6.0
"""Seconds a scheduler that accepted the connection has to answer as a Dask scheduler."""
LOCAL_PRELOAD = "renderer.distributed.local_worker"
"""The module a local cluster's workers preload (:mod:`renderer.distributed.local_worker`)."""
START_TIMEOUT = 120.0
"""Seconds a local cluster started in a process of its own has to report its scheduler's address."""
SCHEMES = ("tcp", "tls", "inproc", "ucx", "ws", "wss")
"""The address schemes Dask's communications know."""
LOCAL_CONFIG = {
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.admin.tick.interval": "200ms",
    "distributed.worker.profile.enabled": False,
}
"""Dask settings of a local cluster (its scheduler, in this process, and its workers): what feeds a dashboard
that a render's cluster does not show, sampled less often. Dask's defaults (system monitor every 0.5 s, the
event loop's tick every 20 ms, the statistical profiler every 10 ms) cost the client's process and each
idle worker 0.06 CPU-seconds per second; with these, 0.02 and 0.01 (``bench/distributed_render.py``, and
``docs/results/distributed.md``)."""


class ClusterError(BrdfStudioError):
    """A scheduler that cannot be reached, a local cluster that cannot start, or a worker that cannot render
    (its message names the worker and what it could not do)."""


def check_address(address: str) -> str:
    """``address`` if it reads as a scheduler address (``tcp://host:port``, ``host:port``, another of
    :data:`SCHEMES`); otherwise a :class:`ParameterError` that shows the expected form."""
    text = address.strip()
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    hostport = re.fullmatch(r"(\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]]+):(\d{1,5})/?", rest)
    ok = scheme in SCHEMES and (scheme == "inproc" or (hostport is not None and 0 < int(hostport[2]) < 65536))
    if not ok:
        raise ParameterError(
            f"'{address}' is not a Dask scheduler address; expected tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786)"
        )
    return text if sep else f"tcp://{text}"


@dataclass(frozen=True)
class ClusterState:
    """What a progress line shows: the workers and their threads, and the render's tasks running on them
    and waiting."""

    address: str
    workers: int
    threads: int
    running: int = 0
    waiting: int = 0

    def describe(self) -> str:
        """``"tcp://10.0.0.5:8786: 4 workers, 8 threads, 6 tasks running, 2 waiting"``."""
        tasks = f"{self.running} tasks running" + (f", {self.waiting} waiting" if self.waiting else "")
        return f"{self.address}: {self.workers} workers, {self.threads} threads, {tasks}"


class RenderCluster:
    """A Dask client and, for a local cluster, the cluster it started (closed with it)."""

    def __init__(self, client: Any, local: Any = None, label: str = ""):
        self.client = client
        self.local = local
        self.address = str(client.scheduler.address)
        self.label = label or self.address
        self._sent: dict[str, Any] = {}
        """The futures of the bytes the last render sent, by digest (:meth:`scatter`)."""

    def scatter(self, data: dict[str, bytes]) -> dict[str, Any]:
        """Futures of ``data`` (bytes by their SHA-256) on the cluster, for a render's tasks: the bytes the
        previous render sent are not sent again; those it sent and this one does not are let go."""
        new = {d: raw for d, raw in data.items() if d not in self._sent}
        sent = self.client.scatter({f"bytes-{d}": raw for d, raw in new.items()}, hash=False) if new else {}
        self._sent = {d: sent[f"bytes-{d}"] if d in new else self._sent[d] for d in data}
        return dict(self._sent)

    def threads(self) -> dict[str, int]:
        """Threads per worker address, as the scheduler knows them now."""
        workers = self.client.scheduler_info(n_workers=-1).get("workers", {})
        return {addr: int(w.get("nthreads", 1)) for addr, w in workers.items()}

    def state(self, keys: set[str] | frozenset[str] = frozenset()) -> ClusterState:
        """The workers, and how many of ``keys`` (a render's tasks) are running on them or waiting."""
        threads = self.threads()
        running = 0
        if keys:
            processing = self.client.processing()
            running = sum(1 for ks in processing.values() for k in ks if str(k) in keys)
        return ClusterState(
            self.label, len(threads), sum(threads.values()), running, max(0, len(keys) - running)
        )

    def warm(self, strategies: tuple[str, ...] = ("adaptive_warp",)) -> dict[str, float]:
        """Load the renderer's kernels for ``strategies`` into every worker now (what a worker's first render
        would otherwise wait for); returns each worker's seconds."""
        return self.client.run(_load_kernels, strategies)

    def close(self) -> None:
        self.client.close()
        if self.local is not None:
            self.local.close()

    def __enter__(self) -> RenderCluster:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _check_scheduler(address: str, reach: float = REACH_TIMEOUT, answer: float = CONNECT_TIMEOUT) -> None:
    """A TCP scheduler checked before a client is made (a client retries a refused port until its timeout,
    and reads whatever another service answers as its messages): its port takes a connection within
    ``reach`` seconds and it answers Dask's ``identity`` as a scheduler within ``answer`` seconds; a
    :class:`ClusterError` naming the address and what failed otherwise."""
    import asyncio
    import socket
    from concurrent.futures import ThreadPoolExecutor

    scheme, _, rest = address.partition("://")
    if scheme not in ("tcp", "tls"):
        return
    host, _, port = rest.rstrip("/").rpartition(":")
    refused = f"cannot reach the Dask scheduler at '{address}'"
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=reach):
            pass
    except TimeoutError:
        raise ClusterError(f"{refused}: no answer within {reach:g} s") from None
    except OSError as exc:
        raise ClusterError(f"{refused}: {(exc.strerror or str(exc) or type(exc).__name__).lower()}") from None
    if scheme != "tcp":
        return  # TLS needs the client's security settings: Dask's client checks the rest

    async def identity() -> Any:
        from distributed.comm import connect as open_comm

        comm = await open_comm(address, timeout=answer)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:  # on a thread of its own: the caller may be running an event loop
        with ThreadPoolExecutor(1) as pool:
            reply = pool.submit(asyncio.run, asyncio.wait_for(identity(), answer)).result()
    except TimeoutError:
        raise ClusterError(f"{refused}: it did not answer as a Dask scheduler within {answer:g} s") from None
    except Exception:  # noqa: BLE001  (another protocol's bytes read as Dask's: anything can break)
        reply = None
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise ClusterError(
            f"{refused}: something answers there, but not a Dask scheduler (the dashboard's port, or another "
            "service's?)"
        )


def _load_kernels(strategies: tuple[str, ...]) -> float:
    from renderer.tracer_warmup import load_kernels

    return sum(seconds for _, seconds in load_kernels(strategies))


def connect(
    address: str | None = None, workers: int | None = None, timeout: float = CONNECT_TIMEOUT
) -> RenderCluster:
    """The scheduler at ``address``, or (without one) a new local cluster of ``workers`` processes (default
    2). Raises :class:`ClusterError` when the scheduler does not answer within ``timeout`` seconds or the
    local cluster cannot start.

    The client of a local cluster fetches the blocks' radiance from the workers directly: through the
    scheduler, which shares the client's process and event loop, every byte would be read and written once
    more there (docs/results/distributed.md). The client of a scheduler elsewhere keeps Dask's choice (the
    ``distributed.client.direct-to-workers`` setting; by default through the scheduler, which reaches workers
    a client may not)."""
    from dask.distributed import Client

    if address:
        address = check_address(address)
        _check_scheduler(address, answer=timeout)
        try:
            client = Client(address, timeout=f"{timeout}s", set_as_default=False)
        except (OSError, TimeoutError, ValueError, MemoryError) as exc:
            why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ClusterError(f"cannot reach the Dask scheduler at '{address}': {why}") from None
        return RenderCluster(client, label=address)
    n = 2 if workers is None else int(workers)
    if n < 1:
        raise ParameterError(f"a local cluster needs at least 1 worker, got {n}")
    if multiprocessing.current_process().daemon:
        # a daemonic process (the app's render process) cannot start worker processes of its own
        return _separate_local(n, timeout)
    local = start_local(n)
    client = Client(local, set_as_default=False, direct_to_workers=True)
    return RenderCluster(client, local, label=f"local cluster of {n}")


def start_local(n: int) -> Any:
    """A ``LocalCluster`` of ``n`` single-threaded worker processes that ignore Ctrl-C, numba on one thread
    each (a :class:`ClusterError` when it cannot start)."""
    import copy

    import dask
    from dask.distributed import LocalCluster

    saved = os.environ.get("NUMBA_NUM_THREADS")
    os.environ["NUMBA_NUM_THREADS"] = "1"  # the worker processes start with this environment
    try:
        with dask.config.set(LOCAL_CONFIG):  # the scheduler's, in this process
            # the workers': a copy of its own, which their nannies keep for every worker they (re)start (the
            # global configuration's nested dictionaries return to their values when the block ends)
            return LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
                preload=[LOCAL_PRELOAD],  # a Ctrl-C in the terminal is the command's: the workers ignore it
                config=copy.deepcopy(dask.config.config),
            )
    except (OSError, TimeoutError, RuntimeError, AssertionError) as exc:
        raise ClusterError(f"cannot start a local Dask cluster of {n} workers: {exc}") from None
    finally:
        if saved is None:
            os.environ.pop("NUMBA_NUM_THREADS", None)
        else:
            os.environ["NUMBA_NUM_THREADS"] = saved


class _LocalProcess:
    """A local cluster in a process of its own (:mod:`renderer.distributed.local_cluster`), ended with it."""

    def __init__(self, proc: subprocess.Popen[bytes]):
        self.proc = proc

    def close(self, timeout: float = 10.0) -> None:
        with contextlib.suppress(OSError):
            if self.proc.stdin is not None:
                self.proc.stdin.close()  # its signal to close the cluster and end
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout)


def _separate_local(n: int, timeout: float) -> RenderCluster:
    """A local cluster of ``n`` workers started in a process of its own (which ends when this process
    closes it or goes away), and a client of it."""
    from dask.distributed import Client

    proc = subprocess.Popen(
        [sys.executable, "-m", "renderer.distributed.local_cluster", str(n)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
    )
    assert proc.stdout is not None
    line = b""
    ready, _, _ = select.select([proc.stdout], [], [], START_TIMEOUT)
    if ready:
        line = proc.stdout.readline()
    address = line.decode(errors="replace").strip()
    if not address.startswith("tcp://"):
        _LocalProcess(proc).close(timeout=2.0)
        why = address or f"no scheduler address within {START_TIMEOUT:g} s"
        raise ClusterError(f"cannot start a local Dask cluster of {n} workers: {why}")
    try:
        client = Client(address, timeout=f"{timeout}s", set_as_default=False, direct_to_workers=True)
    except (OSError, TimeoutError) as exc:
        _LocalProcess(proc).close(timeout=2.0)
        raise ClusterError(f"cannot start a local Dask cluster of {n} workers: {exc}") from None
    return RenderCluster(client, _LocalProcess(proc), label=f"local cluster of {n}")
