"""Where a material's trees are: nodes over the outgoing direction, their cells, and the normalizer between them.

Nodes sit at polar angles ``thetas`` (and, for an anisotropic BRDF, azimuths ``phis``); each node's tree
serves its *cell*, the outgoing directions nearer to it than to any other node (in theta, and in phi). The
seed stored one tree per incident angle; a fixed grid of 1-degree bins (104 with the horizon's, 1 872 for an
anisotropic BRDF) made building a material slow. Here the layout is made per material: it starts coarse and
an interval is halved only where the material asks for it (:mod:`core.sampling.adaptive.table`):

- the rejection-free density of a node, used at its cell's edge, would have a relative variance (chi^2)
  above ``warp_chi2`` (the lobe moves or changes too much across the cell);
- a node's envelope cannot reach the acceptance ``1/n_max`` over its cell;
- the normalizer ``I(wo)`` would not be interpolated between the nodes to ``norm_tol``.

Symmetry (the frame the trees are kept in, :mod:`core.sampling.adaptive.target`):

========== ============================================= =================================================
ISOTROPIC  ``f`` is invariant under rotation about the    one azimuth node; ``wo`` is turned to ``phi = 0``
           normal (trait, or measured numerically)
MIRROR     also under mirroring both directions in the    azimuth nodes over ``[0, pi/2]``; ``wo`` is folded
           x-z and the y-z planes (trait)                  into that quadrant and the draw unfolded
FULL       anything else                                  azimuth nodes over the whole circle
========== ============================================= =================================================

The normalizer (the exact mode's ``I(wo)``) is interpolated from the nodes' integrals: a cubic through the
four nearest nodes in theta (Lagrange, on the non-uniform layout) and, in phi, the cosine series in ``2 phi``
through the quadrant's equally spaced nodes (MIRROR: ``I`` is even about 0 and pi/2) or a periodic cubic
(FULL).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

ISOTROPIC = 0
MIRROR = 1
FULL = 2
SYMMETRIES = ("isotropic", "mirror", "full")

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi

THETA_END = math.radians(89.9)
"""The last node. Beyond it the exact mode draws the cosine density (every model's ``I(wo)`` tends to 0 at the
horizon, and the rejection-free mode goes on with the last node's tree)."""

INITIAL_THETAS_DEG = (0.0, 15.0, 30.0, 45.0, 60.0, 70.0, 78.0, 84.0, 87.0, 89.0, 89.9)
"""The layout a material starts from: coarse where lobes change slowly, denser toward the horizon."""


def phi_nodes(symmetry: int, count: int) -> np.ndarray:
    """Equally spaced azimuth nodes: ``[0]`` (isotropic), ``count`` over ``[0, pi/2]`` ends included
    (mirror), ``count`` over ``[0, 2 pi)`` (full)."""
    if symmetry == ISOTROPIC:
        return np.zeros(1)
    if symmetry == MIRROR:
        return np.linspace(0.0, HALF_PI, max(int(count), 2))
    return np.arange(int(count)) * (TWO_PI / int(count))


def cell_edges(nodes: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """``(len(nodes) + 1,)`` edges of the cells of sorted ``nodes`` within ``[lo, hi]`` (midpoints inside)."""
    mids = 0.5 * (nodes[1:] + nodes[:-1])
    return np.concatenate([[lo], mids, [hi]])


# ------------------------------------------------------------------------------------------ normalizer
def series_coefficients(values: np.ndarray) -> np.ndarray:
    """Coefficients ``a_m`` of ``sum_m a_m cos(2 m phi)`` through ``values (..., J)`` at ``J`` equally spaced
    azimuths over ``[0, pi/2]`` (ends included): the DCT-I of the values."""
    values = np.asarray(values, dtype=np.float64)
    j = values.shape[-1]
    if j == 1:
        return values.copy()
    n = j - 1
    k = np.arange(j)
    w = np.ones(j)
    w[0] = w[-1] = 0.5
    basis = np.cos(np.pi * np.outer(k, k) / n)  # [m, node]
    coef = (values * w) @ basis.T * (2.0 / n)
    coef[..., 0] *= 0.5
    coef[..., -1] *= 0.5
    return coef


@njit(inline="always", nogil=True, cache=True)
def _cosine_series(coef, phi):
    """``sum_m coef[m] cos(2 m phi)`` by the Chebyshev recurrence."""
    c2 = math.cos(2.0 * phi)
    prev = 1.0
    cur = c2
    s = coef[0]
    for m in range(1, coef.shape[0]):
        s += coef[m] * cur
        nxt = 2.0 * c2 * cur - prev
        prev = cur
        cur = nxt
    return s


@njit(inline="always", nogil=True, cache=True)
def _periodic_cubic(values, phi):
    """Cubic Lagrange interpolation of ``values`` at equally spaced azimuths over the whole circle."""
    j = values.shape[0]
    if j == 1:
        return values[0]
    t = phi / TWO_PI * j
    i = int(math.floor(t))
    x = t - i
    s = 0.0
    for a in range(-1, 3):
        w = 1.0
        for b in range(-1, 3):
            if b != a:
                w *= (x - b) / (a - b)
        s += w * values[(i + a) % j]
    return s


@njit(inline="always", nogil=True, cache=True)
def locate(edges_or_nodes, x):
    """Index ``k`` with ``a[k] <= x < a[k + 1]`` in sorted ``a`` (clamped to ``[0, len(a) - 2]``)."""
    lo = 0
    hi = edges_or_nodes.shape[0] - 1
    if x <= edges_or_nodes[0]:
        return 0
    if x >= edges_or_nodes[hi]:
        return hi - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if edges_or_nodes[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@njit(inline="always", nogil=True, cache=True)
def _theta_cubic(thetas, values, theta):
    """Cubic Lagrange interpolation through the four nodes nearest ``theta`` (fewer when there are fewer)."""
    k = thetas.shape[0]
    if k == 1:
        return values[0]
    i = locate(thetas, theta)
    first = min(max(i - 1, 0), max(k - 4, 0))
    last = min(first + 4, k)
    s = 0.0
    for a in range(first, last):
        w = 1.0
        for b in range(first, last):
            if b != a:
                w *= (theta - thetas[b]) / (thetas[a] - thetas[b])
        s += w * values[a]
    return s


def norm_coordinate(theta: np.ndarray | float) -> np.ndarray:
    """``s = -log(cos theta)``, the coordinate the normalizer is interpolated in (see
    :func:`normalizer_at`)."""
    return -np.log(np.cos(np.asarray(theta, dtype=np.float64)))


@njit(nogil=True, cache=True)
def normalizer_at(symmetry, norm_s, norm, norm_log, cos_theta, phi):
    """``I`` at ``(theta, phi)`` (``phi`` folded into the layout's range) from the nodes' ``norm (K, J)``.

    Interpolated in ``s = -log(cos theta)`` (``norm_s``, increasing), of ``log I`` when every node's ``I``
    is positive (``norm_log``): a normalizer that behaves like a power of ``cos theta_o`` near the horizon
    (Minnaert's, Ward's) is then a straight line, and one that is even in ``theta`` (all of them, at normal
    incidence) is smooth in ``s ~ theta^2 / 2``. For MIRROR, ``norm`` holds each row's cosine-series
    coefficients in ``2 phi``."""
    k = norm_s.shape[0]
    s = -math.log(max(cos_theta, 1e-300))
    if symmetry == ISOTROPIC:
        v = _theta_cubic(norm_s, norm[:, 0], s)
    else:
        row = np.empty(k)
        for i in range(k):
            if symmetry == MIRROR:
                row[i] = _cosine_series(norm[i], phi)
            else:
                row[i] = _periodic_cubic(norm[i], phi)
        v = _theta_cubic(norm_s, row, s)
    return math.exp(v) if norm_log else v


def interpolation_errors(coords: np.ndarray, values: np.ndarray) -> np.ndarray:
    """For each node, the error of predicting its value from the other nodes (cubic through the nearest
    four), scaled to the spacing of the layout itself (``/ 8``: a cubic's error at the middle of its nodes'
    interval against at a node skipped between them, ``(1/2)(1/2)(3/2)(3/2) = 9/16`` against ``2 * 1 * 1 * 2``).

    ``coords, values (K,)`` (as :func:`normalizer_at` interpolates: ``log I`` errors are relative already);
    returns ``(K,)``; the first and last nodes get 0."""
    thetas = coords
    k = len(thetas)
    out = np.zeros(k)
    if k < 5:
        return out
    for i in range(1, k - 1):
        others = [j for j in range(k) if j != i]
        near = sorted(others, key=lambda j: abs(thetas[j] - thetas[i]))[:4]
        near.sort()
        x = thetas[i]
        pred = 0.0
        for a in near:
            w = 1.0
            for b in near:
                if b != a:
                    w *= (x - thetas[b]) / (thetas[a] - thetas[b])
            pred += w * values[a]
        out[i] = abs(pred - values[i]) / 8.0
    return out
