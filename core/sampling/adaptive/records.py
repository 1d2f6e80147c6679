"""The adaptive table's records: how a table is made (:class:`TableOptions`), the packed table the draws read
(:class:`AdaptiveTable`), what making it cost (:class:`TableReport`), and a build's cancellation.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np

from core.errors import ParameterError
from core.sampling.adaptive.tree import BuildSettings

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
    each is a view's integral, no tree; see :func:`build_normalizer`)."""
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


# ------------------------------------------------------------------------------------------ the table
class BuildCancelled(Exception):
    """A build stopped because its ``cancel`` event was set (nobody wants the table any more)."""


def check_cancel(cancel: threading.Event | None) -> None:
    if cancel is not None and cancel.is_set():
        raise BuildCancelled


INT_OPTIONS = {"phi_count": (2, 64), "max_thetas": (7, 256), "rounds": (1, 64), "base_level": (1, 6), "max_level": (2, 14),
         "capacity": (64, 1 << 16)}  # fmt: skip
"""Integer options and their ranges (``capacity``: a table indexes a tree's leaves in 16 bits, and a tree of
``2^16`` nodes has at most 49 153)."""
FLOAT_OPTIONS = {"warp_tol": (1e-9, 1.0), "quad_tol": (1e-12, 1e-2), "warp_chi2": (1e-4, 10.0),
           "warp_chi2_anisotropic": (1e-4, 10.0),
           "norm_tol": (1e-9, 1e-2), "min_spacing_deg": (1e-3, 10.0)}  # fmt: skip


def table_options(n_max: Any = 2.0, **options: Any) -> TableOptions:
    """Validated :class:`TableOptions` (a :class:`ParameterError` names the option and its range)."""
    known = {f.name for f in fields(TableOptions)} - {"bounds"}
    if "parameterization" in options and options["parameterization"] not in ("auto", "wi", "half"):
        raise ParameterError(
            f"adaptive option parameterization must be 'auto', 'wi' or 'half', got {options['parameterization']!r}"
        )
    for name in options:
        if name not in known:
            allowed = ", ".join(sorted(known))
            raise ParameterError(f"the adaptive sampler has no option '{name}'; its options are: {allowed}")
    values: dict[str, Any] = {"n_max": _check_n_max(n_max)}
    for name, value in options.items():
        if name == "parameterization":
            values[name] = value
        elif name in INT_OPTIONS:
            lo, hi = INT_OPTIONS[name]
            values[name] = _check_int(name, value, lo, hi)
        else:
            lo, hi = FLOAT_OPTIONS[name]
            values[name] = _check_float(name, value, lo, hi)
    opts = TableOptions(**values)
    if opts.max_level < opts.base_level:
        raise ParameterError(f"max_level ({opts.max_level}) must be at least base_level ({opts.base_level})")
    return opts


def _check_n_max(n_max: Any) -> float:
    try:
        value = float(n_max)
    except (TypeError, ValueError):
        raise ParameterError(f"n_max must be a number greater than 1, got {n_max!r}") from None
    if not math.isfinite(value) or value <= 1.0 or value > 1e3:
        raise ParameterError(
            f"n_max must be a number in (1, 1000] (the mean trials per sample), got {n_max!r}"
        )
    return value


def _check_int(name: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer | float | str):
        raise ParameterError(f"adaptive option {name} must be a whole number in [{lo}, {hi}], got {value!r}")
    try:
        f = float(value)
    except ValueError:
        raise ParameterError(
            f"adaptive option {name} must be a whole number in [{lo}, {hi}], got {value!r}"
        ) from None
    if not math.isfinite(f) or f != int(f) or not lo <= int(f) <= hi:
        raise ParameterError(f"adaptive option {name} must be a whole number in [{lo}, {hi}], got {value!r}")
    return int(f)


def _check_float(name: str, value: Any, lo: float, hi: float) -> float:
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise ParameterError(
            f"adaptive option {name} must be a number in [{lo:g}, {hi:g}], got {value!r}"
        ) from None
    if not math.isfinite(f) or not lo <= f <= hi:
        raise ParameterError(f"adaptive option {name} must be a number in [{lo:g}, {hi:g}], got {value!r}")
    return f
