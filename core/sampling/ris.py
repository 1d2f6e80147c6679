"""Resampled importance sampling (Talbot, Cline & Egbert 2005) of BRDF x incident light.

For each output sample, ``M`` candidates ``x_k`` are drawn from a source sampler (density ``p``), weighted by
``w_k = p_hat(x_k) / p(x_k)`` with the target ``p_hat = f cos L`` (unoccluded light), and one candidate ``y``
is kept with probability proportional to its weight. The estimator of ``integral g`` is
``g(y) / p_hat(y) * mean_k(w_k)``; it is unbiased for any ``g`` that vanishes where ``p_hat`` does, and its
value lies in how cheap ``p_hat`` is compared with ``g`` (in a renderer ``g`` adds a visibility ray that RIS
traces for the kept candidate only).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from core.brdf import LUMINANCE
from core.errors import ParameterError
from core.sampling.base import Sampler


class ResampledBatch(NamedTuple):
    """The directions RIS kept, one per output sample, with their weights and BRDF values."""

    wi: np.ndarray
    """``(n, 3)`` float64: the kept candidates."""
    weight: np.ndarray
    """``(n,)`` float64: ``mean_k(w_k) / p_hat(wi)``, the factor that makes ``g(wi) * weight`` unbiased."""
    f: np.ndarray
    """``(n, 3)`` float64: the BRDF's value at ``(wo, wi)`` (the source sampler's, not evaluated again)."""


def ris_sample(
    sampler: Sampler,
    wo: np.ndarray,
    light_radiance: Callable[[np.ndarray], np.ndarray],
    n: int,
    candidates: int,
    seed: int = 0,
) -> ResampledBatch:
    """``n`` resampled directions for ``wo (3,)``, their RIS weights ``mean_k(w_k) / p_hat(y)`` and ``f``.

    Multiply the integrand ``g(y)`` by the weight to get an unbiased estimate of its integral; a weight of 0
    means every candidate had zero target.

    Parameters
    ----------
    sampler : the source of the candidates (its ``f`` gives the target)
    wo : (3,) float64
        Unit outgoing direction.
    light_radiance : ``(m, 3) -> (m,)`` incident radiance (luminance) from each direction, unoccluded
    n, candidates : output samples, and candidates ``M`` per output sample
    seed : int
    """
    if candidates < 1 or n < 1:
        raise ParameterError("RIS needs at least one candidate and one sample")
    m = int(candidates)
    batch = sampler.sample(wo, n * m, seed=seed)
    wi, pdf = batch.wi, batch.pdf
    target = (batch.f @ LUMINANCE) * np.maximum(wi[:, 2], 0.0) * light_radiance(wi)
    w = np.where(pdf > 0.0, target / np.where(pdf > 0.0, pdf, 1.0), 0.0).reshape(n, m)
    total = w.sum(axis=1)
    rng = np.random.default_rng([seed, 0x5151])
    pick = (rng.random(n)[:, None] * total[:, None] >= np.cumsum(w, axis=1)).sum(axis=1)
    pick = np.minimum(pick, m - 1)
    rows = np.arange(n)
    chosen = wi.reshape(n, m, 3)[rows, pick]
    p_hat = target.reshape(n, m)[rows, pick]
    weight = np.where(p_hat > 0.0, (total / m) / np.where(p_hat > 0.0, p_hat, 1.0), 0.0)
    return ResampledBatch(chosen, weight, batch.f.reshape(n, m, 3)[rows, pick])
