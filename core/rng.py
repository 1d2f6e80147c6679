"""Counter-based random streams for numba kernels.

Every sample ``i`` of a call seeded with ``seed`` draws from its own splitmix64 stream, so results are
reproducible for a given seed whatever the number of threads or the order in which samples are made.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.jit import kernel

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_INV53 = 1.0 / 9007199254740992.0  # 2**-53


@njit(inline="always", nogil=True, cache=True)
def _mix(z: np.uint64) -> np.uint64:
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return z ^ (z >> _S31)


@kernel
def stream(seed: int, index: int) -> np.uint64:
    """Initial state of the stream for sample ``index`` of a call seeded with ``seed``."""
    s = np.uint64(seed) * _GOLDEN + np.uint64(0x632BE59BD9B4E019)
    return _mix(s ^ (_mix(np.uint64(index) + _GOLDEN)))


@njit(inline="always", nogil=True, cache=True)
def next_u01(state: np.uint64) -> tuple[np.uint64, float]:
    """Advance ``state``; return the new state and a uniform float in [0, 1)."""
    state = state + _GOLDEN
    z = _mix(state)
    return state, float(z >> _S11) * _INV53
