"""What a view of the adaptive sampler shows: the tree serving one outgoing direction, on its disk.

Plain numpy over a sampler's table (no Qt): the app's sampler view, the docs' figures and the tests read
these. A tree lives on the square; the concentric map draws it on the unit disk, where its leaves are curved
quads (:func:`leaf_image` rasterizes them by mapping every pixel back to the square).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from core.sampling.adaptive.draw import _frame
from core.sampling.adaptive.layout import FULL, ISOTROPIC, TWO_PI
from core.sampling.adaptive.maps import HALF_VECTOR, PROJECTIONS
from core.sampling.adaptive.sampler import AdaptiveSampler
from core.sampling.adaptive.table import AdaptiveTable


class TreeView(NamedTuple):
    """The tree that serves ``wo`` (see :func:`tree_view`)."""

    projection: str
    """``"orthographic"``, ``"equal_area"`` (disks of ``wi``) or ``"half_vector"`` (disk of ``h``)."""
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
    """``(k,)``: the rejection-free density's mean over each leaf (per unit square area: 1 on average)."""
    bound: np.ndarray
    """``(k,)``: each leaf's ``K_L`` (the exact mode's envelope over the density)."""
    acceptance: float
    """The exact mode's acceptance per trial, ``1 / V``."""
    normalizer: float
    """``I(wo)`` (the exact mode's; 0 beyond the last node)."""


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
    """``(boxes (k, 4), leaf index (k,))`` of tree ``t``, leaves in tree order."""
    boxes: list[tuple[float, float, float, float]] = []
    index: list[int] = []
    stack = [(int(table.root[t]), 0.0, 0.0, 1.0)]
    while stack:
        node, x0, y0, h = stack.pop()
        c = int(table.child[node])
        if c < 0:
            boxes.append((x0, y0, x0 + h, y0 + h))
            index.append(-1 - c)
            continue
        h2 = 0.5 * h
        for q in (3, 2, 1, 0):
            stack.append((c + q, x0 + h2 * (q % 2), y0 + h2 * (q // 2), h2))
    return np.array(boxes).reshape(-1, 4), np.array(index, dtype=np.int64)


def tree_view(sampler: AdaptiveSampler, wo: np.ndarray) -> TreeView:
    """The tree serving ``wo (3,)`` in ``sampler``'s table, with what the exact mode makes of it there."""
    table = sampler.table
    wo = np.asarray(wo, dtype=np.float64).reshape(3)
    t = _tree_of(table, wo)
    boxes, idx = leaves_of(table, t)
    area = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    corners = table.corners[idx].astype(np.float64)
    mass_total = float(np.sum(area * corners.mean(axis=1)))
    density = corners.mean(axis=1) / mass_total if mass_total > 0 else np.zeros(len(idx))
    k, j = divmod(t, len(table.phis))
    th_lo, th_hi = np.degrees(table.theta_edges[k : k + 2])
    if table.symmetry == ISOTROPIC:
        ph_lo, ph_hi = 0.0, 360.0
    else:
        ph_lo, ph_hi = np.degrees(table.phi_edges[j : j + 2])
    return TreeView(
        projection=PROJECTIONS[int(table.projection[t])],
        follow=bool(table.follow),
        tree=t,
        node_deg=(float(np.degrees(table.thetas[k])), float(np.degrees(table.phis[j]))),
        cell_deg=(float(th_lo), float(th_hi), float(ph_lo), float(ph_hi)),
        boxes=boxes,
        density=density,
        bound=table.bound[idx].astype(np.float64),
        acceptance=float(sampler.acceptance(wo)[0]),
        normalizer=float(sampler.normalizer(wo)[0]),
    )


def to_tree_disk(sampler: AdaptiveSampler, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    """Disk points ``(n, 2)`` of directions ``wi (n, 3)`` as the tree serving ``wo`` sees them (its frame
    and its disk: of ``wi``, or of the half vector); NaN for directions it cannot hold (below the horizon)."""
    table = sampler.table
    wo = np.asarray(wo, dtype=np.float64).reshape(3)
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float64))
    t = _tree_of(table, wo)
    _, _, c, s, sx, sy = _frame(table.symmetry, float(wo[0]), float(wo[1]), float(wo[2]))
    if not table.follow:
        c, s = 1.0, 0.0
    v = wi
    if int(table.projection[t]) == HALF_VECTOR:
        h = wi + wo
        n = np.linalg.norm(h, axis=1, keepdims=True)
        v = np.where(n > 0, h / np.where(n > 0, n, 1.0), np.nan)
    x, y, z = sx * v[:, 0], sy * v[:, 1], v[:, 2]
    x, y = c * x + s * y, -s * x + c * y
    out = np.full((len(v), 2), np.nan)
    up = z > 0
    if int(table.projection[t]) == 0:
        out[up] = np.stack([x[up], y[up]], axis=1)
    else:
        scale = 1.0 / np.sqrt(1.0 + z[up])
        out[up] = np.stack([x[up] * scale, y[up] * scale], axis=1)
    return out


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


def leaf_image(view: TreeView, values: np.ndarray, size: int) -> np.ndarray:
    """An image ``(size, size)`` of the disk (``[-1, 1]^2``, row 0 at y = -1) holding, at each pixel inside
    the disk, ``values[leaf]`` of the leaf the pixel maps to (NaN outside the disk)."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    inside = x * x + y * y < 1.0
    a, b = disk_to_square(x[inside], y[inside])
    boxes = view.boxes
    img = np.full((size, size), np.nan)
    which = np.full(a.shape, -1, dtype=np.int64)
    for i, (a0, b0, a1, b1) in enumerate(boxes):
        hit = (a >= a0) & (a < a1 if a1 < 1.0 else a <= a1) & (b >= b0) & (b < b1 if b1 < 1.0 else b <= b1)
        which[hit] = i
    vals = np.where(which >= 0, np.asarray(values, dtype=np.float64)[np.maximum(which, 0)], np.nan)
    img[inside] = vals
    return img


def leaf_outlines(view: TreeView, points_per_edge: int = 8) -> list[np.ndarray]:
    """Each leaf's outline on the disk, ``(4 * points_per_edge + 1, 2)`` per leaf (curved edges)."""
    from core.sampling.adaptive.maps import square_to_disk

    t = np.linspace(0.0, 1.0, points_per_edge, endpoint=False)
    out = []
    for a0, b0, a1, b1 in view.boxes:
        a = np.concatenate(
            [a0 + (a1 - a0) * t, np.full_like(t, a1), a1 - (a1 - a0) * t, np.full_like(t, a0), [a0]]
        )
        b = np.concatenate(
            [np.full_like(t, b0), b0 + (b1 - b0) * t, np.full_like(t, b1), b1 - (b1 - b0) * t, [b0]]
        )
        out.append(np.array([square_to_disk(float(u), float(v)) for u, v in zip(a, b, strict=True)]))
    return out
