"""The exact mode's normalizer: ``I(wo)`` tabulated on polar angles of its own (and azimuths), each value a
view's integral to ``quad_tol``, and packed into the table the draws read.
"""

from __future__ import annotations

import math
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from core.brdf import BRDF
from core.sampling.adaptive.layout import (
    HALF_PI,
    ISOTROPIC,
    MIRROR,
    interpolation_errors,
    norm_coordinate,
    normalizer_table,
    series_coefficients,
)
from core.sampling.adaptive.maps import EQUAL_AREA, HALF_VECTOR
from core.sampling.adaptive.records import TableOptions, check_cancel
from core.sampling.adaptive.survey import HALF_VECTOR_LIMIT
from core.sampling.adaptive.target import make_view
from core.sampling.adaptive.tree import view_integral


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
    check_cancel(cancel)
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


def build_normalizer(brdf: BRDF, options: TableOptions, symmetry: int, phis: np.ndarray, tree_thetas: np.ndarray,
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
        check_cancel(cancel)
        jobs = {(t, k): pool.submit(_integral_unless_cancelled, cancel, brdf, options, t, float(ph), projection,
                                    follow) for t in new for k, ph in enumerate(azimuths)}  # fmt: skip
        for t in new:
            row = np.empty(len(azimuths))
            for k in range(len(azimuths)):
                row[k], e = jobs[(t, k)].result()
                evals += e
            values[t] = row
        table = np.array([values[float(t)] for t in thetas])
        err = normalizer_errors(thetas, table)
        bad = err > options.norm_tol
        halve = np.zeros(len(thetas) - 1, dtype=bool)
        halve |= bad[:-1]
        halve |= bad[1:]
        halve &= np.diff(thetas) > 2.0 * min_spacing
        if not np.any(halve) or len(thetas) >= cap:
            return thetas, table, err, evals
        mids = 0.5 * (thetas[:-1] + thetas[1:])[halve]
        thetas = np.sort(np.concatenate([thetas, mids[: cap - len(thetas)]]))


def normalizer_errors(thetas: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``(K,)``: the normalizer's estimated interpolation error at each polar angle (relative, the worst
    azimuth) from its values ``(K, J')``."""
    s = norm_coordinate(thetas)
    if np.all(values > 0.0):
        cols = [interpolation_errors(s, np.log(values[:, j])) for j in range(values.shape[1])]
    else:
        scale = max(float(np.max(np.abs(values))), 1e-300)
        cols = [interpolation_errors(s, values[:, j] / scale) for j in range(values.shape[1])]
    return np.max(cols, axis=0)


def norm_table(symmetry: int, thetas: np.ndarray, integrals: np.ndarray) -> tuple[np.ndarray, int]:
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
