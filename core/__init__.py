"""BRDF models, measured data, samplers, analysis and the scene description (numpy + numba only)."""

from core._numba_cache import configure as _configure_numba_cache

_configure_numba_cache()
