"""Batch drivers: compiled loops that evaluate, sample or take the density of a model, reached by its id.

Every loop is an ordinary ``@njit(nogil=True, cache=True)`` function taking the model's dispatch id
(:mod:`core.dispatch`) and its kernel parameter vector, so each compiles once per machine for every model
(``python -m core.warmup`` does it at setup) and is loaded from disk afterwards. The id is the same on every
iteration of a loop, so the inlined switch costs little next to the kernel (see :mod:`core.dispatch`).

The Python wrappers take a :class:`core.brdf.Model` or its id, and make every array C-contiguous float64:
one signature per loop, the one the warm-up compiles.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numba import njit, prange

from core.dispatch import MERL, eval_model, pdf_model, sample_model
from core.jit import kernel
from core.merl import MERL_BLOCK, eval_merl_rows

if TYPE_CHECKING:
    from core.brdf import Model


class DirectionSamples(NamedTuple):
    """Directions drawn by a sampling kernel, one per row of ``wo``."""

    wi: np.ndarray
    """``(n, 3)`` float64: the sampled incident directions (possibly below the horizon)."""
    pdf: np.ndarray
    """``(n,)`` float64: their density per unit solid angle (0 where nothing could be drawn)."""


def model_index(model_or_id: Model | int) -> int:
    """The dispatch id of a :class:`core.brdf.Model`, or the id itself."""
    if isinstance(model_or_id, int | np.integer):
        return int(model_or_id)
    return model_or_id.id


def _rows(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


@kernel
def _eval_serial(mid, wi, wo, p, out):
    for i in range(wi.shape[0]):
        r, g, b = eval_model(mid, (wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b


@kernel
def _eval_where(mid, wi, wo, p, keep, out):
    for i in range(wi.shape[0]):
        if keep[i]:
            r, g, b = eval_model(mid, (wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
            out[i, 0] = r
            out[i, 1] = g
            out[i, 2] = b


@njit(nogil=True, cache=True, parallel=True)
def _eval_parallel(mid, wi, wo, p, out):
    for i in prange(wi.shape[0]):
        r, g, b = eval_model(mid, (wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b


@kernel
def _sample_serial(mid, wo, p, u, wi_out, pdf_out):
    for i in range(wo.shape[0]):
        x, y, z, pdf = sample_model(mid, (wo[i, 0], wo[i, 1], wo[i, 2]), p, u[i, 0], u[i, 1], u[i, 2])
        wi_out[i, 0] = x
        wi_out[i, 1] = y
        wi_out[i, 2] = z
        pdf_out[i] = pdf


@kernel
def _pdf_serial(mid, wo, wi, p, out):
    for i in range(wo.shape[0]):
        out[i] = pdf_model(mid, (wo[i, 0], wo[i, 1], wo[i, 2]), (wi[i, 0], wi[i, 1], wi[i, 2]), p)


def eval_batch(
    model_or_id: Model | int, wi: np.ndarray, wo: np.ndarray, p: np.ndarray, threads: bool = False
) -> np.ndarray:
    """``f_r(wi[k], wo[k])`` for every row (note the kernels' order: ``wi`` first).

    Parameters
    ----------
    model_or_id : the model, or its dispatch id
    wi, wo : (n, 3) float64
        Unit directions in the local frame.
    p : (m,) float64
        The model's kernel parameter vector.
    threads : bool
        Run the loop on numba's threads (worth it above ~10^5 rows; never from inside another parallel loop).

    Returns
    -------
    (n, 3) float64
        RGB values, 0 where either direction is below the horizon.
    """
    wi, wo = _rows(wi), _rows(wo)
    out = np.empty((wi.shape[0], 3), dtype=np.float64)
    (_eval_parallel if threads else _eval_serial)(model_index(model_or_id), wi, wo, _rows(p), out)
    return out


_EVERY_ROW = np.zeros(0, dtype=np.bool_)


def eval_into(model_id: int, wi: np.ndarray, wo: np.ndarray, p: np.ndarray, out: np.ndarray,
              where: np.ndarray | None = None) -> None:  # fmt: skip
    """:func:`eval_batch` written into the caller's ``out (n, 3)``, at the rows where ``where (n,)`` holds
    (all rows when None; the other rows are left as they are). Every array must already be C-contiguous
    float64 (``where``: bool): a renderer's buffers, written without a copy. A measured table's rows go through
    :func:`core.merl.eval_merl_rows` (the same values; its reads overlapped a block at a time)."""
    if model_id == MERL:
        cells = np.empty((MERL_BLOCK, 3), dtype=np.int64)
        fractions = np.empty((MERL_BLOCK, 3))
        eval_merl_rows(wi, wo, p, _EVERY_ROW if where is None else where, out, cells, fractions)
    elif where is None:
        _eval_serial(model_id, wi, wo, p, out)
    else:
        _eval_where(model_id, wi, wo, p, where, out)


def sample_batch(model_or_id: Model | int, wo: np.ndarray, p: np.ndarray, u: np.ndarray) -> DirectionSamples:
    """The model's analytic sample for every row of ``wo``.

    Parameters
    ----------
    model_or_id : the model, or its dispatch id
    wo : (n, 3) float64
        Outgoing directions.
    p : (m,) float64
        The model's kernel parameter vector.
    u : (n, 3) float64
        Uniform numbers in [0, 1), one row per sample.

    Returns
    -------
    DirectionSamples
        ``wi (n, 3)`` and ``pdf (n,)`` per unit solid angle; ``pdf = 0`` for a model without a sampler.
    """
    wo = _rows(wo)
    wi = np.empty_like(wo)
    pdf = np.empty(wo.shape[0])
    _sample_serial(model_index(model_or_id), wo, _rows(p), _rows(u), wi, pdf)
    return DirectionSamples(wi, pdf)


def pdf_batch(model_or_id: Model | int, wo: np.ndarray, wi: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The density of the model's analytic sampler at every row.

    Parameters
    ----------
    model_or_id : the model, or its dispatch id
    wo, wi : (n, 3) float64
        Outgoing and incident unit directions (``wi`` in either hemisphere).
    p : (m,) float64
        The model's kernel parameter vector.

    Returns
    -------
    (n,) float64
        Density per unit solid angle; 0 for a model without a sampler.
    """
    wo, wi = _rows(wo), _rows(wi)
    out = np.empty(wo.shape[0])
    _pdf_serial(model_index(model_or_id), wo, wi, _rows(p), out)
    return out
