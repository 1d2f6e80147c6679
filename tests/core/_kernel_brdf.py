"""BRDFs from kernels that core.dispatch does not know: the tests' own lobes, whose integrals are known.

core evaluates a model through its dispatch id (core.kernels); a kernel written in a test has none. A
:class:`KernelBRDF` evaluates its model's kernel in a loop compiled here, per process, with the kernel as an
argument (numba compiles it once per kernel and does not cache it: fine for a test, never for core).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from core.brdf import BRDF, Model


@njit(nogil=True)
def _eval_rows(kernel, wi, wo, p, out):
    for i in range(wi.shape[0]):
        r, g, b = kernel((wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b


class KernelBRDF(BRDF):
    """A :class:`core.brdf.BRDF` whose ``eval`` runs its model's kernel directly (no dispatch id needed)."""

    def eval(self, wo: np.ndarray, wi: np.ndarray, threads: bool = False) -> np.ndarray:
        """``f_r`` as RGB ``(n, 3)`` for directions ``wo``, ``wi`` of shape ``(3,)`` or ``(n, 3)``."""
        wo, wi = np.broadcast_arrays(np.atleast_2d(wo), np.atleast_2d(wi))
        wo = np.ascontiguousarray(wo, dtype=np.float64)
        wi = np.ascontiguousarray(wi, dtype=np.float64)
        out = np.empty((wi.shape[0], 3))
        _eval_rows(self.model.eval, wi, wo, self.params, out)
        return out


def bind(model: Model, **values: Any) -> KernelBRDF:
    """``model`` with validated parameter values, evaluated by its own kernel."""
    return KernelBRDF(model, model.resolve(values))
