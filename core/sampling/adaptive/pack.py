"""A material's trees packed into one :class:`~core.sampling.adaptive.records.AdaptiveTable` of flat arrays
(the leaves' corners, cumulative probabilities and guide tables) that the compiled draws read.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from core.sampling.adaptive.layout import THETA_END
from core.sampling.adaptive.maps import ORTHOGRAPHIC
from core.sampling.adaptive.records import CELL_LUT, AdaptiveTable
from core.sampling.adaptive.tree import TreeArrays
from core.sampling.distributions import fill_guide

if TYPE_CHECKING:
    from core.sampling.adaptive.table import _Node


def pack_table(symmetry: int, thetas: np.ndarray, phis: np.ndarray, theta_edges: np.ndarray,
          phi_edges: np.ndarray, grid: list[list[_Node]], norm: tuple[np.ndarray, int],
          exact: bool) -> AdaptiveTable:  # fmt: skip
    children, corners, cells, cdfs, guides, roots, projections, totals = [], [], [], [], [], [], [], []
    masses = []
    leaf_base = [0]
    node_base = 0
    for row in grid:
        for n in row:
            tr = n.tree
            leaves = _leaves(tr)
            cells.append(_leaf_cells(tr, leaves))
            corner16, widen = _leaf_corners(tr.corners)
            weight = 0.25 ** tr.level[leaves].astype(np.float64) * tr.corners.mean(axis=1)
            if exact:  # K_L rounded up to float32 as before, times what the stored corners' rounding can cost
                weight *= (
                    np.nextafter(tr.bound.astype(np.float32), np.float32(np.inf)).astype(np.float64) * widen
                )
            cdf, guide, total = _leaf_cdf(weight, exact)
            cdfs.append(cdf)
            guides.append(guide)
            totals.append(total if exact else 1.0)
            if not exact:
                child = tr.child.astype(np.int64)
                inner = child >= 0
                child[inner] += node_base
                child[~inner] -= leaf_base[-1]
                children.append(child)
                masses.append(_node_mass(tr, cdf))
            roots.append(node_base)
            node_base += 0 if exact else len(tr.child)
            corners.append(corner16)
            projections.append(n.projection)
            leaf_base.append(leaf_base[-1] + len(weight))
    norm_table, norm_log = norm
    cell_mu = -np.cos(theta_edges)
    starts = -1.0 + np.arange(CELL_LUT) / CELL_LUT
    lut = np.clip(np.searchsorted(cell_mu, starts, side="right") - 1, 0, len(thetas) - 1)
    phi_edges = np.ascontiguousarray(phi_edges, dtype=np.float64)
    return AdaptiveTable(
        symmetry=int(symmetry),
        flat=int(all(n.projection == ORTHOGRAPHIC for row in grid for n in row)),
        follow=np.array([n.follow for row in grid for n in row], dtype=np.int64),
        thetas=np.ascontiguousarray(thetas, dtype=np.float64),
        phis=np.ascontiguousarray(phis, dtype=np.float64),
        theta_edges=np.ascontiguousarray(theta_edges, dtype=np.float64),
        node_mu=-np.cos(thetas),
        cell_mu=cell_mu,
        cell_lut=lut.astype(np.int32),
        phi_edges=phi_edges,
        edge_cos=np.cos(phi_edges),
        edge_sin=np.sin(phi_edges),
        projection=np.array(projections, dtype=np.int64),
        exact=int(exact),
        root=np.array(roots, dtype=np.int64),
        child=np.concatenate(children).astype(np.int32) if children else np.zeros(0, dtype=np.int32),
        node_mass=np.concatenate(masses).astype(np.uint32) if masses else np.zeros(0, dtype=np.uint32),
        leaf_base=np.array(leaf_base, dtype=np.int64),
        leaf_cell=np.concatenate(cells).astype(np.uint32),
        corners=np.ascontiguousarray(np.concatenate(corners), dtype=np.uint16),
        cdf=np.concatenate(cdfs).astype(np.uint32),
        guide=np.concatenate(guides).astype(np.uint16),
        total=np.array(totals, dtype=np.float64),
        norm=norm_table,
        norm_log=int(norm_log),
        cos_min=float(math.cos(THETA_END)),
    )


LEAF_GRID = 14
"""Leaf origins are stored on the ``2^-14`` grid (``max_level`` is at most 14)."""


def _leaves(tree: TreeArrays) -> np.ndarray:
    """The node of every leaf, in leaf order."""
    nodes = np.flatnonzero(tree.child < 0)
    out = np.empty(len(nodes), dtype=np.int64)
    out[-1 - tree.child[nodes]] = nodes
    return out


def _node_mass(tree: TreeArrays, cdf: np.ndarray) -> np.ndarray:
    """Each node's count of ``2^-31`` (:attr:`AdaptiveTable.node_mass`) from its tree's cumulative leaf
    counts: a leaf's own, then level by level upwards the sum of the four children (a node's children are
    made after it, one level deeper)."""
    counts = np.diff(cdf, prepend=0)
    child = tree.child.astype(np.int64)
    mass = np.zeros(len(child), dtype=np.int64)
    leaf = child < 0
    mass[leaf] = counts[-1 - child[leaf]]
    level = tree.level
    for lv in range(int(level.max(initial=0)) - 1, -1, -1):
        inner = np.flatnonzero(~leaf & (level == lv))
        first = child[inner]
        mass[inner] = mass[first] + mass[first + 1] + mass[first + 2] + mass[first + 3]
    return mass


def _leaf_cells(tree: TreeArrays, leaves: np.ndarray) -> np.ndarray:
    """Each leaf's packed origin and level (:attr:`AdaptiveTable.leaf_cell`)."""
    level = tree.level[leaves].astype(np.int64)
    if len(level) and int(level.max()) > LEAF_GRID:
        raise ValueError(f"a leaf at level {int(level.max())}: the table stores leaves to level {LEAF_GRID}")
    scale = float(1 << LEAF_GRID)
    ix = np.rint(tree.x0[leaves] * scale).astype(np.int64)
    iy = np.rint(tree.y0[leaves] * scale).astype(np.int64)
    return (ix | (iy << LEAF_GRID) | (level << (2 * LEAF_GRID))).astype(np.uint32)


CORNER_ONE = 65535
"""A leaf's largest corner value as stored (:attr:`AdaptiveTable.corners`)."""
CDF_ONE = 1 << 31
"""A tree's total probability in the stored ``cdf``'s units (:attr:`AdaptiveTable.cdf`): ``2^-31`` each."""
MAX_TREE_LEAVES = 1 << 16
"""Leaves a tree may have in a table (``guide`` holds indices within a tree as ``uint16``; a tree of
``capacity`` 16 384 nodes has at most 12 289)."""


def _leaf_corners(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(stored (L, 4) uint16, widen (L,))``: each leaf's corner values over its largest, in units of
    ``1 / CORNER_ONE``, rounded up (a leaf's density depends on its corners' ratios only), and the factor
    ``widen >= 1`` by which a bound of ``g / q`` over the leaf must grow to bound ``g / q'``, ``q'`` the
    density of the stored corners: ``q / q' <= max_k (c_k / s_k) * sum(s) / sum(c)`` (a bilinear
    interpolant's ratio lies between its corners' ratios), at most ``1 + 3 / CORNER_ONE``."""
    top = corners.max(axis=1, keepdims=True)
    if not np.all(top > 0.0):  # (the floor keeps every corner positive)
        raise ValueError("a leaf without a positive corner value")
    stored = np.clip(np.ceil(corners / top * CORNER_ONE), 1, CORNER_ONE)
    widen = np.max(corners / stored, axis=1) * stored.sum(axis=1) / corners.sum(axis=1)
    return stored.astype(np.uint16), np.maximum(widen, 1.0) * (1.0 + 1e-12)


def _leaf_cdf(weight: np.ndarray, envelope: bool) -> tuple[np.ndarray, np.ndarray, float]:
    """``(cdf, guide, total)`` of one tree's leaf weights (:attr:`AdaptiveTable.cdf`, ``guide``, ``total``).

    The cumulative counts of ``2^-31`` end at exactly ``CDF_ONE``: a uniform ``u`` on the ``2^-53`` grid
    picks leaf ``L`` with probability ``P_L = n_L / 2^31`` exactly (``u 2^31`` is exact and compared with
    integers). Each count is rounded up from ``w_L S / W`` (``W`` the weights' sum, ``S = CDF_ONE - L``), so
    no leaf of positive weight has probability 0, and what is left of ``CDF_ONE`` goes to the heaviest leaf.
    For the exact mode (``envelope``), ``total`` is the envelope mass ``V`` with ``V P_L >= w_L`` for every
    leaf, the largest of ``w_L CDF_ONE / n_L``: at most ``W CDF_ONE / S`` (``1 + 6e-6`` times ``W`` for the
    largest trees), so the envelope ``V p`` the draws use still bounds ``g / c``. Otherwise ``total`` is
    ``W``."""
    leaves = len(weight)
    if leaves > MAX_TREE_LEAVES:
        raise ValueError(f"a tree of {leaves} leaves: a table holds at most {MAX_TREE_LEAVES} per tree")
    total = float(weight.sum())
    if not total > 0.0:  # (no tree has an empty density: the floor keeps every corner positive)
        weight = np.ones_like(weight)
        total = float(leaves)
    share = CDF_ONE - leaves
    counts = np.ceil(weight * (share / total)).astype(np.int64)
    counts[weight <= 0.0] = 0
    counts[int(np.argmax(weight))] += CDF_ONE - int(counts.sum())
    cdf = np.cumsum(counts)
    guide = np.empty(leaves, dtype=np.int64)  # the first leaf whose count passes each of L equal steps
    fill_guide(cdf, 0, leaves, 0.0, leaves / CDF_ONE, guide)
    if envelope:
        positive = counts > 0
        total = float(np.max(weight[positive] * CDF_ONE / counts[positive])) * (1.0 + 1e-12)
    return cdf, np.minimum(guide, leaves - 1).astype(np.uint16), total
