"""The sampler view's snapshots (:func:`app.view_data.sampling_snapshot`) computed in a separate process.

Why: a snapshot builds an adaptive tree, draws samples and a ratio map. Most of that is compiled code that
releases the interpreter lock, but its numpy glue does not, and neither do the VTK and matplotlib calls
that draw the lobe and the slice on the GUI thread at the same moment: in a thread of the GUI process the
two took turns on the lock, and a 25 ms snapshot took 45-70 ms while the lobe's redraw slowed down too.
In a process of its own it runs beside the GUI at full speed; the worker thread that asks for it waits on a
pipe, which releases the lock.

The process is started once ('spawn', safe with Qt), lazily or by :func:`prewarm`, and kept for the app's
lifetime, so kernels and trees built in it stay in its memory (and on disk, in the table cache both processes
share). It receives a *spec* of the material (model name and parameter values, or the measured file's path),
not the BRDF object: measured tables are large, and the child rebuilds and keeps the few BRDFs it was asked
about. Errors raised in it (:class:`core.errors.BrdfStudioError`) come back as themselves; if the process
dies, the next request starts a new one (once per request); if the app dies, the process ends by itself.
"""

from __future__ import annotations

import atexit
import multiprocessing
import os
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from core.errors import BrdfStudioError

Spec = tuple[str, str | None, tuple]
"""``(model name, measured file or None, sorted parameter items)``: what the child needs to rebuild a BRDF."""

_POOL: ProcessPoolExecutor | None = None
_LOCK = threading.Lock()
_BRDFS: dict[Spec, Any] = {}
"""In the child: the BRDFs asked about, by spec (a few; their samplers' trees are cached by the library)."""
_KEEP = 8
PARENT_POLL_S = 0.5


def spec_of(model: str, measured: str | None, params: dict) -> Spec:
    """The spec of a material; colours read from a project file are lists, made tuples (a spec is a key)."""
    items = ((k, tuple(v) if isinstance(v, list | tuple) else v) for k, v in params.items())
    return (model, measured, tuple(sorted(items)))


def _pool() -> ProcessPoolExecutor:
    global _POOL
    with _LOCK:
        if _POOL is None:
            _POOL = ProcessPoolExecutor(
                max_workers=1,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=_watch_parent,
                initargs=(os.getpid(),),
            )
        return _POOL


def shutdown() -> None:
    """Stop the process (at exit; also after it died, so that the next request starts a new one)."""
    global _POOL
    with _LOCK:
        pool, _POOL = _POOL, None
    if pool is not None:
        pool.shutdown(wait=False, cancel_futures=True)


atexit.register(shutdown)


def _watch_parent(parent: int) -> None:
    """In the child: end when the app has gone away, even if it was killed (an idle worker would otherwise
    wait on its queue forever)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(0)

    threading.Thread(target=watch, name="watch-parent", daemon=True).start()


def _brdf(spec: Spec) -> Any:
    hit = _BRDFS.get(spec)
    if hit is None:
        model, measured, params = spec
        if measured:
            from core.merl import measured_brdf

            hit = measured_brdf(measured)
        else:
            from core.model import get_model

            hit = get_model(model).bind(dict(params))
        if len(_BRDFS) >= _KEEP:
            _BRDFS.pop(next(iter(_BRDFS)))
        _BRDFS[spec] = hit
    return hit


def _snapshot_here(spec: Spec, theta_deg: float, phi_deg: float, options: dict) -> dict:
    from app.view_data import sampling_snapshot

    return sampling_snapshot(_brdf(spec), theta_deg, phi_deg, **options)


def _facts_here(spec: Spec) -> str:
    from app.view_data import adaptive_line

    return adaptive_line(_brdf(spec))


def table_facts(spec: Spec) -> str:
    """:func:`app.view_data.adaptive_line` of the material ``spec`` (its adaptive table's size and build time),
    made in the snapshot process: the table is built once there, for the sampler view and these facts, and
    its build never holds the GUI's interpreter lock."""
    for _ in range(2):
        try:
            return _pool().submit(_facts_here, spec).result()
        except BrokenProcessPool:
            shutdown()
    raise BrdfStudioError("the sampler view's process stopped twice in a row; see the terminal for its error")


def _ready() -> bool:
    return True


def prewarm() -> None:
    """Start the process now (its start-up, ~1-2 s of imports, then overlaps the window's own)."""
    _pool().submit(_ready)


def snapshot(spec: Spec, theta_deg: float, phi_deg: float, **options: Any) -> dict:
    """:func:`app.view_data.sampling_snapshot` of the material ``spec``, computed in the snapshot process.
    Blocks the calling (worker) thread until the result arrives, without holding the interpreter lock."""
    for _ in range(2):
        try:
            return _pool().submit(_snapshot_here, spec, theta_deg, phi_deg, options).result()
        except BrokenProcessPool:
            shutdown()  # it died (killed, out of memory): the next attempt starts a new one
    raise BrdfStudioError("the sampler view's process stopped twice in a row; see the terminal for its error")
