"""Ray queries through Embree: batched closest-hit and occlusion, chunked over worker threads.

Two backends, the same answers (tested): ``"direct"`` calls the Embree library embreex ships from compiled
loops in packets of 16 (:mod:`renderer.embree`, the default); ``"embreex"`` goes through embreex's ``run``,
one ray at a time (used where the library cannot be loaded, or chosen with ``BRDF_STUDIO_EMBREE=embreex``).
Both leave ``tnear`` at 0, so callers offset secondary-ray origins off the surface, and both run without the
GIL, so chunks of one batch run in parallel on the worker threads.
"""

from __future__ import annotations

import contextlib
import os
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError
from renderer.embree import EmbreeScene, EmbreeUnavailable

MISS = -1
BACKEND_ENV = "BRDF_STUDIO_EMBREE"
BACKENDS = ("direct", "embreex")
DEFAULT_BACKEND = "embreex"
"""embreex's ``run``. ``direct`` (Embree's packet queries from compiled code) corrupts the heap now and then
in renders with two threads (a crash in ``malloc`` within a few renders of the demo, or arrays of the wrong
length reaching the samplers); its cause is not found, embreex's ``run`` has shown none in 34 such renders,
and the demo's pass times of the two were within noise. ``BRDF_STUDIO_EMBREE=direct`` chooses it."""
_THREAD_PREFIX = "embree-rays"
_FAR = np.float32(1e30)


def backend_from_environment() -> str:
    """The backend ``$BRDF_STUDIO_EMBREE`` chooses (:data:`DEFAULT_BACKEND` when unset); a value that is not
    one of :data:`BACKENDS` is a :class:`~core.errors.ParameterError` naming the variable and the choices."""
    backend = os.environ.get(BACKEND_ENV) or DEFAULT_BACKEND
    if backend not in BACKENDS:
        raise ParameterError(
            f"{BACKEND_ENV}={backend!r}: expected one of {', '.join(BACKENDS)} (or leave it unset for {DEFAULT_BACKEND})"
        )
    return backend


@dataclass
class Hits:
    """Closest hits of a batch: ``t (n,)`` distance (inf on a miss), ``prim (n,)`` triangle index
    (``MISS`` = -1), and the barycentrics ``u, v (n,)`` of the hit (point = (1-u-v) p0 + u p1 + v p2)."""

    t: np.ndarray
    prim: np.ndarray
    u: np.ndarray
    v: np.ndarray


class Accel:
    """An Embree BVH over triangles ``vertices (n, 3)``, ``faces (m, 3)``; triangle ids are face rows."""

    def __init__(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        threads: int = 2,
        chunk: int = 32768,
        backend: str | None = None,
    ):
        backend = backend or backend_from_environment()
        if backend not in BACKENDS:
            raise ParameterError(f"backend {backend!r}: expected one of {', '.join(BACKENDS)}")
        self._direct: EmbreeScene | None = None
        if backend == "direct":
            try:
                self._direct = EmbreeScene(vertices, faces)
            except EmbreeUnavailable as e:
                warnings.warn(f"{e}; tracing through embreex's run instead", RuntimeWarning, stacklevel=2)
                backend = "embreex"
        if backend == "embreex":
            from embreex import rtcore_scene
            from embreex.mesh_construction import TriangleMesh

            self._scene = rtcore_scene.EmbreeScene()
            self._mesh = TriangleMesh(
                self._scene,
                np.ascontiguousarray(vertices, dtype=np.float32),
                np.ascontiguousarray(faces, dtype=np.int32),
            )
        self.backend = backend
        self.threads = max(1, int(threads))
        self.chunk = int(chunk)
        self._pool = (
            ThreadPoolExecutor(self.threads, thread_name_prefix=_THREAD_PREFIX) if self.threads > 1 else None
        )

    def close(self) -> None:
        """Stop the worker threads (waiting for them, unless called from one of them)."""
        pool, self._pool = getattr(self, "_pool", None), None
        if pool is not None:
            pool.shutdown(wait=not threading.current_thread().name.startswith(_THREAD_PREFIX))

    def __del__(self) -> None:
        # The collector may run this on any thread, a worker of this very pool included, and at interpreter
        # exit or during a Ctrl-C: never join there ("cannot join current thread"), never raise.
        pool, self._pool = getattr(self, "_pool", None), None
        if pool is not None:
            with contextlib.suppress(Exception):
                pool.shutdown(wait=False)

    def _chunks(self, n: int) -> list[slice]:
        size = max(1024, min(self.chunk, -(-n // self.threads)))
        return [slice(i, min(n, i + size)) for i in range(0, n, size)]

    def _map(self, fn, n: int, parallel: bool = True) -> None:  # type: ignore[no-untyped-def]
        if not parallel:
            fn(slice(0, n))
            return
        chunks = self._chunks(n)
        if self._pool is None or len(chunks) == 1:
            for s in chunks:
                fn(s)
        else:
            list(self._pool.map(fn, chunks))

    def intersect(self, origins: np.ndarray, directions: np.ndarray) -> Hits:
        """Closest hit for each ray ``origins (n, 3)``, ``directions (n, 3)`` (unit length)."""
        n = len(origins)
        o = np.ascontiguousarray(origins, dtype=np.float32)
        d = np.ascontiguousarray(directions, dtype=np.float32)
        prim32 = np.empty(n, dtype=np.int32)
        t32, u32, v32 = (np.empty(n, dtype=np.float32) for _ in range(3))
        if n:
            self.trace(o, d, prim32, t32, u32, v32)
        return Hits(
            t32.astype(np.float64), prim32.astype(np.int64), u32.astype(np.float64), v32.astype(np.float64)
        )

    def trace(
        self,
        o32: np.ndarray,
        d32: np.ndarray,
        prim: np.ndarray,
        t: np.ndarray,
        u: np.ndarray,
        v: np.ndarray,
        parallel: bool = True,
    ) -> None:
        """Closest hits of the rays ``o32, d32 (n, 3)`` float32 (C order, unit directions) written into
        ``prim (n,)`` int32 (``MISS`` on a miss), ``t`` float32 (inf on a miss) and the barycentrics ``u, v``
        float32: the wavefront's query, with no conversion of its inputs. ``parallel=False`` traces on the
        calling thread in one call (a caller that runs its own threads)."""
        n = len(o32)
        direct = self._direct
        if direct is not None:
            if n:
                self._map(lambda s: direct.trace(o32[s], d32[s], prim[s], t[s], u[s], v[s]), n, parallel)
            return

        def run(s: slice) -> None:
            ts = t[s]
            ts.fill(np.inf)  # Embree's far limit: left as it is on a miss, the distance on a hit
            r = self._scene.run(o32[s], d32[s], dists=ts, output=1)
            prim[s] = r["primID"]  # MISS (-1) on a miss
            u[s] = r["u"]
            v[s] = r["v"]

        if n:
            self._map(run, n, parallel)

    def occluded(
        self,
        origins: np.ndarray,
        directions: np.ndarray,
        t_max: np.ndarray | None = None,
        parallel: bool = True,
    ) -> np.ndarray:
        """``(n,)`` bool: True where something lies on the ray before ``t_max`` (default: infinity);
        ``parallel=False`` on the calling thread in one call."""
        n = len(origins)
        o = np.ascontiguousarray(origins, dtype=np.float32)
        d = np.ascontiguousarray(directions, dtype=np.float32)
        if t_max is None:
            far = np.full(n, _FAR, dtype=np.float32)
        else:
            far = np.ascontiguousarray(np.minimum(t_max, _FAR), dtype=np.float32)
        out = np.empty(n, dtype=bool)
        direct = self._direct
        if direct is not None:
            if n:
                self._map(lambda s: direct.occluded(o[s], d[s], far[s], out[s]), n, parallel)
            return out

        def run(s: slice) -> None:
            out[s] = self._scene.run(o[s], d[s], dists=far[s], query="OCCLUDED") != MISS

        if n:
            self._map(run, n, parallel)
        return out
