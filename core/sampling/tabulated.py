"""Tabulated-CDF baselines: UniformCDF (Matusik et al. 2003) and CompressCDF (Lawrence et al. 2005).

For each incident-angle bin (isotropic BRDFs: bins over ``theta_o``, rotated by ``phi_o``; anisotropic ones:
bins over ``(theta_o, phi_o)``) the luminance of ``f cos`` is tabulated on a grid of cells uniform in
``theta_i`` and ``phi_i`` (each cell value the mean of stratified sub-samples). The marginal CDF over
``theta_i`` and one conditional CDF over ``phi_i`` per row are inverted; within a cell (or a compressed
segment) directions are uniform in solid angle (uniform in ``cos theta`` and ``phi``).

CompressCDF replaces each CDF curve by the Douglas-Peucker simplification of its polyline (abscissa
``-cos theta`` for the marginal, ``phi`` for the conditionals) with tolerance ``tol`` in CDF units; sampling
is a search (narrowed by a guide table per CDF) and a linear inversion. Both densities are exact: ``pdf``
evaluates the same piecewise constant density the sampler draws from.

Unbiasedness: a cell whose sub-samples all miss a sharp peak would get zero probability while ``f > 0``
there. Every cell is floored at ``defensive`` times the mean cell value, so the density is positive wherever
the BRDF can be (a defensive mixture; it costs at most that fraction of the samples).
"""

from __future__ import annotations

import math
import time
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from core import fastmath
from core.brdf import BRDF, LUMINANCE
from core.errors import ParameterError
from core.jit import kernel
from core.kernels import eval_batch
from core.sampling.base import Sampler, SamplerOption, register_sampler
from core.sampling.distributions import find_interval, guided_interval, interval_guides, walk_interval

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi
EVERY_ROW = np.zeros(0, dtype=np.bool_)  # a row mask that selects every row
_MARGINAL_GUIDE = 64  # guide entries per marginal CDF (the default grid's rows), per conditional below
_CONDITIONAL_GUIDE = 32
_BLOCK = 64  # rows a draw loop takes at a time (see _cdf_sample_rows)


def douglas_peucker(x: np.ndarray, y: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the points kept by Douglas-Peucker simplification of the polyline ``(x, y)``.

    The error is measured vertically (in ``y``, the CDF value), which bounds the CDF error of the
    piecewise-linear curve through the kept points. Endpoints are always kept.
    """
    n = len(x)
    keep = np.zeros(n, dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, n - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        xs = x[a + 1 : b]
        t = (xs - x[a]) / (x[b] - x[a]) if x[b] != x[a] else np.zeros_like(xs)
        err = np.abs(y[a + 1 : b] - (y[a] + t * (y[b] - y[a])))
        k = int(np.argmax(err))
        if err[k] > tol:
            m = a + 1 + k
            keep[m] = True
            stack.append((a, m))
            stack.append((m, b))
    return np.flatnonzero(keep)


def bin_directions(n_theta_o: int, n_phi_o: int) -> np.ndarray:
    """Centre ``wo`` of every incident-angle bin, ``(n_theta_o * n_phi_o, 3)``."""
    th = (np.arange(n_theta_o) + 0.5) * HALF_PI / n_theta_o
    ph = (np.arange(n_phi_o) + 0.5) * TWO_PI / n_phi_o if n_phi_o > 1 else np.zeros(1)
    t, p = np.meshgrid(th, ph, indexing="ij")
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)


@njit(inline="always", nogil=True, cache=True)
def bin_of(wo, n_theta_o, n_phi_o):
    """Bin index of ``wo`` and the cosine and sine of the azimuth its table is relative to: ``phi_o`` for
    isotropic tables (from ``wo``'s components, no arc tangent), 0 for anisotropic ones."""
    cz = min(1.0, max(-1.0, wo[2]))
    it = fastmath.polar_cell(cz, n_theta_o)
    if n_phi_o == 1:
        r = math.sqrt(wo[0] * wo[0] + wo[1] * wo[1])
        if r > 0.0:
            return it, wo[0] / r, wo[1] / r
        return it, 1.0, 0.0
    phi = fastmath.atan2(wo[1], wo[0])
    if phi < 0.0:
        phi += TWO_PI
    ip = min(int(phi / TWO_PI * n_phi_o), n_phi_o - 1)
    return it * n_phi_o + ip, 1.0, 0.0


@njit(inline="always", nogil=True, cache=True)
def table_azimuth(d, c_ref, s_ref):
    """The azimuth in ``[0, 2 pi)`` of ``d`` in a table turned by the azimuth whose cosine and sine are
    ``c_ref, s_ref`` (:func:`bin_of`)."""
    phi = fastmath.atan2(d[1] * c_ref - d[0] * s_ref, d[0] * c_ref + d[1] * s_ref)
    return phi + TWO_PI if phi < 0.0 else phi


@njit(inline="always", nogil=True, cache=True)
def table_azimuth_estimate(d, c_ref, s_ref):
    """:func:`table_azimuth` within 1.7e-6 (:func:`core.fastmath.atan2_estimate`)."""
    phi = fastmath.atan2_estimate(d[1] * c_ref - d[0] * s_ref, d[0] * c_ref + d[1] * s_ref)
    return phi + TWO_PI if phi < 0.0 else phi


def cell_knots(keeps: list[np.ndarray], n_grid: int, n_cells: int) -> np.ndarray:
    """``(len(keeps), n_cells)`` uint16: for each curve, whose knots are the edges ``keeps[c]`` (increasing,
    from 0 to ``n_grid``) of a uniform grid of ``n_grid`` cells, and each of ``n_cells`` equal cells of the
    same range, the curve's own index of its last knot at or below the cell's lower edge: the segment
    holding the cell's start, where :func:`~core.sampling.distributions.walk_interval` starts (``_cdf_density``). A simplified curve's knots are
    some of the grid's edges, so with the grid's own cells (``n_cells = n_grid``) the guess is the answer."""
    out = np.empty((len(keeps), n_cells), dtype=np.uint16)
    edges = np.arange(n_cells, dtype=np.int64) * n_grid  # cell g starts at grid edge g n_grid / n_cells
    for c, keep in enumerate(keeps):
        k = np.searchsorted(np.asarray(keep, dtype=np.int64) * n_cells, edges, side="right") - 1
        out[c] = np.clip(k, 0, len(keep) - 2)
    return out


@njit(inline="always", nogil=True, cache=True)
def _invert(xs, cdf, lo, hi, guide, u):
    """Where the piecewise-linear CDF through the knots ``(xs, cdf)[lo:hi]`` reaches ``u``, and the density
    (the slope) of the segment there."""
    k = guided_interval(cdf, lo, hi, guide, u)
    dF = cdf[k + 1] - cdf[k]
    dx = xs[k + 1] - xs[k]
    x = xs[k] + (u - cdf[k]) / dF * dx if dF > 0.0 else xs[k]
    return min(max(x, xs[k]), xs[k + 1]), dF / dx


@njit(inline="always", nogil=True, cache=True)
def _cdf_marginal(w, u0, mguide, n_theta_o, n_phi_o, n_rows, mx, mf, moff):
    """The first half of a draw for ``wo = w`` (above the horizon) from the uniform ``u0``: the conditional
    ``c`` to draw from, ``cos theta_i``, the marginal's density and the table's azimuth (:func:`bin_of`); the
    layout is explained in :class:`CDFSampler`."""
    b, c_ref, s_ref = bin_of(w, n_theta_o, n_phi_o)
    x, pdf_m = _invert(mx, mf, moff[b], moff[b + 1], mguide[b], u0)
    cos_t = -x
    row = fastmath.polar_cell(min(1.0, max(0.0, cos_t)), n_rows)
    return b * n_rows + row, cos_t, pdf_m, c_ref, s_ref


@njit(inline="always", nogil=True, cache=True)
def _cdf_conditional(c, u1, cos_t, c_ref, s_ref, cguide, cx, cf, coff):
    """The second half: ``phi_i`` from conditional ``c`` and ``u1``; the direction and its density there."""
    phi, pdf_c = _invert(cx, cf, coff[c], coff[c + 1], cguide[c], u1)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    sp, cp = fastmath.sin_cos(phi)
    return sin_t * (cp * c_ref - sp * s_ref), sin_t * (sp * c_ref + cp * s_ref), cos_t, pdf_c


@njit(inline="always", nogil=True, cache=True)
def _azimuth_knot(grid, cx, clo, chi, phi):
    """The knot of the conditional ``cx[clo:chi]`` at or below ``phi`` (a uniform grid's by its cell; a
    simplified conditional's few knots by a search: a start from a guide of azimuth cells was slower)."""
    if grid:
        return walk_interval(cx, clo, chi, phi, clo + int(phi / TWO_PI * (chi - clo - 1)))
    return find_interval(cx, clo, chi, phi)


class CdfTables(NamedTuple):
    """A :class:`CDFSampler`'s tables as its kernels read them (see the class for the layout)."""

    n_theta_o: int
    n_phi_o: int
    n_rows: int
    """Polar rows of ``wi`` per bin."""
    grid: bool
    """Whether the tables are the uniform grid (no simplification)."""
    mx: np.ndarray
    mf: np.ndarray
    moff: np.ndarray
    cx: np.ndarray
    cf: np.ndarray
    coff: np.ndarray
    mrow: np.ndarray
    mguide: np.ndarray
    cguide: np.ndarray


@njit(inline="always", nogil=True, cache=True)
def _cdf_density(w, d, t):
    """The density of a draw (:func:`_cdf_marginal`, :func:`_cdf_conditional`) at ``wi = d`` for ``wo = w``
    (above the horizon). The marginal's segment is walked to from a guess (:func:`~core.sampling.distributions.walk_interval`: the same index
    as a search): the grid's row itself when the tables are the uniform grid (no simplification), else the
    row's entry of ``mrow`` (:func:`cell_knots`), the knot at or below the row's lower edge: a simplified
    marginal's knots are some of the grid's edges, so the guess is the answer but at a row's edge."""
    n_rows, grid, mx, mf, moff, cx, cf, coff = t.n_rows, t.grid, t.mx, t.mf, t.moff, t.cx, t.cf, t.coff
    # wi.z = 0 belongs to the last row: a draw can round onto the horizon (x = 0), and its density is this
    if d[2] < 0.0:
        return 0.0
    b, c_ref, s_ref = bin_of(w, t.n_theta_o, t.n_phi_o)
    cos_t = min(1.0, d[2])
    x = -cos_t
    lo = moff[b]
    hi = moff[b + 1]
    row = fastmath.polar_cell(cos_t, n_rows)
    k = walk_interval(mx, lo, hi, x, lo + row if grid else lo + np.int64(t.mrow[b, row]))
    dx = mx[k + 1] - mx[k]
    dF = mf[k + 1] - mf[k]
    c = b * n_rows + row
    clo = coff[c]
    chi = coff[c + 1]
    # the knot below phi_i: found from the arc tangent's estimate, and from the exact angle only when the
    # estimate is within its error of a knot (the same knot either way)
    guess = table_azimuth_estimate(d, c_ref, s_ref)
    j = _azimuth_knot(grid, cx, clo, chi, guess)
    if not (cx[j] + fastmath.AZIMUTH_MARGIN < guess < cx[j + 1] - fastmath.AZIMUTH_MARGIN):
        j = _azimuth_knot(grid, cx, clo, chi, table_azimuth(d, c_ref, s_ref))
    dphi = cx[j + 1] - cx[j]
    dG = cf[j + 1] - cf[j]
    return (dF / dx) * (dG / dphi) if dx > 0.0 and dphi > 0.0 else 0.0


@kernel
def _cdf_sample_rows(wo, u, t, wi_out, pdf_out, cond, half):
    """One direction per row of ``wo`` from the uniforms ``u (n, >= 2)``, into ``wi_out`` and ``pdf_out``.

    In blocks of ``_BLOCK`` rows, each in two loops (every row's marginal, then every row's conditional):
    a draw is two chains of dependent reads from tables larger than the cache, and in short loops over
    independent rows the processor has several rows' reads in flight at once. ``cond (_BLOCK,)`` int64 and
    ``half (_BLOCK, 4)`` are the block's scratch (the caller's: a kernel allocates nothing, core.jit).
    Returns the read-ahead's sum (kept: not a dead computation to the compiler)."""
    mguide, cguide, mx, mf, moff, cx, cf, coff = t.mguide, t.cguide, t.mx, t.mf, t.moff, t.cx, t.cf, t.coff
    n_theta_o, n_phi_o, n_rows = t.n_theta_o, t.n_phi_o, t.n_rows
    touched = 0.0
    for i0 in range(0, wo.shape[0], _BLOCK):
        i1 = min(wo.shape[0], i0 + _BLOCK)
        for i in range(i0, i1):
            w = (wo[i, 0], wo[i, 1], wo[i, 2])
            if w[2] <= 0.0:
                cond[i - i0] = -1
                continue
            c, cos_t, pdf_m, c_ref, s_ref = _cdf_marginal(w, u[i, 0], mguide, n_theta_o, n_phi_o, n_rows, mx,
                                                          mf, moff)  # fmt: skip
            h = half[i - i0]
            cond[i - i0] = c
            h[0], h[1], h[2], h[3] = cos_t, pdf_m, c_ref, s_ref
        # the conditionals' knots where each row's search starts, read ahead (a few instructions a row: the
        # whole block's reads in flight, as core.merl.read_ahead does; the table is larger than the caches)
        size = cguide.shape[1] - 1
        for i in range(i0, i1):
            c = cond[i - i0]
            if c >= 0:
                j = np.int64(cguide[c, min(int(u[i, 1] * size), size - 1)])
                touched += cf[j] + cf[min(j + 2, coff[c + 1] - 1)]
        for i in range(i0, i1):
            c = cond[i - i0]
            if c < 0:
                x, y, z, pdf = 0.0, 0.0, 1.0, 0.0
            else:
                h = half[i - i0]
                x, y, z, pdf_c = _cdf_conditional(c, u[i, 1], h[0], h[2], h[3], cguide, cx, cf, coff)
                pdf = h[1] * pdf_c
            wi_out[i, 0] = x
            wi_out[i, 1] = y
            wi_out[i, 2] = z
            pdf_out[i] = pdf
    return touched


@kernel
def _cdf_pdf_rows(wo, wi, mask, t, out):
    """The density at the rows of ``(wo, wi)`` where ``mask`` holds (every row for an empty ``mask``)."""
    every = mask.shape[0] == 0
    for i in range(wo.shape[0]):
        if every or mask[i]:
            w = (wo[i, 0], wo[i, 1], wo[i, 2])
            d = (wi[i, 0], wi[i, 1], wi[i, 2])
            if w[2] <= 0.0:
                out[i] = 0.0
            else:
                out[i] = _cdf_density(w, d, t)


class CDFSampler(Sampler):
    """Tabulated marginal/conditional CDFs per incident-angle bin; ``tol > 0`` compresses them.

    Layout (flat arrays so that numba kernels need no per-bin objects): the marginal of bin ``b`` is the
    polyline ``(mx, mf)[moff[b]:moff[b+1]]`` with ``mx = -cos theta_i`` increasing; the conditional of row
    ``r`` of bin ``b`` is ``(cx, cf)[coff[b*n_rows+r]:coff[b*n_rows+r+1]]`` with ``cx = phi_i`` (relative to
    ``phi_o`` for isotropic BRDFs).
    """

    name = "uniform_cdf"
    third_uniform = False  # a draw reads u[:, 0] (the marginal) and u[:, 1] (the conditional) only

    def __init__(
        self,
        brdf: BRDF,
        n_theta_o: int = 32,
        n_phi_o: int | None = None,
        n_theta: int = 64,
        n_phi: int = 128,
        substeps: int = 3,
        tol: float = 0.0,
        defensive: float = 1e-3,
    ):
        super().__init__(brdf)
        for label, v in (
            ("n_theta_o", n_theta_o),
            ("n_theta", n_theta),
            ("n_phi", n_phi),
            ("substeps", substeps),
        ):
            if int(v) < 1:
                raise ParameterError(f"{label} must be a positive integer, got {v}")
        if not (0.0 <= tol < 1.0) or not (0.0 < defensive < 1.0):
            raise ParameterError("tol must be in [0, 1) and defensive in (0, 1)")
        if n_phi_o is None:  # anisotropic: a coarser (theta_o, phi_o) grid keeps memory in check
            n_phi_o = 1 if brdf.model.isotropic else 8
            if not brdf.model.isotropic:
                n_theta_o = min(n_theta_o, 16)
        self.n_theta_o, self.n_phi_o = int(n_theta_o), int(n_phi_o)
        self.n_theta, self.n_phi, self.substeps = int(n_theta), int(n_phi), int(substeps)
        self.tol, self.defensive = float(tol), float(defensive)
        t0 = time.perf_counter()
        self._build()
        self.build_seconds = time.perf_counter() - t0

    def _cell_values(self, wo: np.ndarray) -> np.ndarray:
        """Mean luminance of ``f cos`` over each ``(theta_i, phi_i)`` cell for one ``wo``: ``(n_theta, n_phi)``."""
        s = self.substeps
        nt, nph = self.n_theta, self.n_phi
        # Sub-samples uniform in solid angle within each cell: cos theta stratified, phi stratified.
        r = (np.arange(nt)[:, None] + (np.arange(s)[None, :] + 0.5) / s).ravel()  # fractional row
        c_edges_hi = np.cos(np.floor(r) * HALF_PI / nt)
        c_edges_lo = np.cos((np.floor(r) + 1) * HALF_PI / nt)
        frac = r - np.floor(r)
        cos_t = c_edges_hi + frac * (c_edges_lo - c_edges_hi)
        phi = (np.arange(nph * s) + 0.5) * TWO_PI / (nph * s)
        ct, ph = np.meshgrid(cos_t, phi, indexing="ij")
        st = np.sqrt(np.maximum(0.0, 1.0 - ct * ct))
        wi = np.stack([st * np.cos(ph), st * np.sin(ph), ct], axis=-1).reshape(-1, 3)
        wo_rep = np.broadcast_to(wo, wi.shape)
        f = eval_batch(
            self.brdf.model, np.ascontiguousarray(wi), np.ascontiguousarray(wo_rep), self.brdf.params
        )
        g = (f @ LUMINANCE) * wi[:, 2]
        g = np.maximum(g, 0.0).reshape(nt, s, nph, s).mean(axis=(1, 3))
        return g

    def _build(self) -> None:
        nt, nph = self.n_theta, self.n_phi
        theta_edges = np.arange(nt + 1) * HALF_PI / nt
        x_edges = -np.cos(theta_edges)
        x_edges[-1] = 0.0
        phi_edges = np.arange(nph + 1) * TWO_PI / nph
        solid = np.diff(x_edges)[:, None] * np.diff(phi_edges)[None, :]  # cell solid angles
        mx, mf, moff, mkeep = [], [], [0], []
        cx, cf, coff = [], [], [0]
        for wo in bin_directions(self.n_theta_o, self.n_phi_o):
            if self.n_phi_o == 1:
                wo = np.array([math.sqrt(1.0 - wo[2] ** 2), 0.0, wo[2]])  # isotropic: table relative to phi_o
            g = self._cell_values(wo)
            mean = float(g.mean())
            floor = self.defensive * mean if mean > 0.0 else 1.0
            mass = np.maximum(g, floor) * solid  # probability mass per cell (unnormalized)
            row_mass = mass.sum(axis=1)
            F = np.concatenate([[0.0], np.cumsum(row_mass)])
            F /= F[-1]
            keep = douglas_peucker(x_edges, F, self.tol) if self.tol > 0 else np.arange(nt + 1)
            mx.append(x_edges[keep])
            mf.append(F[keep])
            mkeep.append(keep)
            moff.append(moff[-1] + len(keep))
            for r in range(nt):
                G = np.concatenate([[0.0], np.cumsum(mass[r])])
                G /= G[-1]
                keep = douglas_peucker(phi_edges, G, self.tol) if self.tol > 0 else np.arange(nph + 1)
                cx.append(phi_edges[keep])
                cf.append(G[keep])
                coff.append(coff[-1] + len(keep))
        # each knot's abscissa and CDF value side by side: a draw reads both of the knots it lands between,
        # one cache line where two separate arrays cost two misses (the views below are strided)
        self._m = np.stack([np.concatenate(mx), np.concatenate(mf)], axis=1)
        self._c = np.stack([np.concatenate(cx), np.concatenate(cf)], axis=1)
        self._mx, self._mf = self._m[:, 0], self._m[:, 1]
        self._cx, self._cf = self._c[:, 0], self._c[:, 1]
        self._moff = np.asarray(moff, dtype=np.int64)
        self._coff = np.asarray(coff, dtype=np.int64)
        # where a density's marginal search starts (the uniform grid needs none: a row is its own segment)
        self._mrow = cell_knots(mkeep, nt, nt) if self.tol > 0.0 else np.zeros((0, 1), dtype=np.uint16)
        self._mguide = interval_guides(self._mf, self._moff, _MARGINAL_GUIDE)
        self._cguide = interval_guides(self._cf, self._coff, _CONDITIONAL_GUIDE)

    def _tables(self) -> CdfTables:
        return CdfTables(
            int(self.n_theta_o), int(self.n_phi_o), int(self.n_theta), bool(self.tol == 0.0), self._mx, self._mf,
            self._moff, self._cx, self._cf, self._coff, self._mrow, self._mguide, self._cguide,
        )  # fmt: skip

    def _directions_into(self, wo: np.ndarray, u: np.ndarray, wi: np.ndarray, pdf: np.ndarray) -> None:
        cond, half = np.empty(_BLOCK, dtype=np.int64), np.empty((_BLOCK, 4))
        _cdf_sample_rows(wo, u, self._tables(), wi, pdf, cond, half)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        out = np.empty(wo.shape[0])
        self._pdf_where(wo, wi, EVERY_ROW, out)
        return out

    def _pdf_where(self, wo: np.ndarray, wi: np.ndarray, mask: np.ndarray, pdf: np.ndarray) -> None:
        _cdf_pdf_rows(wo, wi, mask, self._tables(), pdf)

    def memory_bytes(self) -> int:
        arrays = (self._m, self._c, self._moff, self._coff, self._mguide, self._cguide, self._mrow)
        return int(sum(a.nbytes for a in arrays))

    def info(self) -> dict[str, Any]:
        return {
            "sampler": self.name,
            "memory_bytes": self.memory_bytes(),
            "build_seconds": self.build_seconds,
            "bins": self.n_theta_o * self.n_phi_o,
            "grid": f"{self.n_theta}x{self.n_phi}",
            "tol": self.tol,
            "knots": int(len(self._mx) + len(self._cx)),
        }


class CompressedCDFSampler(CDFSampler):
    """CompressCDF: the CDF curves simplified by Douglas-Peucker (default tolerance 1e-3 in CDF units)."""

    name = "compress_cdf"

    def __init__(self, brdf: BRDF, tol: float = 1e-3, **options: Any):
        if not (0.0 < float(tol) < 1.0):
            raise ParameterError(f"compress_cdf needs a tolerance in (0, 1), got {tol}")
        super().__init__(brdf, tol=tol, **options)


_GRID_OPTIONS = (
    SamplerOption("n_theta_o", "int", 1, 256, doc="incident-angle bins in theta"),
    SamplerOption("n_phi_o", "int", 1, 64, doc="incident-angle bins in phi (anisotropic BRDFs)"),
    SamplerOption("n_theta", "int", 1, 1024, doc="rows of each bin's table"),
    SamplerOption("n_phi", "int", 1, 2048, doc="columns of each bin's table"),
    SamplerOption("substeps", "int", 1, 16, doc="sub-samples per cell side when tabulating"),
    SamplerOption("defensive", "float", 0.0, 0.5, lo_open=True, doc="mixture weight of uniform sampling"),
)


def _table_bytes(brdf: BRDF, o: dict[str, Any]) -> float:
    """An upper bound of a table's memory: 2 float64 knots per cell of every bin, and one bin's tabulation
    (``substeps^2`` sub-samples a cell, each with its direction pair and RGB value)."""
    bins = o.get("n_theta_o", 32) * o.get("n_phi_o", 1 if brdf.model.isotropic else 8)
    cells = o.get("n_theta", 64) * (o.get("n_phi", 128) + 1)
    guides = 4.0 * (_MARGINAL_GUIDE + 1 + o.get("n_theta", 64) * (_CONDITIONAL_GUIDE + 1))
    guides += 2.0 * o.get("n_theta", 64)  # cell_knots' starts of the marginal
    return bins * (16.0 * cells + guides) + 120.0 * cells * o.get("substeps", 3) ** 2


register_sampler(
    "uniform_cdf",
    lambda brdf, **o: CDFSampler(brdf, **o),
    (*_GRID_OPTIONS, SamplerOption("tol", "float", 0.0, 0.5, doc="CDF simplification tolerance (0: none)")),
    _table_bytes,
)
register_sampler(
    "compress_cdf",
    lambda brdf, **o: CompressedCDFSampler(brdf, **o),
    (
        *_GRID_OPTIONS,
        SamplerOption("tol", "float", 0.0, 0.5, lo_open=True, doc="CDF simplification tolerance"),
    ),
    _table_bytes,
)
