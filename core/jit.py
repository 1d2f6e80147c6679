"""The compile options of the compiled kernels that allocate no arrays.

numba counts references to every array a compiled function holds: a function's array arguments are
incremented on entry and decremented on every exit, and a helper inlined into a loop (``inline="always"``)
binds its array arguments anew on every iteration. Both are atomic operations (``lock inc``/``lock dec``)
and numba's pass that removes matched pairs misses them wherever the helper branches (multiple returns, a
variable dying in different branches). With them, ``perf`` puts 30 % of a one-thread demo pass and 37 % of
the measured material's table build in numba's ``NRT_incref``/``NRT_decref``, a cost no profile of our own
code shows, called from the sky's light sample (14 a sample: its seven arrays), the sky's lookup at a miss,
the parameter rows of the BRDF stage, the adaptive trees' ``g`` and the models' own kernels. An environment
sample in a loop takes 88 ns with them, 41 ns without.

A function compiled with ``_nrt=False`` (numba's option to compile without its runtime) holds no reference
counts at all: its arguments are borrowed from its caller, which holds them for the call. It may not
allocate, create or return an array it did not receive (numba refuses to compile such a function: "NRT
required but not enabled", found when the kernel is first compiled, at setup); it may read and write the
arrays it is given, make views of them and call any other compiled function. Kernels that need scratch
rows take them from their caller (the render stages from :class:`renderer.wavefront.Buffers`, the trees'
leaf bounds and probes from the construction step that calls them). ``tests/core/test_jit.py`` checks that
the hot loops keep the option.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from numba import njit

F = TypeVar("F", bound=Callable[..., Any])

KERNEL_OPTIONS: dict[str, Any] = {"nogil": True, "cache": True, "_nrt": False}
"""``njit`` options of :func:`kernel`: no GIL, cached on disk, no reference counting."""


def kernel(fn: F) -> F:
    """``numba.njit`` for a kernel that allocates no arrays (see the module): released GIL, cached on disk
    (``core._numba_cache``), compiled without numba's reference counting."""
    return njit(**KERNEL_OPTIONS)(fn)  # type: ignore[no-any-return]
