"""What the sampler view draws: the adaptive sampler's tree for ``wo``, its samples and a ratio map, made by
:func:`sampling_snapshot` off the GUI thread (in the snapshot process, :mod:`app.snapshot_process`) as plain
arrays, and the adaptive table's facts; no Qt, testable on their own."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from core.brdf import BRDF, luminance

if TYPE_CHECKING:
    from collections.abc import Callable

    from core.sampling.adaptive.inspect import TreeView


ADAPTIVE_SAMPLERS = {"exact": "adaptive_exact", "warp": "adaptive_warp"}
"""The registered sampler of each mode of the adaptive sampler."""


def adaptive_sampler(brdf: BRDF, mode: str = "exact", n_max: float = 2.0, progressive: bool = False):  # noqa: ANN201
    """The adaptive sampler of ``brdf`` in ``mode`` (``"exact"`` or ``"warp"``); both modes read one table
    per material and ``n_max`` (made on first use, kept in memory and on disk). ``progressive``: a coarse
    table at once when the full one is not made yet (see :class:`core.sampling.adaptive.AdaptiveSampler`)."""
    from core.errors import ParameterError
    from core.sampling import make_sampler

    if mode not in ADAPTIVE_SAMPLERS:
        raise ParameterError(f"the adaptive sampler's mode must be 'exact' or 'warp', got {mode!r}")
    return make_sampler(ADAPTIVE_SAMPLERS[mode], brdf, n_max=n_max, progressive=progressive)


INTERIM_WARP_TOL = 0.05
"""The warp tolerance of a new value's first fit in the sampler view (5x the tables' default: 2.3x fewer
leaves, about half the build; it is replaced by the exact table a moment later)."""


class NoSnapshot(Exception):
    """A snapshot not made: its request was overtaken by a newer one while it waited, or it asked only for the
    full table's picture and that table is not made yet."""


WAIT_SLICE_S = 0.005
"""How often a wait for a background build looks whether it should give up (``stop``)."""


def _wait_for_build(key: str, timeout: float | None, stop: Callable[[], bool] | None) -> bool:
    """Wait for the background build of table ``key`` (see
    :func:`core.sampling.adaptive.sampler.wait_for_build`) at most ``timeout`` seconds (None: no limit), in
    slices, giving up as soon as ``stop()`` is true; True when no build of it is queued or running."""
    from core.sampling.adaptive.sampler import wait_for_build

    if stop is None:
        return wait_for_build(key, timeout)
    end = math.inf if timeout is None else time.monotonic() + timeout
    while True:
        left = end - time.monotonic()
        if wait_for_build(key, max(0.0, min(WAIT_SLICE_S, left))):
            return True
        if left <= WAIT_SLICE_S or stop():
            return False


def adaptive_line(brdf: BRDF, stop: Callable[[], bool] | None = None) -> str | None:
    """One line of text: the adaptive sampler's table memory and build time for ``brdf`` (builds it, or waits
    for the build a progressive snapshot started: the same table is not built twice). ``stop``: give up the
    wait when it says so (a newer request for the snapshot process is waiting), returning None; with a
    ``stop``, the table is built in the background (a newer request may drop that build), never here."""
    sampler = adaptive_sampler(brdf)
    if stop is None:
        _wait_for_build(sampler.key, None, None)
    else:
        while not sampler.queue_build():
            if stop() or not _wait_for_build(sampler.key, None, stop):
                return None
    sampler.preload()
    info = sampler.info()
    return f"Adaptive table: {info.get('memory_bytes', 0) / 1024:.1f} KiB, {table_origin(info, 'ms')}"


def table_origin(info: dict, unit: str = "s") -> str:
    """Whether a sampler's table (its ``info()``) was built by this process or read from the table cache, with
    the time its build took (the first build's, for a cached table): in seconds, or ``unit="ms"``."""
    seconds = float(info.get("build_seconds", 0.0))
    took = f"{seconds * 1e3:.0f} ms" if unit == "ms" else f"{seconds:.2f} s"
    return (
        "loaded from the table cache" if info.get("from_cache") else "built"
    ) + f" (its build took {took})"


SAMPLING_PROJECTIONS = {
    "orthographic": "wi, orthographic disk",
    "equal_area": "wi, equal-area disk",
    "half_vector": "half vector h, equal-area disk",
    "rim": "wi, rim disk",
}
"""What a tree's disk is, as the sampler view names it."""


@dataclass(frozen=True)
class SamplingSnapshot:
    """What the sampler view draws for one material, direction and set of options (made by
    :func:`sampling_snapshot`, in the snapshot process: plain arrays, picklable).

    Every point is on the disk of the tree that serves ``wo`` (``tree.projection``), in that tree's frame:
    the local frame turned so that ``wo`` lies at phi = 0 when ``tree.follow``, else the local frame, folded
    into the first quadrant by ``tree.mirror`` for a mirror-symmetric table.
    """

    theta_deg: float
    phi_deg: float
    n_max: float
    mode: str
    """``"exact"`` or ``"warp"``: the adaptive mode that drew ``samples`` (and whose density colours the leaves)."""
    tree: TreeView
    samples: np.ndarray
    """``(n, 2)``: the mode's samples on the tree's disk (those above the horizon)."""
    mean_trials: float
    """Trials per sample of this draw (1 in the warp mode)."""
    wo_disk: np.ndarray | None
    """``(2,)``: ``wo`` on the tree's disk; None on a half-vector disk (its points are not directions ``wi``)."""
    cosine_fallback: bool
    """The exact mode draws the cosine density at this ``wo`` (beyond its last node)."""
    ratio_sampler: str
    ratio: np.ndarray | None
    """``(grid, grid)``: ``pdf / (f cos / I)`` of ``ratio_sampler`` on the same disk (row 0 at y = -1; NaN
    outside the disk, where ``wi`` is below the horizon and where both densities are 0)."""
    ratio_error: str
    weight_rel_std: float
    """Relative standard deviation of the weight ``f cos / pdf`` (luminance) over ``ratio_sampler``'s draw."""
    table: dict
    """The adaptive table's facts (:meth:`~core.sampling.adaptive.AdaptiveSampler.info`)."""
    leaf_rgba: np.ndarray
    """``(TREE_RASTER, TREE_RASTER, 4)`` uint8: the leaves coloured by :meth:`leaf_density`
    (:func:`leaf_colours`), made with the snapshot so that the GUI thread only shows it."""
    density_range: tuple[float, float]
    """The densities at the ends of ``leaf_rgba``'s colour scale."""
    ratio_rgba: np.ndarray | None
    """``ratio`` coloured as the view shows it (:func:`ratio_colours`); None with ``ratio``."""
    edges: np.ndarray
    """The polyline that outlines the tree's leaves (:func:`leaf_edges`)."""

    @property
    def acceptance(self) -> float:
        """The exact mode's acceptance per trial at ``wo`` (``>= 1 / n_max``)."""
        return self.tree.acceptance

    def leaf_density(self) -> np.ndarray:
        """``(k,)``: the density the mode proposes on each leaf, per unit square area (1 on average): the
        rejection-free density ``q`` in the warp mode; in the exact mode the density of trials, ``K_L q``
        normalized (``K_L q / V``)."""
        return _leaf_density(self.mode, self.tree)


def _leaf_density(mode: str, t: TreeView) -> np.ndarray:
    if mode == "warp":
        return t.density
    area = (t.boxes[:, 2] - t.boxes[:, 0]) * (t.boxes[:, 3] - t.boxes[:, 1])
    trials = t.bound * t.density
    v = float(np.sum(area * trials))
    return trials / v if v > 0 else trials


TREE_RASTER = 192
"""Pixels across the sampler view's picture of a tree's disk."""
DENSITY_RANGE = 1e-4
"""The tree picture's colour scale spans this factor below the densest leaf."""
RATIO_RANGE = 2.0
"""The ratio map's colour scale: ``log2`` of the ratio from ``-RATIO_RANGE`` to ``RATIO_RANGE``."""
DENSITY_CMAP, RATIO_CMAP = "magma", "coolwarm"


OUTLINE_POINTS = 4
"""Points per edge of a leaf's outline (a base-level leaf's rim edge turns by ~11 degrees)."""
STRAIGHT_SIDE = 1.0 / 32.0
"""Leaves this small or smaller are outlined by straight chords (their edges bend by a fraction of a pixel)."""
OUTLINE_LEVEL = 7
"""Leaves deeper than this are outlined as their ancestor at this level (1/128 of the square, two or three
pixels on screen): a sharp lobe's thousands of tiny leaves would cost tens of ms to outline and show as a
solid patch."""


def outline_path(outlines: np.ndarray) -> np.ndarray:
    """The leaves' outlines ``(k, m, 2)`` as one polyline ``(k (m + 1), 2)``, a NaN row after each outline
    (a break in the line): one path for the line collection instead of one per leaf, which is a few times
    cheaper to set and draw, and edges shared by two leaves are not blended twice."""
    k, m, _ = outlines.shape
    out = np.full((k, m + 1, 2), np.nan)
    out[:, :m] = outlines
    return out.reshape(-1, 2)


def outline_boxes(boxes: np.ndarray, max_level: int = OUTLINE_LEVEL) -> np.ndarray:
    """The boxes ``(m, 4)`` to outline for the leaves ``boxes (k, 4)``: each leaf deeper than ``max_level``
    replaced by its ancestor at that level, once."""
    side = boxes[:, 2] - boxes[:, 0]
    deep = side < 2.0**-max_level
    if not deep.any():
        return boxes
    n = 1 << max_level
    ij = np.floor(boxes[deep, :2] * n).astype(np.int64)
    cell = np.unique(ij[:, 0] * n + ij[:, 1])
    corner = np.stack([cell // n, cell % n], axis=1) / n
    return np.concatenate([boxes[~deep], np.hstack([corner, corner + 1.0 / n])])


def leaf_edges(tree: TreeView) -> np.ndarray:
    """The polyline :func:`outline_path` that outlines the tree's leaves on its disk (:func:`outline_boxes`;
    small leaves by chords)."""
    from core.sampling.adaptive.inspect import leaf_outlines

    boxes = outline_boxes(tree.boxes)
    small = boxes[:, 2] - boxes[:, 0] <= STRAIGHT_SIDE
    return np.concatenate([
        outline_path(leaf_outlines(tree._replace(boxes=boxes[~small]), OUTLINE_POINTS)),
        outline_path(leaf_outlines(tree._replace(boxes=boxes[small]), 1)),
    ])  # fmt: skip


def leaf_colours(
    tree: TreeView, density: np.ndarray, size: int = TREE_RASTER
) -> tuple[np.ndarray, float, float]:
    """``(rgba (size, size, 4) uint8, lo, hi)``: the tree's leaves coloured by ``density`` on a log scale over
    :data:`DENSITY_RANGE` below the densest leaf; transparent outside the disk and on leaves below the range
    (where the lobe is not: a half-vector disk's ``h`` that no ``wi`` above the horizon reaches, say)."""
    from matplotlib import colormaps
    from matplotlib.colors import LogNorm

    from core.sampling.adaptive.inspect import leaf_image

    image = leaf_image(tree, density, size)
    rgba = np.zeros((size, size, 4), dtype=np.uint8)
    positive = np.isfinite(image) & (image > 0)
    if not positive.any():
        return rgba, 0.0, 0.0
    hi = float(image[positive].max())
    lo = max(float(image[positive].min()), hi * DENSITY_RANGE)
    shown = positive & (image >= lo)
    norm = LogNorm(vmin=lo, vmax=hi if hi > lo else lo * 1.0001)
    rgba[shown] = colormaps[DENSITY_CMAP](norm(image[shown]), bytes=True)
    return rgba, lo, hi


def ratio_colours(ratio: np.ndarray) -> np.ndarray:
    """``(n, n, 4)`` uint8: ``log2(ratio)`` on :data:`RATIO_CMAP` over ``[-RATIO_RANGE, RATIO_RANGE]``
    (0 and infinity shown at the ends), transparent where the ratio is NaN."""
    from matplotlib import colormaps

    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.log2(ratio)
    shown = ~np.isnan(log_ratio)
    t = (np.clip(log_ratio[shown], -RATIO_RANGE, RATIO_RANGE) + RATIO_RANGE) / (2.0 * RATIO_RANGE)
    rgba = np.zeros((*ratio.shape, 4), dtype=np.uint8)
    rgba[shown] = colormaps[RATIO_CMAP](t, bytes=True)
    return rgba


def _disk_pixels(grid: int) -> tuple[np.ndarray, np.ndarray]:
    """``(inside (grid, grid) bool, points (m, 2))``: the pixel centres of an image of ``[-1, 1]^2`` (row 0
    at y = -1) that lie inside the unit disk."""
    c = (np.arange(grid) + 0.5) / grid * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    inside = x * x + y * y < 1.0
    return inside, np.stack([x[inside], y[inside]], axis=1)


def _cosine_integral(brdf: BRDF, wo: np.ndarray, grid: int) -> float:
    """``I(wo) = int f cos d(omega)`` (luminance) by the midpoint rule on the orthographic disk, where
    ``cos d(omega) = dx dy`` (used where the table has no normalizer: beyond its last node)."""
    _, p = _disk_pixels(grid)
    wi = np.column_stack([p, np.sqrt(np.maximum(0.0, 1.0 - np.sum(p * p, axis=1)))])
    return float(np.sum(luminance(brdf.eval(wo, wi))) * (2.0 / grid) ** 2)


def _weight_rel_std(batch) -> float:
    fw = luminance(batch.f) * np.maximum(batch.wi[:, 2], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(batch.pdf > 0, fw / batch.pdf, 0.0)
    mean = float(np.mean(w))
    return float(np.std(w) / mean) if mean > 0 else float("nan")


def sampling_snapshot(
    brdf: BRDF,
    theta_deg: float,
    phi_deg: float,
    n_max: float = 2.0,
    mode: str = "exact",
    ratio_sampler: str = "adaptive_exact",
    n_samples: int = 2000,
    seed: int = 1,
    grid: int = 96,
    progressive: bool = False,
    settle: float = 0.0,
    stop: Callable[[], bool] | None = None,
    only_complete: bool = False,
) -> SamplingSnapshot:
    """What the sampler view draws, computed off the GUI thread (no Qt: it runs in the snapshot process).

    The tree of the adaptive sampler's table that serves ``wo`` (both modes use the same one), ``n_samples``
    samples of ``mode`` on its disk, and the ratio map of ``ratio_sampler``'s pdf against the ideal density
    ``f cos / I`` on that same disk: each pixel is taken back to its direction ``wi`` (on a half-vector disk
    the pixel is ``h``, and ``wi = 2 (wo.h) h - wo``), so the two images compare point for point. ``I`` is the
    exact mode's normalizer ``I(wo)`` (a quadrature beyond the table's last node): the exact mode's map is 1
    wherever ``f > 0``.

    ``progressive``: when the material's full table is not made yet, draw from its coarse table (the initial
    layout only: a fraction of the time, exact all the same) or, in the exact mode when not even that is
    made, from a first fit: the rejection-free mode's coarse table at :data:`INTERIM_WARP_TOL` (no bounds,
    no normalizer: 10-40 ms, where the exact coarse table takes 30-300 ms; ``table["interim"]``, and ``mode``
    is then ``"warp"``);
    ``table["complete"]`` says whether it is the full one, ``table["full_pending"]`` whether asking again
    will bring it. The full table is built in the background only when asked for again: with ``settle``
    (wait for it up to that many seconds) or ``only_complete`` (raise :class:`NoSnapshot` unless it is made:
    the app's follow-ups, which ask again a moment later rather than wait in the process, where a wait would
    hold up a drag's next value). So a slider's new value shows its tree at once, and no build of a value
    the drag has left takes the cores the next value's picture needs. ``stop``: stop waiting when it says
    so (a newer request is waiting for the process): :class:`NoSnapshot` too, no picture nobody wants.
    """
    from core.errors import BrdfStudioError
    from core.sampling import make_sampler, sampler_names
    from core.sampling.adaptive.inspect import from_tree_disk, to_tree_disk, tree_view

    t, p = math.radians(theta_deg), math.radians(phi_deg)
    wo = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
    sampler = wanted = adaptive_sampler(brdf, mode, n_max, progressive)
    interim = False
    if progressive:
        from core.sampling.adaptive.sampler import drop_builds

        drop_builds(keep=sampler.key)  # a drag's earlier values: their full tables are not wanted now
        # The full table is built (in the background) only when asked for again: with a settle, or by the
        # app's follow-up a moment later; during a drag, no build of a value already left takes the cores the
        # next value's picture needs.
        if settle > 0.0 and not sampler.queue_build():
            _wait_for_build(sampler.key, settle, stop)
        if (stop is not None and stop()) or (only_complete and not sampler.queue_build()):
            raise NoSnapshot
        if mode == "exact" and not sampler.available():
            interim, mode = True, "warp"
            if ratio_sampler == ADAPTIVE_SAMPLERS["exact"]:
                ratio_sampler = ADAPTIVE_SAMPLERS["warp"]
            # its coarse table only, and coarser: half the build (Ward sx=0.05 sy=0.25: 41 ms of CPU instead of 80)
            sampler = make_sampler(ADAPTIVE_SAMPLERS[mode], brdf, n_max=n_max, progressive=True,
                                   warp_tol=INTERIM_WARP_TOL)  # fmt: skip
        sampler.preload()  # (a new sampler: the full table when it is made, else the coarse one)
    tree = tree_view(sampler, wo)
    batch, trials = sampler.sample_with_trials(np.repeat(wo[None, :], int(n_samples), axis=0), seed)
    points = to_tree_disk(sampler, wo, batch.wi)
    samples = points[np.isfinite(points).all(axis=1)]
    wo_disk = None if tree.projection == "half_vector" else to_tree_disk(sampler, wo, wo)[0]

    # the ratio map, on the tree's disk
    inside, pts = _disk_pixels(grid)
    wi = from_tree_disk(sampler, wo, pts)
    up = np.isfinite(wi[:, 0])
    integral = tree.normalizer if tree.normalizer > 0 else _cosine_integral(brdf, wo, grid)
    f = luminance(brdf.eval(wo, wi[up]))
    target = f * wi[up, 2] / integral if integral > 0 else np.zeros_like(f)
    ratio, ratio_error, rel_std = None, "", float("nan")
    if ratio_sampler in sampler_names():
        try:
            if ratio_sampler == ADAPTIVE_SAMPLERS[mode]:
                other, drawn = sampler, batch  # the draw shown (same seed and count)
            else:
                adaptive = ratio_sampler in ADAPTIVE_SAMPLERS.values()
                extra = {"n_max": n_max, "progressive": progressive} if adaptive else {}
                other = make_sampler(ratio_sampler, brdf, **extra)
                drawn = other.sample(wo, n_samples, seed)
            pdf = other.pdf(np.broadcast_to(wo, wi[up].shape), wi[up])
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.where((pdf > 0) | (target > 0), pdf / target, np.nan)
            ratio = np.full(inside.shape, np.nan)
            values = np.full(len(pts), np.nan)
            values[up] = r
            ratio[inside] = values
            rel_std = _weight_rel_std(drawn)
        except BrdfStudioError as exc:
            ratio_error = str(exc)
    else:
        ratio_error = f"there is no sampler '{ratio_sampler}'"
    leaf_rgba, lo, hi = leaf_colours(tree, _leaf_density(mode, tree))
    return SamplingSnapshot(
        leaf_rgba=leaf_rgba,
        density_range=(lo, hi),
        ratio_rgba=None if ratio is None else ratio_colours(ratio),
        edges=leaf_edges(tree),
        theta_deg=theta_deg,
        phi_deg=phi_deg,
        n_max=float(n_max),
        mode=mode,
        tree=tree,
        samples=samples,
        mean_trials=float(np.mean(trials)) if len(trials) else float("nan"),
        wo_disk=wo_disk,
        cosine_fallback=tree.normalizer <= 0.0,
        ratio_sampler=ratio_sampler,
        ratio=ratio,
        ratio_error=ratio_error,
        weight_rel_std=rel_std,
        table={
            **sampler.info(),
            "complete": not interim and sampler.complete,
            "full_pending": progressive and (interim or not sampler.complete) and not wanted.build_failed,
            "interim": interim,
        },
    )
