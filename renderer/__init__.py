"""The path tracer: embreex intersection, numba shading kernels, film, EXR/PNG output."""

from core._numba_cache import configure as _configure_numba_cache

_configure_numba_cache()
