"""Batch drivers around the per-model kernels.

Each driver is one numba loop specialized to one kernel, so the loops never branch on the model at run time
(pbrt's one-kernel-per-type). The specializations are generated modules with the kernel bound as a global
(:mod:`core.specialize`), so numba compiles them once per machine and loads them from disk afterwards; a
kernel that cannot be imported by name (a closure) goes to the generic drivers below, which take it as an
argument and compile once per process.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit, prange

from core.specialize import specialize

if TYPE_CHECKING:
    from core.model import Model

_EVAL = """
from numba import njit, prange


@njit(nogil=True, cache=True)
def serial(wi, wo, p, out):
    for i in range(wi.shape[0]):
        r, g, b = _eval((wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b


@njit(nogil=True, cache=True, parallel=True)
def parallel(wi, wo, p, out):
    for i in prange(wi.shape[0]):
        r, g, b = _eval((wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b
"""

_SAMPLE = """
from numba import njit


@njit(nogil=True, cache=True)
def serial(wo, p, u, wi_out, pdf_out):
    for i in range(wo.shape[0]):
        x, y, z, pdf = _sample((wo[i, 0], wo[i, 1], wo[i, 2]), p, u[i, 0], u[i, 1], u[i, 2])
        wi_out[i, 0] = x
        wi_out[i, 1] = y
        wi_out[i, 2] = z
        pdf_out[i] = pdf
"""

_PDF = """
from numba import njit


@njit(nogil=True, cache=True)
def serial(wo, wi, p, out):
    for i in range(wo.shape[0]):
        out[i] = _pdf((wo[i, 0], wo[i, 1], wo[i, 2]), (wi[i, 0], wi[i, 1], wi[i, 2]), p)
"""


@njit(nogil=True)
def _eval_serial(kernel, wi, wo, p, out):
    for i in range(wi.shape[0]):
        r, g, b = kernel((wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b


@njit(nogil=True, parallel=True)
def _eval_parallel(kernel, wi, wo, p, out):
    for i in prange(wi.shape[0]):
        r, g, b = kernel((wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b


def eval_batch(
    model: Model, wi: np.ndarray, wo: np.ndarray, p: np.ndarray, threads: bool = False
) -> np.ndarray:
    """``f_r(wi[k], wo[k])`` for every row; ``wi, wo (n, 3)`` float64 contiguous; returns ``(n, 3)``."""
    out = np.empty((wi.shape[0], 3), dtype=np.float64)
    mod = specialize(_EVAL, _eval=model.eval)
    if mod is not None:
        (mod.parallel if threads else mod.serial)(wi, wo, p, out)
    else:
        (_eval_parallel if threads else _eval_serial)(model.eval, wi, wo, p, out)
    return out


@njit(nogil=True)
def _sample_serial(kernel, wo, p, u, wi_out, pdf_out):
    for i in range(wo.shape[0]):
        x, y, z, pdf = kernel((wo[i, 0], wo[i, 1], wo[i, 2]), p, u[i, 0], u[i, 1], u[i, 2])
        wi_out[i, 0] = x
        wi_out[i, 1] = y
        wi_out[i, 2] = z
        pdf_out[i] = pdf


@njit(nogil=True)
def _pdf_serial(kernel, wo, wi, p, out):
    for i in range(wo.shape[0]):
        out[i] = kernel((wo[i, 0], wo[i, 1], wo[i, 2]), (wi[i, 0], wi[i, 1], wi[i, 2]), p)


def sample_batch(kernel, wo: np.ndarray, p: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run a ``sample(wo, p, u1, u2, u3)`` kernel for every row of ``wo (n, 3)`` with uniforms ``u (n, 3)``."""
    wi = np.empty_like(wo)
    pdf = np.empty(wo.shape[0])
    mod = specialize(_SAMPLE, _sample=kernel)
    if mod is not None:
        mod.serial(wo, p, u, wi, pdf)
    else:
        _sample_serial(kernel, wo, p, u, wi, pdf)
    return wi, pdf


def pdf_batch(kernel, wo: np.ndarray, wi: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Run a ``pdf(wo, wi, p)`` kernel for every row: density per unit solid angle."""
    out = np.empty(wo.shape[0])
    mod = specialize(_PDF, _pdf=kernel)
    if mod is not None:
        mod.serial(wo, wi, p, out)
    else:
        _pdf_serial(kernel, wo, wi, p, out)
    return out
