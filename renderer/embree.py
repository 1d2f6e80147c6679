"""Embree called from compiled code: the library embreex ships, bound through ctypes, queried in packets of 16.

embreex's ``run`` traces one ray at a time behind a Python call that allocates six result arrays per batch;
the path tracer then copies them into its own buffers. Here the wavefront's float32 rays go to Embree's
``rtcIntersect16`` / ``rtcOccluded16`` from a numba loop that writes the hits straight into the wavefront's
arrays (no allocation, no copy, no GIL). The library is the very one embreex loads (its wheel's ``.libs``
directory); :class:`renderer.accel.Accel` falls back to embreex's ``run`` where it cannot be found.

The Embree functions reach the compiled loops as arguments (ctypes function pointers), never as globals, so
numba caches the loops on disk like any other kernel (a global would bake this process's library address in).

Layout of Embree 4's 16-wide packets (structure of arrays, 16 lanes a field, 64-byte aligned):
``RTCRayHit16`` = 21 fields: ``org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar, mask, id, flags``,
then the hit's ``Ng_x, Ng_y, Ng_z, u, v, primID, geomID, instID, instPrimID``; ``RTCRay16`` is its first 12.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import glob
import os
from dataclasses import dataclass

import numba as nb
import numpy as np

WIDTH = 16  # lanes of a packet
_FIELDS_HIT = 21
_FIELDS_RAY = 12
_TFAR, _MASK, _ID, _FLAGS = 8, 9, 10, 11
_U, _V, _PRIM, _GEOM = 15, 16, 17, 18
_INVALID = 0xFFFFFFFF
_ALIGN = 64

# Embree 4's enumerations (rtcore_common.h, rtcore_buffer.h, rtcore_geometry.h)
_GEOMETRY_TRIANGLE = 0
_BUFFER_INDEX, _BUFFER_VERTEX = 0, 1
_FORMAT_UINT3, _FORMAT_FLOAT3 = 0x5003, 0x9003
_ERRORS = {
    1: "unknown error",
    2: "invalid argument",
    3: "invalid operation",
    4: "out of memory",
    5: "unsupported CPU",
    6: "cancelled",
    7: "level zero runtime error",
}


class EmbreeUnavailable(RuntimeError):
    """The Embree library could not be loaded or refused the scene."""


def library_path() -> str | None:
    """The Embree 4 library embreex's wheel ships (its ``embreex.libs`` directory), else one the system's
    loader finds; None when neither exists."""
    try:
        import embreex
    except ImportError:  # pragma: no cover - embreex is a dependency
        embreex = None
    if embreex is not None:
        base = os.path.dirname(os.path.abspath(embreex.__file__))
        for folder in (base + ".libs", os.path.join(os.path.dirname(base), "embreex.libs"), base):
            found = sorted(glob.glob(os.path.join(folder, "libembree4*")))
            if found:
                return found[0]
    return ctypes.util.find_library("embree4")


@dataclass(frozen=True)
class _Library:
    lib: ctypes.CDLL
    intersect16: object  # ctypes function pointers handed to the compiled loops
    occluded16: object


_LIBRARY: _Library | None = None


def _load() -> _Library:
    global _LIBRARY
    if _LIBRARY is not None:
        return _LIBRARY
    path = library_path()
    if path is None:
        raise EmbreeUnavailable(
            "no Embree 4 library found (neither in embreex's wheel nor on the loader's path)"
        )
    try:
        lib = ctypes.CDLL(path)
    except OSError as e:
        raise EmbreeUnavailable(f"cannot load Embree from {path}: {e}") from e
    p, u32, i32 = ctypes.c_size_t, ctypes.c_uint, ctypes.c_int
    signatures = {
        "rtcNewDevice": ([ctypes.c_char_p], p),
        "rtcReleaseDevice": ([p], None),
        "rtcGetDeviceError": ([p], i32),
        "rtcNewScene": ([p], p),
        "rtcReleaseScene": ([p], None),
        "rtcCommitScene": ([p], None),
        "rtcNewGeometry": ([p, i32], p),
        "rtcSetNewGeometryBuffer": ([p, i32, u32, i32, p, p], p),
        "rtcCommitGeometry": ([p], None),
        "rtcAttachGeometry": ([p, p], u32),
        "rtcReleaseGeometry": ([p], None),
        "rtcIntersect16": ([p, p, p, p], None),
        "rtcOccluded16": ([p, p, p, p], None),
    }
    try:
        for name, (args, res) in signatures.items():
            fn = getattr(lib, name)
            fn.argtypes, fn.restype = args, res
    except AttributeError as e:
        raise EmbreeUnavailable(f"{path} is not an Embree 4 library ({e})") from e
    _LIBRARY = _Library(lib, lib.rtcIntersect16, lib.rtcOccluded16)
    return _LIBRARY


class EmbreeScene:
    """A committed Embree scene of one triangle mesh, ``vertices (n, 3)`` and ``faces (m, 3)`` (triangle ids
    are face rows), on a device of its own. Raises :class:`EmbreeUnavailable` when the library is missing or
    Embree reports an error."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        lib = _load()
        self._lib = lib
        v = np.ascontiguousarray(vertices, dtype=np.float32)
        f = np.ascontiguousarray(faces, dtype=np.uint32)
        self.device = lib.lib.rtcNewDevice(None)
        if not self.device:
            raise EmbreeUnavailable("Embree could not create a device (unsupported CPU?)")
        self.scene = 0
        try:
            self.scene = lib.lib.rtcNewScene(self.device)
            geom = lib.lib.rtcNewGeometry(self.device, _GEOMETRY_TRIANGLE)
            # Embree's own buffers: it pads them as its vector loads need
            vbuf = lib.lib.rtcSetNewGeometryBuffer(geom, _BUFFER_VERTEX, 0, _FORMAT_FLOAT3, 12, len(v))
            ibuf = lib.lib.rtcSetNewGeometryBuffer(geom, _BUFFER_INDEX, 0, _FORMAT_UINT3, 12, len(f))
            self._check("allocating the mesh's buffers")
            ctypes.memmove(vbuf, v.ctypes.data, v.nbytes)
            ctypes.memmove(ibuf, f.ctypes.data, f.nbytes)
            lib.lib.rtcCommitGeometry(geom)
            lib.lib.rtcAttachGeometry(self.scene, geom)
            lib.lib.rtcReleaseGeometry(geom)
            lib.lib.rtcCommitScene(self.scene)
            self._check("building the scene")
        except BaseException:
            self.release()
            raise

    def _check(self, what: str) -> None:
        code = self._lib.lib.rtcGetDeviceError(self.device)
        if code:
            raise EmbreeUnavailable(f"Embree failed {what}: {_ERRORS.get(code, f'error {code}')}")

    def release(self) -> None:
        """Free the scene and the device (idempotent; no query may run at the same time)."""
        lib = self._lib.lib
        if getattr(self, "scene", 0):
            lib.rtcReleaseScene(self.scene)
            self.scene = 0
        if getattr(self, "device", 0):
            lib.rtcReleaseDevice(self.device)
            self.device = 0

    def __del__(self) -> None:
        # the collector may run this at interpreter exit or during a Ctrl-C: never raise from here
        if getattr(self, "_lib", None) is not None:
            with contextlib.suppress(Exception):
                self.release()

    def trace(self, o32: np.ndarray, d32: np.ndarray, prim: np.ndarray, t: np.ndarray, u: np.ndarray,
              v: np.ndarray) -> None:  # fmt: skip
        """Closest hits of ``o32, d32 (n, 3)`` float32 into ``prim`` int32 (-1 on a miss), ``t`` float32 (inf
        on a miss), ``u, v`` float32 barycentrics (0 on a miss); on the calling thread, without the GIL."""
        trace_packets(self._lib.intersect16, self.scene, o32, d32, prim, t, u, v)

    def occluded(self, o32: np.ndarray, d32: np.ndarray, t_max: np.ndarray, out: np.ndarray) -> None:
        """``out (n,)`` bool: something lies on the ray in ``[0, t_max]``; on the calling thread."""
        occluded_packets(self._lib.occluded16, self.scene, o32, d32, t_max, out)


@nb.njit(cache=True, inline="always")
def _aligned(n_floats):  # type: ignore[no-untyped-def]
    """A float32 scratch of ``n_floats`` starting on a 64-byte boundary, with its uint32 view and address."""
    raw = np.empty(n_floats + _ALIGN // 4, np.float32)
    skip = ((_ALIGN - raw.ctypes.data % _ALIGN) % _ALIGN) // 4
    buf = raw[skip : skip + n_floats]
    return buf, buf.view(np.uint32), buf.ctypes.data


@nb.njit(cache=True, inline="always")
def _packet(fields):  # type: ignore[no-untyped-def]
    """A packet of ``fields`` 16-lane fields and its valid mask: ``(r, r as uint32, r's address, mask as
    int32, mask's address)``."""
    r, ri, r_ptr = _aligned(fields * WIDTH)
    valid, _, valid_ptr = _aligned(WIDTH)
    return r, ri, r_ptr, valid.view(np.int32), valid_ptr


@nb.njit(cache=True, nogil=True)
def _load_packet(r, ri, vi, o32, d32, s, m, t_max):  # type: ignore[no-untyped-def]
    """Rays ``s .. s + m - 1`` into the packet ``r`` (``ri``: its uint32 view), lanes ``m ..`` off in the
    valid mask ``vi``: from 0 to ``t_max[i]``, or for ``t_max = None`` to infinity with the hit's geometry
    id cleared (a closest-hit query's ``RTCRayHit16``)."""
    for k in range(WIDTH):
        if k >= m:
            vi[k] = 0
            continue
        i = s + k
        r[k] = o32[i, 0]
        r[WIDTH + k] = o32[i, 1]
        r[2 * WIDTH + k] = o32[i, 2]
        r[3 * WIDTH + k] = 0.0  # tnear: callers offset their origins off the surface
        r[4 * WIDTH + k] = d32[i, 0]
        r[5 * WIDTH + k] = d32[i, 1]
        r[6 * WIDTH + k] = d32[i, 2]
        r[7 * WIDTH + k] = 0.0  # time
        ri[_MASK * WIDTH + k] = _INVALID
        ri[_ID * WIDTH + k] = 0
        ri[_FLAGS * WIDTH + k] = 0
        if t_max is None:
            r[_TFAR * WIDTH + k] = np.inf
            ri[_GEOM * WIDTH + k] = _INVALID
        else:
            r[_TFAR * WIDTH + k] = t_max[i]
        vi[k] = -1


@nb.njit(cache=True, nogil=True)
def trace_packets(intersect16, scene, o32, d32, prim, t, u, v):  # type: ignore[no-untyped-def]
    """Closest hits of the rays in packets of 16 through ``rtcIntersect16`` (``intersect16``, a ctypes
    function pointer; ``scene`` the ``RTCScene`` handle); results into ``prim, t, u, v``."""
    n = o32.shape[0]
    r, ri, r_ptr, vi, valid_ptr = _packet(_FIELDS_HIT)
    for s in range(0, n, WIDTH):
        m = min(WIDTH, n - s)
        _load_packet(r, ri, vi, o32, d32, s, m, None)
        intersect16(valid_ptr, scene, r_ptr, 0)
        for k in range(m):
            i = s + k
            if ri[_GEOM * WIDTH + k] == _INVALID:
                prim[i] = -1
                t[i] = np.inf
                u[i] = 0.0
                v[i] = 0.0
            else:
                prim[i] = ri[_PRIM * WIDTH + k]
                t[i] = r[_TFAR * WIDTH + k]
                u[i] = r[_U * WIDTH + k]
                v[i] = r[_V * WIDTH + k]


@nb.njit(cache=True, nogil=True)
def occluded_packets(occluded16, scene, o32, d32, t_max, out):  # type: ignore[no-untyped-def]
    """``out[i]``: something lies on ray ``i`` before ``t_max[i]``, through ``rtcOccluded16`` in packets of
    16 (Embree sets an occluded ray's ``tfar`` to -inf)."""
    n = o32.shape[0]
    r, ri, r_ptr, vi, valid_ptr = _packet(_FIELDS_RAY)
    for s in range(0, n, WIDTH):
        m = min(WIDTH, n - s)
        _load_packet(r, ri, vi, o32, d32, s, m, t_max)
        occluded16(valid_ptr, scene, r_ptr, 0)
        for k in range(m):
            out[s + k] = r[_TFAR * WIDTH + k] < 0.0
