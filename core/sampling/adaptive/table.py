"""A material's adaptive table: every node's tree, made at once, in parallel.

:func:`build_table` surveys the material (:mod:`~core.sampling.adaptive.survey`: its symmetry, its square, its
azimuths), tabulates the exact mode's normalizer (:mod:`~core.sampling.adaptive.normalizer`), lays out the
nodes (:mod:`core.sampling.adaptive.layout`), builds their trees (:mod:`core.sampling.adaptive.tree`) on
threads (the compiled builder releases the GIL), halves the intervals where the material asks for it, and
packs the trees (:mod:`~core.sampling.adaptive.pack`) into one
:class:`~core.sampling.adaptive.records.AdaptiveTable` of flat arrays that the compiled draws
(:mod:`core.sampling.adaptive.draw`) read. :mod:`~core.sampling.adaptive.store` keeps tables on disk.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from core.brdf import BRDF
from core.sampling.adaptive.layout import INITIAL_THETAS_DEG, ISOTROPIC, THETA_END, cell_edges, phi_nodes
from core.sampling.adaptive.maps import EQUAL_AREA, HALF_VECTOR, ORTHOGRAPHIC, RIM
from core.sampling.adaptive.normalizer import build_normalizer, norm_table, normalizer_errors
from core.sampling.adaptive.pack import pack_table
from core.sampling.adaptive.records import AdaptiveTable, TableOptions, TableReport, check_cancel
from core.sampling.adaptive.survey import (
    HALF_VECTOR_LIMIT,
    azimuth_count,
    azimuth_edges,
    cell_views,
    choose_projection,
    is_lambertian,
    symmetry_of,
)
from core.sampling.adaptive.tree import (
    ACCEPT_MARGIN,
    ANISOTROPIC_BOUND_SAFETY,
    TreeArrays,
    TreeShape,
    bound_tree,
    shape_tree,
)
from core.threads import thread_budget


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
    views, weights, edge, angles = cell_views(cell[0], theta, cell[1], phis, symmetry, bool(follow))
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
            norm_thetas, norm_values, norm_err, report.evaluations = build_normalizer(
                brdf, options, symmetry, phis, thetas, projection, follow, pool, cancel
            )
            norm = norm_table(symmetry, norm_thetas, norm_values)
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
            check_cancel(cancel)
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
                check_cancel(cancel)
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
        norm_err = normalizer_errors(thetas, norm_values)
        norm = norm_table(symmetry, thetas, norm_values)
    table = pack_table(
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
    check_cancel(cancel)
    return step(*args)


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
"""An anisotropic node's views on its cell's azimuth edges, at the node's theta (see :func:`cell_views`)."""
