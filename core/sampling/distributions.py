"""The sampling toolkit: piecewise-constant distributions in one and two dimensions, the one interval search
and the one guide-table builder behind them, and the warps of the square onto the sphere.

A **CDF** is a segment ``cdf[lo:hi]`` of a float64 array, non-decreasing from ``cdf[lo] = 0`` to
``cdf[hi - 1] = 1``: ``hi - lo - 1`` bins, bin ``k`` (absolute index) holding the mass
``cdf[k + 1] - cdf[k]``. Many CDFs share one flat array at offsets, so that compiled kernels need no
per-distribution objects.

- :func:`upper_bound` is the single binary search (``np.searchsorted(..., side="right")`` on a segment, by
  conditional moves: CDFs are searched at random points, where a branch mispredicts half the time);
  :func:`walk_upper_bound` finds the same index by stepping from a guess.
- :func:`find_interval` is the bin of ``u``: the largest ``k`` in ``[lo, hi - 2]`` with ``cdf[k] <= u``
  (``lo`` below the first bin, ``hi - 2`` at or above 1); zero-mass bins are never chosen for ``u`` in
  ``[0, 1)`` (ties go to the last bin that starts at ``u``). :func:`walk_interval` and
  :func:`guided_interval` give the same index from a guess or a guide table.
- :func:`fill_guide` builds a guide table: the search's answers at ``size`` equally spaced ``u``, so that a
  search at ``u`` starts between its two nearest entries.
- :func:`build_cdf` (numpy) turns non-negative weights into a CDF with checks; :func:`build_cdf_2d` the
  marginal over rows and one conditional CDF per row. :func:`sample_discrete`, :func:`sample_continuous`,
  :func:`pdf_continuous` and :func:`sample_2d`, :func:`pdf_2d` draw from and evaluate them.
- Warps: :func:`cosine_hemisphere` (Malley's method), :func:`uniform_sphere`, with their densities and
  inverses.

The compiled helpers are inlined (``inline="always"``) and allocate nothing: the renderer's per-sample
loops call them (see :mod:`core.jit`). Users: :mod:`core.sampling.tabulated`, :mod:`core.sampling.factored`,
:mod:`core.study_lights`, :mod:`renderer.envmap` and the light selection of :mod:`renderer.stages.surface`
(docs/ARCHITECTURE.md names those that do not use it, and why).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.jit import kernel
from core.models.lobes import cosine_hemisphere as cosine_hemisphere  # the models' warp: one definition
from core.models.lobes import cosine_hemisphere_pdf as cosine_hemisphere_pdf

PI = math.pi
TWO_PI = 2.0 * math.pi
INV_FOUR_PI = 1.0 / (4.0 * math.pi)
ONE_MINUS_EPSILON = 1.0 - 2.0**-53
"""The largest float64 below 1."""


# ---- searches


@njit(inline="always", nogil=True, cache=True)
def upper_bound(a, lo, n, v):
    """``lo`` plus the number of elements ``<= v`` in the sorted ``a[lo:lo + n]`` (``np.searchsorted(...,
    side="right")`` on that segment), by a binary search without data-dependent branches (the next probe is a
    conditional move, never a mispredicted jump)."""
    base = lo
    while n > 1:
        half = n >> 1
        base = base + half if a[base + half] <= v else base
        n -= half
    if n == 1 and a[base] <= v:
        base += 1
    return base


@njit(inline="always", nogil=True, cache=True)
def walk_upper_bound(a, lo, n, v, start):
    """:func:`upper_bound` by a walk from ``start``, a guess in ``[lo, lo + n]``: down while the element
    before is above ``v``, then up while the element is at most ``v``. Exact whatever the guess; as fast as
    the guess is close (a guide table's: about one step instead of ``log2 n`` dependent loads)."""
    i = min(max(start, lo), lo + n)
    while i > lo and a[i - 1] > v:
        i -= 1
    while i < lo + n and a[i] <= v:
        i += 1
    return i


@njit(inline="always", nogil=True, cache=True)
def find_interval(cdf, lo, hi, u):
    """The bin of ``u`` in the CDF ``cdf[lo:hi]``: the largest ``k`` in ``[lo, hi - 2]`` with ``cdf[k] <= u``
    (``lo`` when there is none)."""
    return upper_bound(cdf, lo + 1, hi - lo - 2, u) - 1


@njit(inline="always", nogil=True, cache=True)
def walk_interval(cdf, lo, hi, u, k):
    """:func:`find_interval`'s answer found by stepping from a guess ``k`` (a few steps when it is close)."""
    return walk_upper_bound(cdf, lo + 1, hi - lo - 2, u, k + 1) - 1


@njit(inline="always", nogil=True, cache=True)
def guided_interval(cdf, lo, hi, guide, u):
    """:func:`find_interval`'s answer searched only between the answers at the guide's two nearest ``u``
    (``guide``: :func:`interval_guides`' row, ``size + 1`` entries at ``g / size``), for ``u >= 0``."""
    size = guide.shape[0] - 1
    g = min(int(u * size), size - 1)
    return find_interval(cdf, guide[g], min(guide[g + 1] + 2, hi), u)


@njit(inline="always", nogil=True, cache=True)
def fill_guide(a, lo, n, base, size, out):
    """A guide table into ``out``: ``out[g] = upper_bound(a, lo, n, base + g / size)`` for every entry of
    ``out`` (one monotone walk; ``base`` offsets the abscissae of a CDF stored shifted)."""
    i = lo
    for g in range(out.shape[0]):
        v = base + g / size
        while i < lo + n and a[i] <= v:
            i += 1
        out[g] = i


@njit(nogil=True, cache=True)
def interval_guides(cdf, offsets, size):
    """Guide rows for :func:`guided_interval`: for CDF ``c`` (``cdf[offsets[c]:offsets[c + 1]]``), entry
    ``g`` of row ``c`` is :func:`find_interval`'s answer at ``u = g / size``; ``(n_cdfs, size + 1)`` int32."""
    out = np.empty((offsets.shape[0] - 1, size + 1), dtype=np.int32)
    for c in range(offsets.shape[0] - 1):
        lo = offsets[c]
        hi = offsets[c + 1]
        row = out[c]
        fill_guide(cdf, lo + 1, hi - lo - 2, 0.0, size, row)
        for g in range(size + 1):
            row[g] -= 1
    return out


# ---- piecewise-constant distributions


def build_cdf(weights: np.ndarray) -> np.ndarray:
    """The CDF (``n + 1`` entries from 0 to 1) of ``n >= 1`` non-negative finite weights; a ``ValueError``
    for NaN, infinite or negative weights and for weights that sum to zero."""
    w = np.asarray(weights, dtype=np.float64).ravel()
    if w.size == 0:
        raise ValueError("a distribution needs at least one bin")
    if not np.all(np.isfinite(w)):
        raise ValueError("a distribution's weights must be finite (no NaN or infinity)")
    if np.any(w < 0.0):
        raise ValueError("a distribution's weights must be non-negative")
    cdf = np.concatenate([[0.0], np.cumsum(w)])
    if not cdf[-1] > 0.0:
        raise ValueError("a distribution's weights sum to zero: nothing to sample")
    cdf /= cdf[-1]
    cdf[-1] = 1.0
    return cdf


def build_cdf_2d(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The marginal CDF over the rows of ``weights (rows, cols)`` and the conditional CDF of every row,
    ``(rows + 1,)`` and ``(rows, cols + 1)`` (a row of zero mass gets a uniform conditional: it is never
    chosen)."""
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 2:
        raise ValueError("a 2-D distribution's weights are a (rows, cols) array")
    build_cdf(w)  # the checks: finite, non-negative, some mass
    marginal = build_cdf(w.sum(axis=1))
    cond = np.empty((w.shape[0], w.shape[1] + 1))
    for r in range(w.shape[0]):
        cond[r] = build_cdf(w[r]) if w[r].sum() > 0.0 else np.linspace(0.0, 1.0, w.shape[1] + 1)
    return marginal, cond


@njit(inline="always", nogil=True, cache=True)
def remainder(u, lo, hi):
    """Where ``u`` lies in ``[lo, hi)``, in ``[0, 1]`` (0.5 for an empty interval)."""
    r = (u - lo) / (hi - lo) if hi > lo else 0.5
    return min(1.0, max(0.0, r))


@njit(inline="always", nogil=True, cache=True)
def sample_discrete(cdf, lo, hi, u):
    """A bin of the CDF ``cdf[lo:hi]`` from ``u``: ``(k, p, u_rest)`` with ``k`` relative to ``lo``, ``p`` its
    probability and ``u_rest`` where ``u`` fell inside the bin's interval (uniform, independent of ``k``)."""
    k = find_interval(cdf, lo, hi, u)
    return k - lo, cdf[k + 1] - cdf[k], remainder(u, cdf[k], cdf[k + 1])


@njit(inline="always", nogil=True, cache=True)
def sample_continuous(cdf, lo, hi, u):
    """A point ``x`` of ``[0, 1)`` with the piecewise-constant density of ``cdf[lo:hi]`` over equal bins:
    ``(x, pdf, k)`` with ``k`` the bin relative to ``lo``."""
    n = hi - lo - 1
    k, p, du = sample_discrete(cdf, lo, hi, u)
    return min((k + du) / n, ONE_MINUS_EPSILON), p * n, k


@njit(inline="always", nogil=True, cache=True)
def pdf_continuous(cdf, lo, hi, x):
    """The density of :func:`sample_continuous` at ``x`` in ``[0, 1]``."""
    n = hi - lo - 1
    k = lo + min(max(int(x * n), 0), n - 1)
    return (cdf[k + 1] - cdf[k]) * n


@njit(inline="always", nogil=True, cache=True)
def sample_2d(marginal, cond, u0, u1):
    """A point ``(x, y)`` of ``[0, 1)^2`` from :func:`build_cdf_2d`'s CDFs (rows along ``y``, columns along
    ``x``) and its density: ``(x, y, pdf)``."""
    y, pdf_y, r = sample_continuous(marginal, 0, marginal.shape[0], u0)
    row = cond[r]
    x, pdf_x, _ = sample_continuous(row, 0, row.shape[0], u1)
    return x, y, pdf_y * pdf_x


@njit(inline="always", nogil=True, cache=True)
def pdf_2d(marginal, cond, x, y):
    """The density of :func:`sample_2d` at ``(x, y)`` in ``[0, 1]^2``."""
    rows = marginal.shape[0] - 1
    r = min(max(int(y * rows), 0), rows - 1)
    row = cond[r]
    return pdf_continuous(marginal, 0, rows + 1, y) * pdf_continuous(row, 0, row.shape[0], x)


@kernel
def find_intervals(cdf, u, out):
    """:func:`find_interval` over the whole ``cdf`` for every ``u``, into ``out`` (int64)."""
    for i in range(u.shape[0]):
        out[i] = find_interval(cdf, 0, cdf.shape[0], u[i])


# ---- warps


@njit(inline="always", nogil=True, cache=True)
def cosine_hemisphere_inverse(x, y, z):
    """The uniforms ``(u1, u2)`` that :func:`cosine_hemisphere` maps to the unit ``(x, y, z)``, ``z >= 0``."""
    phi = math.atan2(y, x)
    if phi < 0.0:
        phi += TWO_PI
    return min(1.0, max(0.0, x * x + y * y)), phi / TWO_PI


@njit(inline="always", nogil=True, cache=True)
def uniform_sphere(u1, u2):
    """A direction uniform on the unit sphere (``z = 1 - 2 u1``)."""
    z = 1.0 - 2.0 * u1
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = TWO_PI * u2
    return r * math.cos(phi), r * math.sin(phi), z


@njit(inline="always", nogil=True, cache=True)
def uniform_sphere_pdf():
    """The density per solid angle of :func:`uniform_sphere`."""
    return INV_FOUR_PI


@njit(inline="always", nogil=True, cache=True)
def uniform_sphere_inverse(x, y, z):
    """The uniforms ``(u1, u2)`` that :func:`uniform_sphere` maps to the unit ``(x, y, z)``."""
    phi = math.atan2(y, x)
    if phi < 0.0:
        phi += TWO_PI
    return min(1.0, max(0.0, 0.5 * (1.0 - z))), phi / TWO_PI
