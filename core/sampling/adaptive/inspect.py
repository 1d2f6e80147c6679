"""What a view of the adaptive sampler shows: the tree serving one outgoing direction, on its disk.

Plain numpy over a sampler's table (no Qt): the app's sampler view, the docs' figures and the tests read
these. A tree lives on the square; the concentric map draws it on the unit disk, where its leaves are curved
quads (:func:`leaf_image` rasterizes them by mapping every pixel back to the square).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from core.sampling.adaptive.frames import _frame
from core.sampling.adaptive.layout import FULL, ISOTROPIC, TWO_PI
from core.sampling.adaptive.maps import HALF_PI, HALF_VECTOR, ORTHOGRAPHIC, PROJECTIONS, QUARTER_PI, RIM
from core.sampling.adaptive.pack import CDF_ONE, LEAF_GRID
from core.sampling.adaptive.records import AdaptiveTable
from core.sampling.adaptive.sampler import AdaptiveSampler


class TreeView(NamedTuple):
    """The tree that serves ``wo`` (see :func:`tree_view`)."""

    projection: str
    """``"orthographic"``, ``"equal_area"``, ``"rim"`` (disks of ``wi``) or ``"half_vector"`` (disk of ``h``)."""
    follow: bool
    """The tree's frame is turned so that ``wo`` lies in its x-z plane (else: the local frame, folded)."""
    tree: int
    node_deg: tuple[float, float]
    """The node's ``(theta, phi)`` in degrees (phi in the folded range)."""
    cell_deg: tuple[float, float, float, float]
    """The node's cell: ``theta_lo, theta_hi, phi_lo, phi_hi`` in degrees."""
    boxes: np.ndarray
    """``(k, 4)``: each leaf's square ``a0, b0, a1, b1`` in ``[0, 1]^2``."""
    density: np.ndarray
    """``(k,)``: the mean over each leaf of the density the table's mode draws from (per unit square area:
    1 on average): the rejection-free density in a rejection-free table, the trials' density ``K_L q / V``
    in an exact one (whose leaves do not keep ``q``'s own masses: their stored corners are relative)."""
    bound: np.ndarray
    """``(k,)``: the exact mode's envelope over ``density``: ``V`` on every leaf of an exact table (the
    envelope is ``V`` times the trials' density); 1 in a rejection-free table, which has no envelope."""
    acceptance: float
    """The exact mode's acceptance per trial, ``1 / V``."""
    normalizer: float
    """``I(wo)`` (the exact mode's; 0 beyond the last node, where it draws the cosine density)."""
    mirror: tuple[float, float]
    """The signs ``(sx, sy)`` applied to the local x and y before the tree's frame (-1 where a mirror-symmetric
    table folds ``wo`` into the first quadrant; else 1)."""


def _tree_of(table: AdaptiveTable, wo: np.ndarray) -> int:
    mu, phi, *_ = _frame(table.symmetry, float(wo[0]), float(wo[1]), float(wo[2]))
    k = int(np.clip(np.searchsorted(table.cell_mu, mu, side="right") - 1, 0, len(table.thetas) - 1))
    j = len(table.phis)
    if table.symmetry == ISOTROPIC or j == 1:
        jj = 0
    elif table.symmetry == FULL:
        jj = int(math.floor(phi / TWO_PI * j + 0.5)) % j
    else:
        jj = int(np.clip(np.searchsorted(table.phi_edges, phi, side="right") - 1, 0, j - 1))
    return k * j + jj


def leaves_of(table: AdaptiveTable, t: int) -> tuple[np.ndarray, np.ndarray]:
    """``(boxes (k, 4), leaf index (k,))`` of tree ``t``, leaves in the table's order."""
    idx = np.arange(int(table.leaf_base[t]), int(table.leaf_base[t + 1]), dtype=np.int64)
    cell = table.leaf_cell[idx].astype(np.int64)
    scale = 1.0 / (1 << LEAF_GRID)
    x0 = (cell & ((1 << LEAF_GRID) - 1)) * scale
    y0 = ((cell >> LEAF_GRID) & ((1 << LEAF_GRID) - 1)) * scale
    h = 0.5 ** (cell >> (2 * LEAF_GRID)).astype(np.float64)
    return np.column_stack([x0, y0, x0 + h, y0 + h]).reshape(-1, 4), idx


def leaf_probabilities(table: AdaptiveTable, t: int) -> np.ndarray:
    """``(k,)``: the probability each leaf of tree ``t`` is chosen with (the differences of its ``cdf``)."""
    cdf = table.cdf[int(table.leaf_base[t]) : int(table.leaf_base[t + 1])].astype(np.int64)
    return np.diff(cdf, prepend=0) / CDF_ONE


def tree_view(sampler: AdaptiveSampler, wo: np.ndarray) -> TreeView:
    """The tree serving ``wo (3,)`` in ``sampler``'s table, with what the exact mode makes of it there."""
    table = sampler.table
    wo = np.asarray(wo, dtype=np.float64).reshape(3)
    t = _tree_of(table, wo)
    *_, sx, sy = _frame(table.symmetry, float(wo[0]), float(wo[1]), float(wo[2]))
    boxes, idx = leaves_of(table, t)
    area = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    density = leaf_probabilities(table, t) / area
    # the exact mode's envelope is V times its trials' density (see draw.py); a rejection-free table has none
    bound = np.full(len(idx), float(table.total[t]) if table.exact else 1.0)
    k, j = divmod(t, len(table.phis))
    th_lo, th_hi = np.degrees(table.theta_edges[k : k + 2])
    if table.symmetry == ISOTROPIC:
        ph_lo, ph_hi = 0.0, 360.0
    else:
        ph_lo, ph_hi = np.degrees(table.phi_edges[j : j + 2])
    return TreeView(
        projection=PROJECTIONS[int(table.projection[t])],
        follow=bool(table.follow[t]),
        tree=t,
        node_deg=(float(np.degrees(table.thetas[k])), float(np.degrees(table.phis[j]))),
        cell_deg=(float(th_lo), float(th_hi), float(ph_lo), float(ph_hi)),
        boxes=boxes,
        density=density,
        bound=bound,
        acceptance=float(sampler.acceptance(wo)[0]),
        normalizer=float(sampler.normalizer(wo)[0]),
        mirror=(float(sx), float(sy)),
    )


def _tree_frame(table: AdaptiveTable, wo: np.ndarray) -> tuple[float, float, float, float]:
    """``(cos, sin, sx, sy)``: the turn and the mirror signs from the local frame to the tree's (as the draws'
    ``_tree_frame``: no turn for a tree kept in the local frame)."""
    _, _, c, s, sx, sy = _frame(table.symmetry, float(wo[0]), float(wo[1]), float(wo[2]))
    if not table.follow[_tree_of(table, wo)]:
        c, s = 1.0, 0.0
    return c, s, sx, sy


def to_tree_disk(sampler: AdaptiveSampler, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Disk points ``(n, 2)`` of directions ``wi (n, 3)`` as the tree serving ``wo`` sees them (its frame
    and its disk: of ``wi``, or of the half vector); NaN for directions it cannot hold (below the horizon)."""
    table = sampler.table
    wo = np.asarray(wo, dtype=np.float64).reshape(3)
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float64))
    t = _tree_of(table, wo)
    c, s, sx, sy = _tree_frame(table, wo)
    v = wi
    if int(table.projection[t]) == HALF_VECTOR:
        h = wi + wo
        n = np.linalg.norm(h, axis=1, keepdims=True)
        v = np.where(n > 0, h / np.where(n > 0, n, 1.0), np.nan)
    x, y, z = sx * v[:, 0], sy * v[:, 1], v[:, 2]
    x, y = c * x + s * y, -s * x + c * y
    out = np.full((len(v), 2), np.nan)
    up = z > 0
    if int(table.projection[t]) == ORTHOGRAPHIC:
        out[up] = np.stack([x[up], y[up]], axis=1)
    elif int(table.projection[t]) == RIM:
        root = np.sqrt(z[up])
        scale = 1.0 / np.sqrt((1.0 + root) * (1.0 + z[up]))
        out[up] = np.stack([x[up] * scale, y[up] * scale], axis=1)
    else:
        scale = 1.0 / np.sqrt(1.0 + z[up])
        out[up] = np.stack([x[up] * scale, y[up] * scale], axis=1)
    return out


def from_tree_disk(sampler: AdaptiveSampler, wo: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The inverse of :func:`to_tree_disk`: directions ``wi (n, 3)`` in the local frame of the tree disk's
    points ``(n, 2)``. On a half-vector disk the point is ``h`` and ``wi = 2 (wo.h) h - wo``. Rows are NaN for
    points outside the disk and for ``wi`` at or below the horizon."""
    table = sampler.table
    wo = np.asarray(wo, dtype=np.float64).reshape(3)
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    t = _tree_of(table, wo)
    projection = int(table.projection[t])
    c, s, sx, sy = _tree_frame(table, wo)
    x, y = pts[:, 0], pts[:, 1]
    r2 = x * x + y * y
    with np.errstate(invalid="ignore"):
        if projection == ORTHOGRAPHIC:
            z = np.sqrt(1.0 - r2)
        elif projection == RIM:
            root = 1.0 - r2
            k = np.sqrt((1.0 + root) * (1.0 + root * root))
            x, y, z = x * k, y * k, root * root
        else:
            k = np.sqrt(2.0 - r2)
            x, y, z = x * k, y * k, 1.0 - r2
    v = np.stack([sx * (c * x - s * y), sy * (s * x + c * y), z], axis=1)
    if projection == HALF_VECTOR:
        v = 2.0 * (v @ wo)[:, None] * v - wo
    bad = ~(r2 <= 1.0) | ~(v[:, 2] > 0.0)
    v[bad] = np.nan
    return v


def square_to_disk(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The concentric map, vectorized: points of the square ``[0, 1]^2`` to the unit disk (as
    :func:`core.sampling.adaptive.maps.square_to_disk`)."""
    u = 2.0 * np.asarray(a, dtype=np.float64) - 1.0
    v = 2.0 * np.asarray(b, dtype=np.float64) - 1.0
    wide = np.abs(u) > np.abs(v)
    r = np.where(wide, u, v)
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = np.where(wide, QUARTER_PI * (v / u), HALF_PI - QUARTER_PI * (u / v))
    phi = np.where(r == 0.0, 0.0, phi)
    return r * np.cos(phi), r * np.sin(phi)


def disk_to_square(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The inverse concentric map, vectorized: disk points to the square ``[0, 1]^2``."""
    r = np.hypot(x, y)
    phi = np.arctan2(y, x)
    phi = np.where(phi < -0.25 * np.pi, phi + 2.0 * np.pi, phi)
    q = 0.25 * np.pi
    u = np.select(
        [phi < q, phi < 3 * q, phi < 5 * q],
        [r, (0.5 * np.pi - phi) / q * r, -r],
        (phi - 1.5 * np.pi) / q * r,
    )
    v = np.select(
        [phi < q, phi < 3 * q, phi < 5 * q],
        [phi / q * r, r, (phi - np.pi) / q * (-r)],
        -r,
    )
    return np.clip(0.5 * (u + 1.0), 0.0, 1.0), np.clip(0.5 * (v + 1.0), 0.0, 1.0)


def _spread_bits(i: np.ndarray) -> np.ndarray:
    """The bits of ``i`` (< 2^32) moved to the even positions of a 64-bit word (half of a Morton code)."""
    i = i.astype(np.uint64) & np.uint64(0xFFFFFFFF)
    for shift, mask in ((16, 0x0000FFFF0000FFFF), (8, 0x00FF00FF00FF00FF), (4, 0x0F0F0F0F0F0F0F0F),
                        (2, 0x3333333333333333), (1, 0x5555555555555555)):  # fmt: skip
        i = (i | (i << np.uint64(shift))) & np.uint64(mask)
    return i


DEPTH = 31
"""Leaves are found by their Morton codes at this depth (deeper than any tree: ``max_level`` is at most 14)."""


def _codes(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Morton codes at :data:`DEPTH` of square points (a point on an edge between cells goes to the
    cell on its upper side, as in the draws)."""
    n = 1 << DEPTH
    ia = np.clip(np.floor(np.asarray(a, dtype=np.float64) * n), 0, n - 1)
    ib = np.clip(np.floor(np.asarray(b, dtype=np.float64) * n), 0, n - 1)
    return _spread_bits(ia) | (_spread_bits(ib) << np.uint64(1))


def _find(boxes: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """The rows of ``boxes (k, 4)`` (dyadic squares tiling the square) holding the points of ``codes``: a
    leaf at depth ``l`` is one run of ``4^(DEPTH - l)`` codes starting at its corner's, and the runs of a
    tiling partition ``[0, 4^DEPTH)``, so a sorted search of the runs' starts finds each point's leaf."""
    level = np.rint(-np.log2(boxes[:, 2] - boxes[:, 0])).astype(np.int64)
    if level.max() > DEPTH:
        raise ValueError(f"leaves deeper than level {DEPTH} cannot be looked up (found {level.max()})")
    start = _codes(boxes[:, 0], boxes[:, 1])  # (a box's corner is a whole number of cells at DEPTH)
    order = np.argsort(start, kind="stable")
    pos = np.searchsorted(start[order], codes, side="right") - 1
    return order[np.maximum(pos, 0)]


def leaf_lookup(boxes: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The leaf (row of ``boxes (k, 4)``, the dyadic squares of a tree, tiling ``[0, 1]^2``) holding each
    square point ``(a, b)``; vectorized (Morton codes and a sorted search, no loop over leaves)."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not len(boxes):
        return np.full(np.shape(a), -1, dtype=np.int64)
    return _find(boxes, _codes(a, b))


@functools.lru_cache(maxsize=8)
def _disk_pixels(size: int) -> tuple[np.ndarray, np.ndarray]:
    """``(inside (size, size) bool, codes (m,))``: the pixels of a ``size``-square image of the disk whose
    centre lies inside it, and their points' Morton codes on the square (the same for every tree)."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    inside = x * x + y * y < 1.0
    codes = _codes(*disk_to_square(x[inside], y[inside]))
    inside.flags.writeable = False
    codes.flags.writeable = False
    return inside, codes


def leaf_image(view: TreeView, values: np.ndarray, size: int) -> np.ndarray:
    """An image ``(size, size)`` of the disk (``[-1, 1]^2``, row 0 at y = -1) holding, at each pixel inside
    the disk, ``values[leaf]`` of the leaf its centre maps to (NaN outside the disk)."""
    img = np.full((size, size), np.nan)
    boxes = np.asarray(view.boxes, dtype=np.float64).reshape(-1, 4)
    if len(boxes):
        inside, codes = _disk_pixels(int(size))
        img[inside] = np.asarray(values, dtype=np.float64)[_find(boxes, codes)]
    return img


def leaf_outlines(view: TreeView, points_per_edge: int = 8) -> np.ndarray:
    """Each leaf's outline on the disk, ``(k, 4 * points_per_edge + 1, 2)``: the square's edges, counter-
    clockwise from ``(a0, b0)``, through the concentric map (curved; closed)."""
    boxes = np.asarray(view.boxes, dtype=np.float64).reshape(-1, 4)
    t = np.linspace(0.0, 1.0, points_per_edge, endpoint=False)
    one, zero = np.ones_like(t), np.zeros_like(t)
    # (fraction of the way from a0 to a1, from b0 to b1) around the square
    fa = np.concatenate([t, one, 1.0 - t, zero, [0.0]])
    fb = np.concatenate([zero, t, one, 1.0 - t, [0.0]])
    a0, b0, a1, b1 = (boxes[:, i : i + 1] for i in range(4))
    x, y = square_to_disk(a0 + (a1 - a0) * fa, b0 + (b1 - b0) * fb)
    return np.stack([x, y], axis=-1)
