"""The sampler view's snapshots (:func:`app.sampling_data.sampling_snapshot`) computed in a separate process.

Why: a snapshot builds an adaptive tree, draws samples and a ratio map. Most of that is compiled code that
releases the interpreter lock, but its numpy glue does not, and neither do the VTK and matplotlib calls
that draw the lobe and the slice on the GUI thread at the same moment: in a thread of the GUI process the
two would take turns on the lock, and a 25 ms snapshot would take 45-70 ms and slow the lobe's redraw too.
In a process of its own it runs beside the GUI at full speed; the worker thread that asks for it waits on a
pipe, which releases the lock.

The process is started once ('spawn', safe with Qt), lazily or by :func:`prewarm`, and kept for the app's
lifetime, so kernels and trees built in it stay in its memory (and on disk, in the table cache both processes
share). It receives a *spec* of the material (model name and parameter values, or the measured file's path;
for a model file, also the text the app uses, :mod:`app.model_library`), not the BRDF object: measured
tables are large, and the child rebuilds and keeps the few BRDFs it was asked about. Errors raised in it
(:class:`core.errors.BrdfStudioError`) come back as themselves; if the process dies, the next request starts
a new one (once per request); if the app dies, the process ends by itself.

The process does one request at a time. The table's facts wait in it for a background build of the full
table (the app's sampler view does not: it asks again a moment later). A new value of a slider drag must
not queue behind such a wait: :func:`interrupt` (called by the app when it asks for a new material or
direction) bumps a counter shared with the process, and a wait begun under an older count gives up at once. The
process also runs the background builds at a lower priority (:data:`BUILD_NICENESS`) and stops the build
of a value the view no longer shows (:func:`core.sampling.adaptive.sampler.drop_builds`), so that the new
value's coarse table gets the cores.
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

from app import child_process
from core.errors import BrdfStudioError

Spec = tuple[str, str | None, tuple, str | None]
"""``(model name, measured file or None, sorted parameter items, text of the model file or None)``: what the
child needs to rebuild a BRDF. A model file's text is the version the app uses (a saved edit is a new spec;
a broken one never reaches the child)."""

_POOL: ProcessPoolExecutor | None = None
_LOCK = threading.Lock()
_BRDFS: dict[Spec, Any] = {}
"""In the child: the BRDFs asked about, by spec (a few; their samplers' trees are cached by the library)."""
_KEEP = 8
PARENT_POLL_S = 0.5
BUILD_NICENESS = 10
"""The niceness of the full tables' background builds in the process (the coarse table the view waits
for, and the GUI, come first)."""
_GENERATION: Any = None
"""A ``multiprocessing.Value`` shared with the process: the count of :func:`interrupt` calls."""


def spec_of(model: str, measured: str | None, params: dict) -> Spec:
    """The spec of a material; colours read from a project file are lists, made tuples (a spec is a key)."""
    from core.model_files import is_model_file, pinned_text

    items = ((k, tuple(v) if isinstance(v, list | tuple) else v) for k, v in params.items())
    text = pinned_text(model) if model and is_model_file(model) else None
    return (model, measured, tuple(sorted(items)), text)


def _pool() -> ProcessPoolExecutor:
    global _POOL, _GENERATION
    with _LOCK:
        if _POOL is None:
            context = multiprocessing.get_context("spawn")
            _GENERATION = context.Value("q", 0, lock=False)
            _POOL = ProcessPoolExecutor(
                max_workers=1,
                mp_context=context,
                initializer=child_process.initialize,  # SIGINT ignored first (app.child_process)
                initargs=(f"{__name__}:{_start_child.__name__}", os.getpid(), _GENERATION),
            )
        return _POOL


def generation() -> int:
    """The current count of :func:`interrupt` calls: a request made now carries it."""
    _pool()
    return int(_GENERATION.value)


def interrupt() -> None:
    """Make the process's waits (and albedo quadratures) begun by earlier requests give up: a newer request
    is on its way. Nothing to do before the process is started."""
    if _GENERATION is not None:
        _GENERATION.value += 1  # (only the GUI thread writes it)


def _start_child(parent: int, shared: Any) -> None:
    global _GENERATION
    _GENERATION = shared
    from core.sampling.adaptive.sampler import lower_build_priority

    lower_build_priority(BUILD_NICENESS)
    _watch_parent(parent)


def _superseded(asked_at: int | None) -> Any:
    """In the child: ``stop`` for a wait of a request made at count ``asked_at`` (None: never stops)."""
    if asked_at is None:
        return None
    return lambda: _GENERATION.value != asked_at


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
        model, measured, params, text = spec
        if measured:
            from core.merl import measured_brdf

            hit = measured_brdf(measured)
        elif text is not None:
            from core.model_files import load_model_file

            hit = load_model_file(model, text).bind(dict(params))
        else:
            from core.brdf import get_model

            hit = get_model(model).bind(dict(params))
        if len(_BRDFS) >= _KEEP:
            _BRDFS.pop(next(iter(_BRDFS)))
        _BRDFS[spec] = hit
    return hit


def _snapshot_here(spec: Spec, theta_deg: float, phi_deg: float, options: dict, asked_at: int | None) -> Any:
    from app.sampling_data import NoSnapshot, sampling_snapshot

    try:
        return sampling_snapshot(_brdf(spec), theta_deg, phi_deg, stop=_superseded(asked_at), **options)
    except NoSnapshot:
        return None


def _facts_here(spec: Spec, asked_at: int | None) -> str | None:
    from app.sampling_data import adaptive_line

    return adaptive_line(_brdf(spec), stop=_superseded(asked_at))


def _albedo_here(spec: Spec, thetas_deg: tuple[float, ...], asked_at: int | None) -> Any:
    from app.view_data import directional_albedo

    return directional_albedo(_brdf(spec), list(thetas_deg), stop=_superseded(asked_at))


def _call(fn: Any, *args: Any) -> Any:
    """``fn(*args)`` in the process; blocks the calling (worker) thread until the result arrives, without
    holding the interpreter lock."""
    for _ in range(2):
        try:
            return _pool().submit(fn, *args).result()
        except BrokenProcessPool:
            shutdown()  # it died (killed, out of memory): the next attempt starts a new one
    raise BrdfStudioError("the sampler view's process stopped twice in a row; see the terminal for its error")


def table_facts(spec: Spec, asked_at: int | None = None) -> str | None:
    """:func:`app.sampling_data.adaptive_line` of the material ``spec`` (its adaptive table's size and build time),
    made in the snapshot process: the table is built once there, for the sampler view and these facts, and
    its build never holds the GUI's interpreter lock. ``asked_at``: the :func:`generation` when the app
    asked; a wait for the table's build gives up when a later :func:`interrupt` came, and None is
    returned (ask again later)."""
    return _call(_facts_here, spec, asked_at)


def albedo(spec: Spec, thetas_deg: tuple[float, ...], asked_at: int | None = None) -> Any:
    """:func:`app.view_data.directional_albedo` of the material ``spec`` at ``thetas_deg`` (0.1-0.3 s of
    quadrature, kept out of the GUI process's interpreter), or None when a later :func:`interrupt` came
    before it was done (ask again later)."""
    return _call(_albedo_here, spec, tuple(thetas_deg), asked_at)


def _ready() -> bool:
    return True


def prewarm() -> None:
    """Start the process now (its start-up, ~1-2 s of imports, then overlaps the window's own)."""
    _pool().submit(_ready)


def snapshot(
    spec: Spec, theta_deg: float, phi_deg: float, asked_at: int | None = None, **options: Any
) -> Any:
    """:func:`app.sampling_data.sampling_snapshot` of the material ``spec``, computed in the snapshot process.
    Blocks the calling (worker) thread until the result arrives, without holding the interpreter lock.
    ``asked_at``: see :func:`table_facts`. None when no picture was made (:class:`app.sampling_data.NoSnapshot`:
    a newer request is on its way, or ``only_complete`` and the full table is not made yet)."""
    return _call(_snapshot_here, spec, theta_deg, phi_deg, options, asked_at)
