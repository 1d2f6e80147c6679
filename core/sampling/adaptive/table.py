"""A material's adaptive table: every node's tree, made at once, in parallel, and stored on disk.

:func:`build_table` lays out the nodes (:mod:`core.sampling.adaptive.layout`), builds their trees
(:mod:`core.sampling.adaptive.tree`) on threads (the compiled builder releases the GIL), halves the intervals
where the material asks for it, and packs the trees into one :class:`AdaptiveTable` of flat arrays that the
compiled draws (:mod:`core.sampling.adaptive.draw`) read.
"""

from __future__ import annotations

import hashlib
import inspect
import math
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from core.cache import TableCache, table_key
from core.model import BRDF
from core.sampling.adaptive.layout import (
    FULL,
    HALF_PI,
    INITIAL_THETAS_DEG,
    ISOTROPIC,
    MIRROR,
    THETA_END,
    TWO_PI,
    cell_edges,
    interpolation_errors,
    norm_coordinate,
    normalizer_table,
    phi_nodes,
    series_coefficients,
)
from core.sampling.adaptive.maps import EQUAL_AREA, HALF_VECTOR, ORTHOGRAPHIC, RIM
from core.sampling.adaptive.target import g_at, make_view
from core.sampling.adaptive.tree import (
    ACCEPT_MARGIN,
    ANISOTROPIC_BOUND_SAFETY,
    BuildSettings,
    TreeArrays,
    TreeShape,
    bound_tree,
    shape_tree,
    view_integral,
)
from core.threads import thread_budget

TABLE_FORMAT = 12
"""Bumped when the stored arrays change meaning."""

CELL_LUT = 512


@dataclass(frozen=True)
class TableOptions:
    """How a material's table is made (the adaptive sampler's options; see ``docs/adaptive.md``)."""

    n_max: float = 2.0
    """Mean trials per sample the exact mode's envelope aims at (the seed's knob; > 1)."""
    warp_tol: float = 0.01
    """Leaves split until the rejection-free density's relative variance (chi^2 divergence from the node's,
    then from the cell's mixture of ``f cos``), estimated on the stencils, is at most this."""
    quad_tol: float = 1e-4
    """Relative error of the normalizer's values (exact mode), by the quadrature's own estimate."""
    warp_chi2: float = 0.05
    """Halve an interval while a node's rejection-free density has a chi^2 above this at its cell's edge."""
    warp_chi2_anisotropic: float = 0.2
    """The same for an anisotropic material, whose polar nodes each carry ``phi_count`` trees: a halving costs
    four times as much there, and the balance of variance against build, memory and speed lies higher
    (``python bench/adaptive.py --models ward,ashikhmin_shirley --option warp_chi2_anisotropic=0.05``: Ward
    sx=0.05 sy=0.25's warp table 2.9 s / 2.7 MB at 0.05 against 0.45 s / 0.47 MB at 0.2, with 1.9x the
    furnace variance but 2.6x the draws per second relative to cosine's (a table 1/6 the size walks faster),
    so the efficiency relative to cosine's in the same run went 21 -> 28; Ashikhmin-Shirley nu=10 nv=200:
    3.2 s / 2.5 MB -> 0.84 s / 0.81 MB, efficiency 88 -> 77)."""
    norm_tol: float = 5e-5
    """Halve an interval of the normalizer's own polar angles (not the trees') while its interpolation error
    is estimated above this (exact mode)."""
    phi_count: int = 4
    """Azimuth nodes of an anisotropic material (over the quadrant when it is mirror-symmetric)."""
    max_thetas: int = 48
    """At most this many polar nodes, and twice as many polar angles of the exact mode's normalizer (its own:
    each is a view's integral, no tree; see :func:`_normalizer`)."""
    rounds: int = 12
    """Rounds of halving intervals at most (1: the initial layout only, a coarse table in a fraction of the
    time: exact all the same, with more trials and a larger warp variance)."""
    min_spacing_deg: float = 0.05
    """Intervals are not halved below this."""
    parameterization: str = "auto"
    """``"wi"`` (the equal-area disk of the incident direction), ``"half"`` (of the half vector), or
    ``"auto"``: whichever moves the material's lobe less between neighbouring views."""
    bounds: bool = True
    """Whether the trees carry the exact mode's bounds (steps 3 and 3b of the construction). The rejection-free
    mode never reads them, and its tables are built without: the bounds' refinement and probes are most of an
    anisotropic material's build. Set by the sampler from its mode, not a user's option."""
    base_level: int = 3
    max_level: int = 12
    capacity: int = 16384
    """Nodes a tree may have (at most ``2^16``: a table indexes a tree's leaves in 16 bits)."""

    def settings(self) -> BuildSettings:
        return BuildSettings(
            n_max=self.n_max, warp_tol=self.warp_tol, quad_tol=self.quad_tol, base_level=self.base_level,
            max_level=self.max_level, capacity=self.capacity,
        )  # fmt: skip


class AdaptiveTable(NamedTuple):
    """Every tree of a material in flat arrays (``K`` polar nodes, ``J`` azimuth nodes, tree ``t = k J + j``,
    ``N`` tree nodes, ``L`` leaves). Read by the compiled draws."""

    symmetry: int
    """:data:`~core.sampling.adaptive.layout.ISOTROPIC`, ``MIRROR`` or ``FULL``."""
    flat: int
    """1: the BRDF is Lambertian (``f`` the same for every pair of directions): every tree is one uniform
    level on the orthographic disk, whose density is the cosine-weighted hemisphere's, so both modes draw
    that density directly (the same density; no tree to descend)."""
    follow: np.ndarray
    """``(K * J,)`` int64, per tree: 1, the tree's frame is turned with ``wo``'s azimuth (``wo`` in its x-z
    plane); 0, the tree is kept in the local frame, ``wo`` only folded into the quadrant (half-vector trees of
    an anisotropic BRDF)."""
    thetas: np.ndarray
    """``(K,)`` polar nodes (radians), increasing; ``thetas[0] = 0``."""
    phis: np.ndarray
    """``(J,)`` azimuth nodes."""
    theta_edges: np.ndarray
    """``(K + 1,)`` cells in theta (the exact mode's nearest node)."""
    node_mu: np.ndarray
    """``(K,)``: ``-cos(thetas)``, increasing: the draws bracket and locate ``wo`` by its ``z`` (no
    trigonometry), and blend the two nodes around it linearly in ``cos theta``."""
    cell_mu: np.ndarray
    """``(K + 1,)``: ``-cos(theta_edges)``."""
    cell_lut: np.ndarray
    """``(CELL_LUT,)`` int32: for ``mu`` in bin ``i`` of ``[-1, 0]``, the first cell that can hold it (a
    lookup and a step or two instead of a binary search)."""
    phi_edges: np.ndarray
    """``(J + 1,)`` cells in phi."""
    edge_cos: np.ndarray
    """``(J + 1,)``: ``cos(phi_edges)``, and ``edge_sin`` their sines: the draws find ``wo``'s azimuth cell
    from its unit vector without trigonometry (and, allocating nothing, take them from the table)."""
    edge_sin: np.ndarray
    projection: np.ndarray
    """``(K * J,)`` int64: each tree's disk projection."""
    exact: int
    """1: the exact mode's table (its leaves chosen by the envelope ``K_L q_L``, no tree structure kept: the
    exact mode's pdf is ``f cos / I``); 0: the rejection-free mode's (leaves chosen by ``q_L``)."""
    root: np.ndarray
    """``(K * J,)`` int64: each tree's root in ``child`` (the rejection-free mode's pdf locates a point by it)."""
    child: np.ndarray
    """``(N,)`` int32: a node's first child, or ``-1 - leaf`` (global leaf index); empty in an exact table."""
    node_mass: np.ndarray
    """``(N,)`` uint32: a node's probability in units of ``2^-31``, the sum of its leaves' ``cdf`` counts
    (``2^31`` at a root): a caller's point descends the tree by it, both coordinates at every level
    (:func:`~core.sampling.adaptive.draw.descend_at`); empty in an exact table (format 12)."""
    leaf_base: np.ndarray
    """``(K * J + 1,)`` int64: tree ``t``'s leaves are ``leaf_base[t] : leaf_base[t + 1]`` of the leaf arrays."""
    leaf_cell: np.ndarray
    """``(L,)`` uint32: a leaf's place on the square, ``ix | iy << 14 | level << 28`` (origin
    ``(ix, iy) / 2^14``, side ``2^-level``; ``max_level <= 14``): the draws go from the chosen leaf to its
    square without a descent."""
    corners: np.ndarray
    """``(L, 4)`` uint16: the bilinear density's corner values ``(x0, y0), (x1, y0), (x0, y1), (x1, y1)`` over
    the leaf's largest, in units of ``1 / 65535``, rounded up (a leaf's density on the square is
    ``bilinear / (mean * h^2)`` from these stored values, whatever their scale: exact; an exact table's
    bounds are widened for the rounding, see :func:`_leaf_corners`)."""
    cdf: np.ndarray
    """``(L,)`` uint32: per tree, the cumulative probability of its leaves in units of ``2^-31`` (ending at
    exactly ``2^31``): the rejection-free mode's ``q_L``, the exact mode's ``K_L q_L / V``, each rounded up
    (:func:`_leaf_cdf`). A leaf's probability is the difference of two entries, the very interval a uniform
    falls in to choose it: the densities are exact whatever rounding made the entries."""
    guide: np.ndarray
    """``(L,)`` uint16: per tree of ``n`` leaves, ``guide[k]`` the first leaf (counted within the tree) whose
    ``cdf`` exceeds ``k / n`` (Chen and Asau's guide table: a lookup and a step or two instead of a search
    or a descent)."""
    total: np.ndarray
    """``(K * J,)`` float64: the exact mode's envelope mass ``V`` per tree, ``sum K_L q_L`` widened for the
    stored probabilities' rounding (the acceptance is ``1 / V``; a trial's envelope is ``V`` times its own
    density, see :mod:`~core.sampling.adaptive.draw`); 1 in a rejection-free table."""
    norm: np.ndarray
    """``(NORM_ROWS, J)``: the normalizer's table at the ``cos theta`` of
    :func:`~core.sampling.adaptive.layout.normalizer_grid` (``log I``, or ``I`` when ``norm_log`` is 0;
    MIRROR: cosine-series coefficients), see :func:`~core.sampling.adaptive.layout.normalizer_at`."""
    norm_log: int
    """1 when ``norm`` holds logarithms (every node's ``I > 0``)."""
    cos_min: float
    """The exact mode draws the cosine density where ``cos theta_o`` is below this (beyond the last node)."""


@dataclass
class TableReport:
    """What making a table cost and gave (for ``info()`` and the benchmarks)."""

    seconds: float = 0.0
    evaluations: int = 0
    trees: int = 0
    leaves: int = 0
    rounds: int = 0
    acceptance_min: float = 0.0
    chi2_max_edge: float = 0.0
    chi2_max_phi_edge: float = 0.0
    norm_error_max: float = 0.0
    from_cache: bool = False


# ------------------------------------------------------------------------------------------ symmetry
def symmetry_of(brdf: BRDF, pairs: int = 512, seed: int = 7) -> int:
    """The layout's symmetry: isotropic by trait, or measured so (an anisotropic model at isotropic
    parameters, such as Ward with ``sx = sy``: ``f`` unchanged to 1e-10 under random rotations of both
    directions about the normal); else mirror-symmetric by trait; else none."""
    model = brdf.model
    if model.isotropic:
        return ISOTROPIC
    rng = np.random.default_rng(seed)
    wo = _random_upper(rng, pairs)
    wi = _random_upper(rng, pairs)
    angle = rng.uniform(0.0, TWO_PI, pairs)
    c, s = np.cos(angle), np.sin(angle)

    def rot(w: np.ndarray) -> np.ndarray:
        return np.stack([c * w[:, 0] - s * w[:, 1], s * w[:, 0] + c * w[:, 1], w[:, 2]], axis=1)

    a = brdf.eval(wo, wi)
    b = brdf.eval(rot(wo), rot(wi))
    scale = np.maximum(np.abs(a), 1e-300)
    if np.all(np.abs(a - b) <= 1e-10 * scale + 1e-300):
        return ISOTROPIC
    return MIRROR if model.mirror_symmetric else FULL


def _random_upper(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    v[:, 2] = np.abs(v[:, 2])
    return v


# ------------------------------------------------------------------------------------------ nodes
def is_lambertian(brdf: BRDF, pairs: int = 2048, seed: int = 11) -> bool:
    """Whether ``f`` is the same for every pair of directions (measured: random pairs, and exact mirror
    pairs, where a lobe of any sharpness peaks): then ``pi f`` is flat on the orthographic disk, which one
    level of leaves holds exactly. Measured on the material, not per node: a grid of a node's disk steps over
    a lobe 0.5 degrees wide at grazing (Phong with n = 1e4), which then looked flat."""
    rng = np.random.default_rng(seed)
    wo = _random_upper(rng, pairs)
    wi = np.concatenate([_random_upper(rng, pairs), wo * np.array([-1.0, -1.0, 1.0])])
    f = brdf.eval(np.concatenate([wo, wo]), wi)
    top = float(np.max(f))
    # per channel: a coloured Lambertian BRDF differs between its channels, not between directions
    return top > 0.0 and float(np.max(np.ptp(f, axis=0))) <= 1e-12 * top


@njit(nogil=True, cache=True)
def _motion(mid, p, projection, view_a, view_b):
    """How far the normalized ``g`` moves between two views: the total-variation distance of the two on a
    16 x 16 grid of the square (0: the same density, 1: disjoint)."""
    n = 16
    ga = np.empty(n * n)
    gb = np.empty(n * n)
    for i in range(n):
        for j in range(n):
            a = (i + 0.5) / n
            b = (j + 0.5) / n
            ga[i * n + j] = g_at(mid, p, a, b, projection, view_a)
            gb[i * n + j] = g_at(mid, p, a, b, projection, view_b)
    sa = ga.sum()
    sb = gb.sum()
    if sa <= 0.0 or sb <= 0.0:
        return 1.0
    return 0.5 * np.abs(ga / sa - gb / sb).sum()


PROBE_PAIRS_DEG = ((20.0, 0.0, 30.0, 0.0), (50.0, 0.0, 60.0, 0.0), (72.0, 0.0, 80.0, 0.0))
PROBE_PAIRS_ANISO_DEG = ((45.0, 20.0, 45.0, 35.0), (70.0, 50.0, 70.0, 65.0), (70.0, 10.0, 78.0, 10.0))
AZIMUTH_FLOOR_THETAS_DEG = (20.0, 45.0, 60.0, 70.0, 78.0)
"""Polar angles at which :func:`azimuth_floor` compares the views at an azimuth cell's two edges (below 80
degrees: beyond, every tree is a ``wi`` tree turned with ``wo``)."""


AZIMUTH_FLOOR_GRAZING_DEG = (82.0, 85.0, 87.0, 88.5, 89.5)
"""Polar angles beyond 80 degrees at which :func:`azimuth_count` compares them as well (``wi`` trees there)."""
AZIMUTH_SHARE = 0.5
"""The exact mode raises an anisotropic material's azimuth nodes while the azimuth cells' envelope floor
takes more than this share of the acceptance's slack ``n_max / (1 + ACCEPT_MARGIN) - 1``."""


def azimuth_floor(brdf: BRDF, projection: int, follow: int, phi_edges: np.ndarray,
                  thetas_deg: tuple[float, ...] = AZIMUTH_FLOOR_THETAS_DEG) -> float:  # fmt: skip
    """A lower estimate of the least envelope mass ``V`` a tree of ``projection`` can reach over an azimuth
    cell: ``1 + TV`` of the views at the two azimuth edges of the widest cell (the largest over the polar
    angles ``thetas_deg``; beyond 80 degrees a half-vector disk gives way to ``wi``, as the trees do). Any
    density ``q`` on the square has ``V >= integral of max(pa, pb) / q * q = 1 + TV(pa, pb)``, however fine its
    leaves; the layout halves polar intervals only, so this floor stays."""
    k = int(np.argmax(np.diff(phi_edges)))
    lo, hi = float(phi_edges[k]), float(phi_edges[k + 1])
    floor = 1.0
    for theta in thetas_deg:
        disk, turned = projection, follow
        if projection == HALF_VECTOR and math.radians(theta) > HALF_VECTOR_LIMIT:
            disk, turned = EQUAL_AREA, 1
        va = make_view(math.radians(theta), lo, bool(turned))
        vb = make_view(math.radians(theta), hi, bool(turned))
        floor = max(floor, 1.0 + _motion(brdf.model.id, brdf.params, disk, va, vb))
    return floor


def azimuth_edges(symmetry: int, phis: np.ndarray) -> np.ndarray:
    """``(J + 1,)``: the azimuth nodes' cells."""
    if symmetry == MIRROR:
        return cell_edges(phis, 0.0, HALF_PI)
    if symmetry == FULL:
        return cell_edges(phis, phis[0] - 0.5 * (phis[1] - phis[0]), TWO_PI - 0.5 * (phis[1] - phis[0]))
    return np.array([0.0, TWO_PI])


def azimuth_count(brdf: BRDF, symmetry: int, projection: int, follow: int, options: TableOptions) -> int:
    """The exact mode's azimuth nodes of an anisotropic material: ``phi_count``, or 1.5 or 2 times as many
    while the :func:`azimuth_floor` of the cells (at every polar angle, grazing ones included) is above
    :data:`AZIMUTH_SHARE` of the acceptance's slack. Near that floor the bounds' refinement splits leaves by
    the thousand for what the cell's width, not the leaves, costs: Ashikhmin-Shirley nu=10 nv=200 at
    ``n_max = 2`` (floor 1.62 at 89.5 degrees with 4 nodes, 1.42 with 6) had grazing trees of 3 000-11 500
    leaves (the rejection-free ones: ~370)."""
    count = options.phi_count
    if not options.bounds or symmetry == ISOTROPIC:
        return count
    slack = AZIMUTH_SHARE * (options.n_max / (1.0 + ACCEPT_MARGIN) - 1.0)
    thetas = AZIMUTH_FLOOR_THETAS_DEG + AZIMUTH_FLOOR_GRAZING_DEG
    for count in (options.phi_count, (3 * options.phi_count) // 2, 2 * options.phi_count):
        edges = azimuth_edges(symmetry, phi_nodes(symmetry, count))
        if azimuth_floor(brdf, projection, follow, edges, thetas) - 1.0 <= slack:
            break
    return count


def choose_projection(brdf: BRDF, symmetry: int, parameterization: str = "auto", n_max: float = 0.0,
                      phi_edges: np.ndarray | None = None) -> tuple[int, int]:  # fmt: skip
    """``(projection, follow)`` for a material's non-flat trees: the equal-area disk of ``wi`` (turned with
    ``wo``), or of the half vector (kept in the local frame when anisotropic), whichever moves the lobe less
    between neighbouring views (mean total-variation distance over a few pairs of views).

    ``n_max > 0`` (the exact mode) and an anisotropic material: a disk whose :func:`azimuth_floor` over the
    cells ``phi_edges`` is above the envelope's aim ``n_max / (1 + ACCEPT_MARGIN)`` is not chosen while the
    other's is not: no refinement of its trees and no halving of polar intervals reaches the acceptance
    (Poulin-Fournier at ``n_max = 1.3``: its half-vector lobe, elongated, turns with ``wo``'s azimuth in the
    local frame; the trees filled their capacity and the layout its 48 polar nodes, acceptance 0.69 at 60
    degrees)."""
    half = (HALF_VECTOR, 1 if symmetry == ISOTROPIC else 0)
    if parameterization == "wi":
        return EQUAL_AREA, 1
    if parameterization == "half":
        return half
    candidates = [(EQUAL_AREA, 1), half]
    if n_max > 0.0 and symmetry != ISOTROPIC and phi_edges is not None:
        aim = n_max / (1.0 + ACCEPT_MARGIN)
        reachable = [c for c in candidates if azimuth_floor(brdf, c[0], c[1], phi_edges) <= aim]
        if len(reachable) == 1:
            return reachable[0]
    pairs = PROBE_PAIRS_DEG if symmetry == ISOTROPIC else PROBE_PAIRS_DEG + PROBE_PAIRS_ANISO_DEG
    best = (EQUAL_AREA, 1)
    best_motion = np.inf
    for projection, follow in candidates:
        motion = 0.0
        for ta, pa, tb, pb in pairs:
            va = make_view(math.radians(ta), math.radians(pa), bool(follow))
            vb = make_view(math.radians(tb), math.radians(pb), bool(follow))
            motion += _motion(brdf.model.id, brdf.params, projection, va, vb)
        if motion < 0.9 * best_motion:  # ties go to the wi disk (the seed's domain)
            best, best_motion = (projection, follow), motion
    return best


def _views(theta_lo: float, theta: float, theta_hi: float, phis: tuple[float, ...], symmetry: int,
           follow: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """A node's views (row 0 the node), their weights in the cell's mixture (the trapezoidal rule over the
    cell), whether each lies on the cell's theta edge, and each one's ``(theta, phi)``."""
    if symmetry == ISOTROPIC:
        ts = [theta, theta_lo, 0.5 * (theta_lo + theta), 0.5 * (theta + theta_hi), theta_hi]
        a = theta - theta_lo
        b = theta_hi - theta
        w = np.array([0.25 * (a + b), 0.25 * a, 0.5 * a, 0.5 * b, 0.25 * b])
        edge = [False, True, False, False, True]
        angles = np.array([[t, 0.0] for t in ts])
        return np.array([make_view(t, 0.0) for t in ts]), _normalized(w), np.array(edge), angles
    # the node, the middles of the cell's four edges and its four corners: the lobe turns and the horizon's
    # front moves across an anisotropic cell, and their extremes are at its corners (with the edges' middles
    # only, a bound there fell short 1.2x on wi disks and 1800x beyond a half-vector disk's front)
    phi, phi_lo, phi_hi = phis
    pairs = ((theta, phi), (theta, phi_lo), (theta, phi_hi), (theta_lo, phi), (theta_hi, phi),
             (theta_lo, phi_lo), (theta_lo, phi_hi), (theta_hi, phi_lo), (theta_hi, phi_hi))  # fmt: skip
    rows = [make_view(t, ph, follow) for t, ph in pairs]
    weights = np.array([4.0, 2.0, 2.0, 2.0, 2.0, 1.0, 1.0, 1.0, 1.0])
    edge = [False, False, False, True, True, True, True, True, True]
    return np.array(rows), _normalized(weights), np.array(edge), np.array(pairs, dtype=np.float64)


def _normalized(w: np.ndarray) -> np.ndarray:
    total = float(np.sum(w))
    return w / total if total > 0.0 else np.full(len(w), 1.0 / len(w))


@dataclass
class _Node:
    tree: TreeArrays
    """Without bounds until :func:`_bound_node` (the exact mode's) replaces it."""
    projection: int
    follow: int
    edge: np.ndarray
    seconds: float
    shaped: TreeShape | None = None
    """What the exact mode's bounds continue from; dropped once they are made."""
    bounded: bool = False


HALF_VECTOR_LIMIT = math.radians(80.0)
"""Half-vector trees stop at cells reaching beyond 80 degrees (those nodes get ``wi`` trees, turned with
``wo``): near the horizon the region of half vectors whose ``wi`` is above it moves across the disk with
``wo``, a front that the stencils and the bounds follow badly (Ashikhmin-Shirley at 89 degrees: bounds 2.5x
short at the front); the ``wi`` disk has no such front."""


RIM_LIMIT = math.radians(80.0)
"""An exact tree on the equal-area disk of a cell reaching beyond this polar angle that misses the acceptance
is made again on the rim disk (:mod:`~core.sampling.adaptive.maps`) when more than :data:`RIM_SHARE` of its
envelope mass lies in leaves along the horizon, and the better of the two is kept: a ridge of ``f cos``
within a degree of the horizon (Duer's geometry term at 89 degrees: acceptance 0.073 on the equal-area disk,
its trees full, 64-73 % of their mass on the rim; 0.83 on the rim disk). Other trees stay on the equal-area
disk: there the built-in models' lobes at 80-89 degrees take as many leaves or fewer, and the short trees of
Ward's anisotropic table (acceptance 0.46-0.51 before their polar interval is halved, 0.4-1.4 % of their
mass on the rim) gain nothing on the rim disk for 1.5 times the table's time."""
RIM_SHARE = 0.25
"""The least share of a short tree's envelope mass on the rim for which it is tried on the rim disk."""


class _NodeSetup(NamedTuple):
    """What a node's tree is built from (both steps of :func:`_shape_node` and :func:`_bound_node`)."""

    projection: int
    follow: int
    views: np.ndarray
    weights: np.ndarray
    edge: np.ndarray
    angles: np.ndarray
    cell: np.ndarray
    """``theta_lo, theta_hi, phi_lo, phi_hi, follow``."""


def _node_setup(symmetry: int, theta: float, cell: tuple[float, float], phi: float, phi_cell: tuple[float, float],
                projection: int, follow: int) -> _NodeSetup:  # fmt: skip
    if symmetry == ISOTROPIC:
        phis: tuple[float, ...] = (0.0,)
    else:
        phis = (phi, phi_cell[0], phi_cell[1])
    if projection == HALF_VECTOR and cell[1] > HALF_VECTOR_LIMIT:
        projection, follow = EQUAL_AREA, 1
    views, weights, edge, angles = _views(cell[0], theta, cell[1], phis, symmetry, bool(follow))
    if symmetry == ISOTROPIC:
        cell_arr = np.array([cell[0], cell[1], 0.0, 0.0, 1.0])
    else:
        cell_arr = np.array([cell[0], cell[1], phi_cell[0], phi_cell[1], float(follow)])
    return _NodeSetup(projection, follow, views, weights, edge, angles, cell_arr)


def _shape_node(brdf: BRDF, options: TableOptions, symmetry: int, theta: float, cell: tuple[float, float],
                phi: float, phi_cell: tuple[float, float], projection: int, follow: int) -> _Node:  # fmt: skip
    """One node's tree without bounds (``projection`` ORTHOGRAPHIC for a Lambertian material): the
    rejection-free mode's, and the layout's criteria but the acceptance."""
    t0 = time.perf_counter()
    setup = _node_setup(symmetry, theta, cell, phi, phi_cell, projection, follow)
    tree, shaped = shape_tree(brdf.model.id, brdf.params, setup.projection, setup.views, setup.weights,
                              options.settings())  # fmt: skip
    return _Node(tree, setup.projection, setup.follow, setup.edge, time.perf_counter() - t0,
                 shaped if options.bounds else None)  # fmt: skip


def _bound_node(node: _Node, brdf: BRDF, options: TableOptions, symmetry: int, theta: float,
                cell: tuple[float, float], phi: float, phi_cell: tuple[float, float], projection: int, follow: int,
                norm: tuple[np.ndarray, np.ndarray]) -> _Node:  # fmt: skip
    """The exact mode's tree of a node from its tree without bounds (the same arguments as it was made with),
    once the layout no longer changes its cell: the bounds are made only for trees the table keeps (a
    third to a half of the trees the layout's rounds build are replaced when a neighbour's interval is
    halved)."""
    t0 = time.perf_counter()
    assert node.shaped is not None
    setup = _node_setup(symmetry, theta, cell, phi, phi_cell, projection, follow)
    settings = options.settings()
    if symmetry != ISOTROPIC:
        settings = settings._replace(bound_safety=ANISOTROPIC_BOUND_SAFETY)
    tree = bound_tree(node.shaped, brdf.model.id, brdf.params, setup.projection, setup.views, setup.weights,
                      setup.cell, settings, setup.angles, norm[0], norm[1])  # fmt: skip
    evaluations = tree.evaluations + node.tree.evaluations
    projection = node.projection
    rim_bound = setup.projection == EQUAL_AREA and cell[1] > RIM_LIMIT
    if rim_bound and _short(tree, options) and _rim_share(tree) > RIM_SHARE:
        plain, shaped = shape_tree(
            brdf.model.id, brdf.params, RIM, setup.views, setup.weights, options.settings()
        )
        rim = bound_tree(shaped, brdf.model.id, brdf.params, RIM, setup.views, setup.weights, setup.cell, settings,
                         setup.angles, norm[0], norm[1])  # fmt: skip
        evaluations += plain.evaluations + rim.evaluations
        if rim.envelope < tree.envelope:
            tree, projection = rim, RIM
    tree = tree._replace(evaluations=evaluations)
    return _Node(tree, projection, node.follow, node.edge, node.seconds + time.perf_counter() - t0,
                 None, True)  # fmt: skip


def _rim_share(tree: TreeArrays) -> float:
    """The share of an exact tree's envelope mass ``V`` in its leaves along the square's edge (the horizon)."""
    leaves = np.flatnonzero(tree.child < 0)
    k = -1 - tree.child[leaves]
    side = 0.5 ** tree.level[leaves].astype(np.float64)
    mass = side * side * tree.corners[k].mean(axis=1) * tree.bound[k]
    x0, y0 = tree.x0[leaves], tree.y0[leaves]
    rim = (x0 <= 0.0) | (y0 <= 0.0) | (x0 + side >= 1.0) | (y0 + side >= 1.0)
    total = float(mass.sum())
    return float(mass[rim].sum()) / total if total > 0.0 else 0.0


def _short(tree: TreeArrays, options: TableOptions) -> bool:
    """Whether an exact tree's acceptance ``1 / V`` is below the layout's aim."""
    return tree.envelope <= 0.0 or 1.0 / tree.envelope < (1.0 + ACCEPT_MARGIN) / options.n_max


# ------------------------------------------------------------------------------------------ the table
class BuildCancelled(Exception):
    """A build stopped because its ``cancel`` event was set (nobody wants the table any more)."""


def _check(cancel: threading.Event | None) -> None:
    if cancel is not None and cancel.is_set():
        raise BuildCancelled


def build_table(brdf: BRDF, options: TableOptions, threads: int | None = None,
                cancel: threading.Event | None = None) -> tuple[AdaptiveTable, TableReport]:  # fmt: skip
    """Lay out the nodes, build their trees (on ``threads`` threads, default all cores) and pack them.
    ``cancel``: when set, the build stops at its next node or quadrature (``BuildCancelled``), within one
    tree's time: a slider drag's superseded table gives its cores back to the next value's."""
    t0 = time.perf_counter()
    symmetry = symmetry_of(brdf)
    phis = phi_nodes(symmetry, options.phi_count)
    phi_edges = azimuth_edges(symmetry, phis)
    thetas = np.radians(np.array(INITIAL_THETAS_DEG))
    if is_lambertian(brdf):
        projection, follow = ORTHOGRAPHIC, 1
    else:
        projection, follow = choose_projection(brdf, symmetry, options.parameterization,
                                               options.n_max if options.bounds else 0.0, phi_edges)  # fmt: skip
        count = azimuth_count(brdf, symmetry, projection, follow, options)
        if count != options.phi_count:
            phis = phi_nodes(symmetry, count)
            phi_edges = azimuth_edges(symmetry, phis)
    nodes: dict[tuple[float, float, float, int], _Node] = {}
    report = TableReport()
    workers = threads or thread_budget()
    min_spacing = math.radians(options.min_spacing_deg)
    target = (1.0 + ACCEPT_MARGIN) / options.n_max
    with ThreadPoolExecutor(max_workers=workers) as pool:
        if options.bounds:  # the normalizer first: the trees' bounds are on g / c, c as the draws read it
            norm_thetas, norm_values, norm_err, report.evaluations = _normalizer(
                brdf, options, symmetry, phis, thetas, projection, follow, pool, cancel
            )
            norm = _norm_table(symmetry, norm_thetas, norm_values)
        else:
            norm = (np.zeros((4, 1)), 0)
        norm_args = (norm[0], np.array([float(symmetry), float(norm[1])]))

        def node_args(key: tuple[float, float, float, int]) -> tuple[Any, ...]:
            return (brdf, options, symmetry, key[0], (key[1], key[2]), float(phis[key[3]]),
                    (float(phi_edges[key[3]]), float(phi_edges[key[3] + 1])), projection, follow)  # fmt: skip

        while True:
            report.rounds += 1
            edges = cell_edges(thetas, 0.0, THETA_END)
            wanted = []
            for k, theta in enumerate(thetas):
                for j in range(len(phis)):
                    key = (float(theta), float(edges[k]), float(edges[k + 1]), j)
                    if key not in nodes:
                        wanted.append(key)
            _check(cancel)
            jobs = {
                key: pool.submit(_unless_cancelled, cancel, _shape_node, *node_args(key)) for key in wanted
            }
            for key, job in jobs.items():
                nodes[key] = job.result()
            keys = [
                [(float(theta), float(edges[k]), float(edges[k + 1]), j) for j in range(len(phis))]
                for k, theta in enumerate(thetas)
            ]
            current = {key for row in keys for key in row}
            for key, node in nodes.items():
                if key not in current:  # replaced (its cell changed): its state is not needed again
                    node.shaped = None
            halve = _intervals_to_halve(thetas, [[nodes[key] for key in row] for row in keys], symmetry, options,
                                        target)  # fmt: skip
            halve &= np.diff(thetas) > 2.0 * min_spacing
            last = len(thetas) >= options.max_thetas or report.rounds >= options.rounds
            if options.bounds and (last or not np.any(halve)):
                # the layout is settled but for the acceptance, which only bounds show: bound the trees it
                # keeps, and halve where they fall short of it
                _check(cancel)
                unbounded = [key for row in keys for key in row if not nodes[key].bounded]
                jobs = {key: pool.submit(_unless_cancelled, cancel, _bound_node, nodes[key], *node_args(key),
                                         norm_args) for key in unbounded}  # fmt: skip
                for key, job in jobs.items():
                    nodes[key] = job.result()
                halve = _intervals_to_halve(thetas, [[nodes[key] for key in row] for row in keys], symmetry,
                                            options, target)  # fmt: skip
                halve &= np.diff(thetas) > 2.0 * min_spacing
            grid = [[nodes[key] for key in row] for row in keys]
            if not np.any(halve) or last:
                break
            new = 0.5 * (thetas[:-1] + thetas[1:])[halve]
            new = new[: options.max_thetas - len(thetas)]
            thetas = np.sort(np.concatenate([thetas, new]))
    if not options.bounds:  # the rejection-free mode never reads the normalizer: the trees' own integrals
        norm_values = np.array([[n.tree.integrals[0] for n in row] for row in grid])
        norm_err = _interpolation_errors(thetas, norm_values)
        norm = _norm_table(symmetry, thetas, norm_values)
    table = _pack(
        symmetry, thetas, phis, cell_edges(thetas, 0.0, THETA_END), phi_edges, grid, norm, options.bounds
    )
    report.seconds = time.perf_counter() - t0
    report.trees = len(thetas) * len(phis)
    report.leaves = len(table.corners)
    report.evaluations += sum(n.tree.evaluations for n in nodes.values())
    report.acceptance_min = (
        min(1.0 / n.tree.envelope if n.tree.envelope > 0 else 0.0 for row in grid for n in row)
        if options.bounds
        else math.nan
    )
    report.chi2_max_edge = max(
        float(np.max(n.tree.chi2[np.concatenate(_edge_views(n, len(row) > 1))])) for row in grid for n in row
    )
    if len(phis) > 1:
        report.chi2_max_phi_edge = max(
            float(np.max(n.tree.chi2[PHI_EDGE_VIEWS])) for row in grid for n in row
        )
    report.norm_error_max = float(np.max(norm_err))
    return table, report


def _unless_cancelled(cancel: threading.Event | None, step: Callable[..., _Node], *args: Any) -> _Node:
    _check(cancel)
    return step(*args)


def _norm_azimuths(symmetry: int, phis: np.ndarray) -> np.ndarray:
    """The azimuths the normalizer is tabulated at: the azimuth nodes and the cells' edges between them,
    equally spaced (``2 J - 1`` over the mirror's quadrant, ends included; ``2 J`` around the circle): through
    the nodes alone the azimuth series is 0.26-0.3 % off between them at 80-89 degrees (Ashikhmin-Shirley
    nu=10 nv=200)."""
    j = len(phis)
    if symmetry == ISOTROPIC or j == 1:
        return np.zeros(1)
    if symmetry == MIRROR:
        return np.linspace(0.0, HALF_PI, 2 * j - 1)
    return np.arange(2 * j) * (math.pi / j)


def _integral_unless_cancelled(cancel: threading.Event | None, *args: Any) -> tuple[float, int]:
    _check(cancel)
    return _view_integral(*args)


def _view_integral(brdf: BRDF, options: TableOptions, theta: float, phi: float, projection: int,
                   follow: int) -> tuple[float, int]:  # fmt: skip
    """``I(theta, phi)`` to ``quad_tol`` on the disk a tree there would use (a measured material's on the
    ``wi`` disk), and the evaluations made."""
    if projection == HALF_VECTOR and (theta > HALF_VECTOR_LIMIT or brdf.model.measured):
        # a measured table's kinks (its half and difference angles' cells) make the quadrature on the half
        # vector's disk read its error low (at 30-78 degrees up to 2.8e-4 off at an estimate of 1e-4); on the
        # ``wi`` disk within 1e-4, with 2.5x fewer evaluations
        projection, follow = EQUAL_AREA, 1
    s = options.settings()
    value, _, evals = view_integral(brdf.model.id, brdf.params, int(projection), make_view(theta, phi, bool(follow)),
                                    s.warp_tol, s.quad_tol, s.base_level, s.max_level, s.capacity)  # fmt: skip
    return float(value), int(evals)


def _normalizer(brdf: BRDF, options: TableOptions, symmetry: int, phis: np.ndarray, tree_thetas: np.ndarray,
                projection: int, follow: int, pool: ThreadPoolExecutor, cancel: threading.Event | None = None,
                ) -> tuple[
                    np.ndarray, np.ndarray, np.ndarray, int]:  # fmt: skip
    """The exact mode's normalizer, on polar angles of its own: from the trees' nodes, an interval is halved
    while the interpolation error at either end is estimated above ``norm_tol``; each angle's values are
    integrals of one view each (:func:`~core.sampling.adaptive.tree.view_integral`: a tree for the view's
    own density, then the quadrature), not a node's tree with its bounds. Until this, only trees carried the
    normalizer, and the layout halved their intervals for it: Schlick's exact table had 24 trees where its
    rejection-free one has 7. Returns ``(thetas, values (K, J'), errors (K,), evaluations)``."""
    azimuths = _norm_azimuths(symmetry, phis)
    min_spacing = math.radians(options.min_spacing_deg)
    # the analytic models stop below max_thetas (48) by norm_tol; the measured material asks for 64, its last
    # intervals near the horizon, where its I peaks at 89.3 degrees and falls to the last node (capped at 48
    # it is 3.9e-3 off at 89.85 degrees)
    cap = 2 * options.max_thetas
    thetas = np.asarray(tree_thetas, dtype=np.float64)
    values: dict[float, np.ndarray] = {}
    evals = 0
    while True:
        new = [float(t) for t in thetas if float(t) not in values]
        _check(cancel)
        jobs = {(t, k): pool.submit(_integral_unless_cancelled, cancel, brdf, options, t, float(ph), projection,
                                    follow) for t in new for k, ph in enumerate(azimuths)}  # fmt: skip
        for t in new:
            row = np.empty(len(azimuths))
            for k in range(len(azimuths)):
                row[k], e = jobs[(t, k)].result()
                evals += e
            values[t] = row
        table = np.array([values[float(t)] for t in thetas])
        err = _interpolation_errors(thetas, table)
        bad = err > options.norm_tol
        halve = np.zeros(len(thetas) - 1, dtype=bool)
        halve |= bad[:-1]
        halve |= bad[1:]
        halve &= np.diff(thetas) > 2.0 * min_spacing
        if not np.any(halve) or len(thetas) >= cap:
            return thetas, table, err, evals
        mids = 0.5 * (thetas[:-1] + thetas[1:])[halve]
        thetas = np.sort(np.concatenate([thetas, mids[: cap - len(thetas)]]))


def _interpolation_errors(thetas: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``(K,)``: the normalizer's estimated interpolation error at each polar angle (relative, the worst
    azimuth) from its values ``(K, J')``."""
    s = norm_coordinate(thetas)
    if np.all(values > 0.0):
        cols = [interpolation_errors(s, np.log(values[:, j])) for j in range(values.shape[1])]
    else:
        scale = max(float(np.max(np.abs(values))), 1e-300)
        cols = [interpolation_errors(s, values[:, j] / scale) for j in range(values.shape[1])]
    return np.max(cols, axis=0)


def _intervals_to_halve(thetas: np.ndarray, grid: list[list[_Node]], symmetry: int, options: TableOptions,
                        target: float) -> np.ndarray:  # fmt: skip
    """``(K - 1,)``: the intervals the material asks to halve (see :mod:`core.sampling.adaptive.layout`)."""
    k = len(thetas)
    halve = np.zeros(k - 1, dtype=bool)
    chi2_limit = options.warp_chi2 if symmetry == ISOTROPIC else options.warp_chi2_anisotropic
    for i in range(k):
        row = grid[i]
        weak = any(n.bounded and n.tree.envelope > 0 and 1.0 / n.tree.envelope < target for n in row)
        rough_lo = rough_hi = False
        for n in row:
            views_lo, views_hi = _edge_views(n, len(row) > 1)
            rough_lo |= bool(np.max(n.tree.chi2[views_lo]) > chi2_limit)
            rough_hi |= bool(np.max(n.tree.chi2[views_hi]) > chi2_limit)
        if i > 0 and (weak or rough_lo):
            halve[i - 1] = True
        if i < k - 1 and (weak or rough_hi):
            halve[i] = True
    return halve


def _edge_views(node: _Node, anisotropic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the views on the cell's lower and upper theta edge, at the node's azimuth (halving in theta
    does nothing for the azimuth's edges)."""
    if not anisotropic:
        return np.array([1]), np.array([4])
    return np.array([3]), np.array([4])


PHI_EDGE_VIEWS = np.array([1, 2])
"""An anisotropic node's views on its cell's azimuth edges, at the node's theta (see :func:`_views`)."""


def _norm_table(symmetry: int, thetas: np.ndarray, integrals: np.ndarray) -> tuple[np.ndarray, int]:
    """The normalizer's table and whether it holds logarithms (see
    :func:`~core.sampling.adaptive.layout.normalizer_at`) from its values ``(K, J')`` at ``thetas``: the
    cubic through the nodes is of ``log I`` where every value is positive, and an isotropic table then holds
    its ``exp`` (read linearly in ``cos theta``: no exponential per view)."""
    norm_log = bool(np.all(integrals > 0.0))
    values = np.log(integrals) if norm_log else integrals
    norm = series_coefficients(values) if symmetry == MIRROR else values
    table = normalizer_table(thetas, norm)
    if norm_log and symmetry == ISOTROPIC:
        table, norm_log = np.exp(table), False
    return np.ascontiguousarray(table, dtype=np.float64), int(norm_log)


def _pack(symmetry: int, thetas: np.ndarray, phis: np.ndarray, theta_edges: np.ndarray,
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
    guide = np.searchsorted(cdf, (np.arange(leaves) * CDF_ONE) // leaves, side="right")
    if envelope:
        positive = counts > 0
        total = float(np.max(weight[positive] * CDF_ONE / counts[positive])) * (1.0 + 1e-12)
    return cdf, np.minimum(guide, leaves - 1).astype(np.uint16), total


# ------------------------------------------------------------------------------------------ storage
_SOURCES_HASH: dict[str, str] = {}


def source_files(brdf: BRDF) -> list[Path]:
    """The sources that can change a material's table: the model's own file (and, for a model that is a
    package of its own such as ``core/rgl``, the package's other files), the shared model helpers
    (``core/models/_*.py``, ``lobes.py``, ``core/geometry.py``), the dispatch switch and this package. An
    edit anywhere else (the app, the renderer, another model) keeps the stored tables."""
    func = getattr(brdf.model.eval, "py_func", brdf.model.eval)
    own = Path(inspect.getfile(func)).resolve()
    core = Path(__file__).resolve().parents[2]
    files = sorted(Path(__file__).resolve().parent.glob("*.py"))
    files += sorted((core / "models").glob("_*.py"))
    files += [core / "models" / "lobes.py", core / "geometry.py", core / "dispatch.py", core / "rng.py"]
    if own.parent != core / "models" and own.parent != core:
        # a model that is a package of its own (core/rgl): every file of it can change its values
        files += [f for f in sorted(own.parent.glob("*.py")) if f != own]
    if own not in files:
        files.append(own)
    return files


def sources_hash(brdf: BRDF) -> str:
    """Hash of :func:`source_files` (read once per process and model file)."""
    files = source_files(brdf)
    key = str(files[-1])
    if key not in _SOURCES_HASH:
        h = hashlib.sha256()
        for f in files:
            h.update(f.name.encode())
            h.update(f.read_bytes())
        _SOURCES_HASH[key] = h.hexdigest()[:20]
    return _SOURCES_HASH[key]


def table_cache_key(brdf: BRDF, options: TableOptions) -> str:
    return table_key(
        ["adaptive", TABLE_FORMAT, brdf.model.name, brdf.params, sorted(asdict(options).items()),
         sources_hash(brdf)]
    )  # fmt: skip


def save_table(cache: TableCache, key: str, table: AdaptiveTable, report: TableReport) -> bool:
    arrays: dict[str, Any] = {name: np.asarray(value) for name, value in table._asdict().items()}
    arrays["report"] = np.array([report.seconds, report.evaluations, report.rounds, report.acceptance_min,
                                 report.chi2_max_edge, report.norm_error_max])  # fmt: skip
    return cache.save(key, "table", arrays)


def load_table(cache: TableCache, key: str) -> tuple[AdaptiveTable, TableReport] | None:
    arrays = cache.load(key, "table")
    if arrays is None:
        return None
    try:
        rep = arrays.pop("report")
        fields = {}
        for name in AdaptiveTable._fields:
            value = arrays[name]
            fields[name] = value.item() if value.ndim == 0 else np.ascontiguousarray(value)
        fields["symmetry"] = int(fields["symmetry"])
        fields["flat"] = int(fields["flat"])
        fields["norm_log"] = int(fields["norm_log"])
        fields["exact"] = int(fields["exact"])
        fields["cos_min"] = float(fields["cos_min"])
        table = AdaptiveTable(**fields)
    except (KeyError, ValueError, TypeError):
        return None
    report = TableReport(
        seconds=float(rep[0]), evaluations=int(rep[1]), trees=len(table.root), leaves=len(table.corners),
        rounds=int(rep[2]), acceptance_min=float(rep[3]), chi2_max_edge=float(rep[4]),
        norm_error_max=float(rep[5]), from_cache=True,
    )  # fmt: skip
    return table, report


def memory_bytes(table: AdaptiveTable) -> int:
    return int(sum(v.nbytes for v in table if isinstance(v, np.ndarray)))
