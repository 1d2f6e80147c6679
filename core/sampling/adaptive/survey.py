"""What a material asks of its table, measured before any tree: its symmetry, whether it is Lambertian, the
square its trees use (the projection) and how many azimuth nodes it needs; and the views that represent a
node's cell.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.brdf import BRDF
from core.sampling.adaptive.layout import FULL, HALF_PI, ISOTROPIC, MIRROR, TWO_PI, cell_edges, phi_nodes
from core.sampling.adaptive.maps import EQUAL_AREA, HALF_VECTOR
from core.sampling.adaptive.records import TableOptions
from core.sampling.adaptive.target import g_at, make_view
from core.sampling.adaptive.tree import ACCEPT_MARGIN

HALF_VECTOR_LIMIT = math.radians(80.0)
"""Half-vector trees stop at cells reaching beyond 80 degrees (those nodes get ``wi`` trees, turned with
``wo``): near the horizon the region of half vectors whose ``wi`` is above it moves across the disk with
``wo``, a front that the stencils and the bounds follow badly (Ashikhmin-Shirley at 89 degrees: bounds 2.5x
short at the front); the ``wi`` disk has no such front."""


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


def cell_views(theta_lo: float, theta: float, theta_hi: float, phis: tuple[float, ...], symmetry: int,
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
