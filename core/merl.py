"""MERL measured BRDFs (Matusik et al. 2003, "A Data-Driven Reflectance Model"): the ``.binary`` format.

File layout: three int32 ``(90, 90, 180)`` (the table dimensions), then ``3 x 90*90*180`` float64 stored as
separate R, G, B planes. A cell is indexed by the Rusinkiewicz half/difference angles of the pair:

``index = phi_d_idx + 180 * theta_d_idx + 180 * 90 * theta_h_idx`` with
``theta_h_idx = floor(sqrt(theta_h / (pi/2)) * 90)`` (non-linear: finer near the mirror direction),
``theta_d_idx = floor(theta_d / (pi/2) * 90)``, ``phi_d_idx = floor(phi_d / pi * 180)`` after folding
``phi_d`` into ``[0, pi)`` by reciprocity; every index is clamped into its range. Stored values are
multiplied by the channel scales ``1/1500, 1.15/1500, 1.66/1500`` to give ``f_r``; negative values mark
missing measurements.

A measured BRDF is a :class:`core.brdf.BRDF` like any other: its kernel ``eval_merl(wi, wo, p)`` has the model
kernel signature, and ``p`` is the whole scaled table (missing cells kept negative, RGB interleaved), so every batch driver and
sampler takes it unchanged. Make one with :func:`measured_brdf`.

Lookup (a decision, see docs/analysis.md): trilinear interpolation between cell centres in index space
(``sqrt(theta_h)``, ``theta_d``, ``phi_d``, periodic in ``phi_d``), leaving missing cells out of the weights. It
is exact at the cell centres, continuous (so reciprocity and isotropy hold to rounding, with no jumps at cell
faces, and quadrature error estimates stay reliable) and second-order accurate between centres. MERL's reference
lookup, the containing cell, is :func:`eval_merl_nearest` (``measured_brdf(path, interpolate=False)``).

The writer exports any BRDF by evaluating it at the cell centres (centre taken in index space, so the
``theta_h`` centre is ``((i + 1/2) / 90)^2 * pi/2``) with ``phi_h = 0``. MERL tables are isotropic and
reciprocal by construction: an anisotropic model is exported as its ``phi_h = 0`` slice and a non-reciprocal
one as its ``phi_d in [0, pi)`` half. Cells whose centre puts ``wi`` or ``wo`` below the horizon hold the mean
of the model over the part of the cell above the horizon (a 4 x 4 x 4 sub-grid), or a missing marker (-1)
when no sub-point is valid.

Reproduce the bundled demo file: ``python -m core.merl --export MODEL [k=v ...] --out FILE``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numba import njit

from core import dispatch  # the module: it imports this one (circular, resolved when _tabulate compiles)
from core.brdf import BRDF, Model, Traits
from core.errors import FileFormatError
from core.fastmath import atan2
from core.io import atomic_write, check_input_file
from core.jit import kernel
from core.measured import FileBRDF

N_THETA_H = 90
N_THETA_D = 90
N_PHI_D = 180
N_CELLS = N_THETA_H * N_THETA_D * N_PHI_D
SHAPE = (3, N_THETA_H, N_THETA_D, N_PHI_D)
SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])
HEADER_BYTES = 3 * 4
FILE_BYTES = HEADER_BYTES + 3 * N_CELLS * 8
MISSING = -1.0
"""Raw value the writer stores for a cell with no valid direction pair."""

HALF_PI = 0.5 * math.pi


# --------------------------------------------------------------------------------------------- lookup


@njit(inline="always", nogil=True, cache=True)
def half_diff_angles(wi, wo):
    """Rusinkiewicz half/difference angles ``(theta_h, theta_d, phi_d)`` of a pair; ``phi_d`` in ``(-pi, pi]``."""
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    n = math.sqrt(hx * hx + hy * hy + hz * hz)
    if n == 0.0:
        hx, hy, hz = 0.0, 0.0, 1.0
    else:
        hx, hy, hz = hx / n, hy / n, hz / n
    # cos/sin of theta_h and phi_h straight from h (no trig calls); atan2 keeps small angles accurate.
    r = math.sqrt(hx * hx + hy * hy)
    theta_h = math.atan2(r, hz)
    if r > 0.0:
        c, s = hx / r, hy / r
    else:
        c, s = 1.0, 0.0
    # d = R_y(-theta_h) R_z(-phi_h) wi: wi seen from the half vector's frame.
    x = wi[0] * c + wi[1] * s
    y = wi[1] * c - wi[0] * s
    z = wi[2]
    ct, st = hz, r
    dx = x * ct - z * st
    dz = x * st + z * ct
    theta_d = math.atan2(math.sqrt(dx * dx + y * y), dz)
    phi_d = math.atan2(y, dx)
    return theta_h, theta_d, phi_d


@njit(inline="always", nogil=True, cache=True)
def merl_index(wi, wo):
    """Flat cell index of a direction pair (both above the horizon), as MERL's reference reader computes it."""
    theta_h, theta_d, phi_d = half_diff_angles(wi, wo)
    if theta_h <= 0.0:
        ih = 0
    else:
        ih = min(N_THETA_H - 1, max(0, int(math.sqrt(theta_h / HALF_PI) * N_THETA_H)))
    id_ = min(N_THETA_D - 1, max(0, int(theta_d / HALF_PI * N_THETA_D)))
    if phi_d < 0.0:
        phi_d += math.pi
    ip = min(N_PHI_D - 1, max(0, int(phi_d / math.pi * N_PHI_D)))
    return ip + N_PHI_D * (id_ + N_THETA_D * ih)


@kernel
def eval_merl_nearest(wi, wo, p):
    """``f_r`` from the containing cell, as MERL's reference reader; missing cells read as 0.

    ``p`` is :meth:`MerlTable.kernel_vector`: scaled values, missing cells negative, RGB interleaved.
    """
    if wi[2] <= 0.0 or wo[2] <= 0.0 or p.shape[0] != 3 * N_CELLS:
        return 0.0, 0.0, 0.0
    k = 3 * merl_index(wi, wo)
    return max(p[k], 0.0), max(p[k + 1], 0.0), max(p[k + 2], 0.0)


@njit(inline="always", nogil=True, cache=True)
def _bracket(u, n):
    """Lower neighbour index and weight of the upper one for centre-based coordinate ``u`` (clamped)."""
    if u <= 0.0:
        return 0, 0.0
    if u >= n - 1:
        return n - 2, 1.0
    i = int(u)
    return i, u - i


@njit(inline="always", nogil=True, cache=True)
def _lookup_angles(wi, wo):
    """``(theta_h, theta_d, phi_d)`` of a pair as :func:`half_diff_angles` (to ~1e-14), ``phi_d`` folded into
    ``[0, pi]``, without normalizing ``h`` or turning ``wi`` into its frame: with ``h = wi + wo`` unnormalized,
    ``r = |h_xy|`` and ``n = |h|``, the vector ``d`` of :func:`half_diff_angles` times ``r n`` is
    ``(a h_z - wi_z r^2, n (wi_y h_x - wi_x h_y), r (a + wi_z h_z))``, ``a = wi_x h_x + wi_y h_y``, and the
    three angles are arc tangents of ratios (no divisions before them); the arc tangents are :func:`core.fastmath.atan2`."""
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    r2 = hx * hx + hy * hy
    r = math.sqrt(r2)
    if r > 0.0:
        n = math.sqrt(r2 + hz * hz)
        a = wi[0] * hx + wi[1] * hy
        dx = a * hz - wi[2] * r2
        dy = n * (wi[1] * hx - wi[0] * hy)
        dz = r * (a + wi[2] * hz)
    else:  # h along the normal: its frame is the local one
        dx, dy, dz = wi[0], wi[1], wi[2]
    theta_h = atan2(r, hz)
    theta_d = atan2(math.sqrt(dx * dx + dy * dy), dz)
    if dy < 0.0:  # reciprocity: phi_d and phi_d + pi are the same cell
        dx, dy = -dx, -dy
    return theta_h, theta_d, atan2(dy, dx)


@njit(inline="always", nogil=True, cache=True)
def _add_corner(p, k, w, acc):
    """``acc = (sum w v_r, sum w v_g, sum w v_b, sum w over valid r, g, b)`` with the corner at ``p[k]``
    added; a missing (negative) value adds nothing (selects, not branches)."""
    r = p[k]
    g = p[k + 1]
    b = p[k + 2]
    wr = w if r >= 0.0 else 0.0
    wg = w if g >= 0.0 else 0.0
    wb = w if b >= 0.0 else 0.0
    return (acc[0] + wr * r, acc[1] + wg * g, acc[2] + wb * b, acc[3] + wr, acc[4] + wg, acc[5] + wb)


@njit(inline="always", nogil=True, cache=True)
def _cell(wi, wo):
    """Where :func:`eval_merl` reads for a pair (both above the horizon): the first of the four
    ``(theta_h, theta_d)`` rows of its eight corners (``b00``), the two ``phi_d`` neighbours ``k0, k1`` and the
    fractions ``th, td, tp`` along the three axes. The corners' values are ``p[3 (k + b)]`` for ``k`` in
    ``(k0, k1)`` and ``b`` in ``b00``, ``b00 + N_PHI_D``, ``b00 + N_PHI_D N_THETA_D`` and the next row."""
    theta_h, theta_d, phi_d = _lookup_angles(wi, wo)
    ih, th = _bracket(math.sqrt(max(theta_h, 0.0) * (1.0 / HALF_PI)) * N_THETA_H - 0.5, N_THETA_H)
    jd, td = _bracket(theta_d * (N_THETA_D / HALF_PI) - 0.5, N_THETA_D)
    up = phi_d * (N_PHI_D / math.pi) - 0.5
    kp = int(math.floor(up))
    tp = up - kp
    k0 = kp if kp >= 0 else kp + N_PHI_D  # the two phi_d neighbours (periodic), without a modulo
    k1 = kp + 1 if kp + 1 < N_PHI_D else kp + 1 - N_PHI_D
    return N_PHI_D * (jd + N_THETA_D * ih), k0, k1, th, td, tp


@njit(inline="always", nogil=True, cache=True)
def _combine(p, b00, k0, k1, th, td, tp):
    """The trilinear sum of :func:`eval_merl` over the eight corners of :func:`_cell`'s answer."""
    b01 = b00 + N_PHI_D
    b10 = b00 + N_PHI_D * N_THETA_D
    b11 = b10 + N_PHI_D
    w00 = (1.0 - th) * (1.0 - td)
    w01 = (1.0 - th) * td
    w10 = th * (1.0 - td)
    w11 = th * td
    sp = 1.0 - tp
    # straight-line, in the order of the loops it replaced (theta_h, theta_d, phi_d): the same sums to the bit
    acc = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    acc = _add_corner(p, 3 * (k0 + b00), w00 * sp, acc)
    acc = _add_corner(p, 3 * (k1 + b00), w00 * tp, acc)
    acc = _add_corner(p, 3 * (k0 + b01), w01 * sp, acc)
    acc = _add_corner(p, 3 * (k1 + b01), w01 * tp, acc)
    acc = _add_corner(p, 3 * (k0 + b10), w10 * sp, acc)
    acc = _add_corner(p, 3 * (k1 + b10), w10 * tp, acc)
    acc = _add_corner(p, 3 * (k0 + b11), w11 * sp, acc)
    acc = _add_corner(p, 3 * (k1 + b11), w11 * tp, acc)
    acc_r, acc_g, acc_b, w_r, w_g, w_b = acc
    r = acc_r / w_r if w_r > 0.0 else 0.0
    g = acc_g / w_g if w_g > 0.0 else 0.0
    b_ = acc_b / w_b if w_b > 0.0 else 0.0
    return r, g, b_


@kernel
def eval_merl(wi, wo, p):
    """``f_r`` by trilinear interpolation between cell centres in index space (``sqrt(theta_h)``,
    ``theta_d``, ``phi_d``; periodic in ``phi_d`` with period pi). Exact at cell centres and continuous;
    missing cells are left out of the weights (0 where every neighbour is missing).

    ``p`` is :meth:`MerlTable.kernel_vector`: scaled values, missing cells negative, RGB interleaved.
    The angles come from :func:`_lookup_angles` (its own arc tangents; MERL's reference reader,
    :func:`eval_merl_nearest`, keeps :func:`half_diff_angles`) and the eight corners are summed
    without branches: 75 ns a lookup, against 136 ns with the library's arc tangents and branching sums (a
    sweep of one view's directions, one core). Many rows at
    once: :func:`eval_merl_rows`.
    """
    if wi[2] <= 0.0 or wo[2] <= 0.0 or p.shape[0] != 3 * N_CELLS:
        return 0.0, 0.0, 0.0
    b00, k0, k1, th, td, tp = _cell(wi, wo)
    return _combine(p, b00, k0, k1, th, td, tp)


MERL_BLOCK = 64
"""Rows of :func:`eval_merl_rows`'s blocks (its scratch rows)."""
_ROW = 3 * N_PHI_D  # the table's step to the next theta_d row, and to the next theta_h slab
_SLAB = 3 * N_PHI_D * N_THETA_D


@njit(inline="always", nogil=True, cache=True)
def find_cell(wi, wo, p, cell, fraction):
    """:func:`_cell` of a lookup into ``cell (3,)`` int64 (``b00, k0, k1``) and ``fraction (3,)``, or
    ``cell[0] = -2`` where :func:`eval_merl` is 0 (a direction at or below the horizon, a table of the wrong
    size). The first step of a lookup split in three (:func:`eval_merl_rows`)."""
    if wi[2] <= 0.0 or wo[2] <= 0.0 or p.shape[0] != 3 * N_CELLS:
        cell[0] = -2
        return
    b00, k0, k1, th, td, tp = _cell(wi, wo)
    cell[0], cell[1], cell[2] = b00, k0, k1
    fraction[0], fraction[1], fraction[2] = th, td, tp


@njit(inline="always", nogil=True, cache=True)
def read_ahead(p, cell):
    """The first and the last value of each of the four pairs of corners of a found ``cell`` (0 for none),
    summed: the second step, a few instructions that bring the corners into the cache. A pair (the two
    ``phi_d`` neighbours, 48 bytes) crosses a cache line in 5 cells of 8, and its far end was read only by the
    sums: reading it here too brings a measured row's ``f`` in a ``compress_cdf`` pass from 163 to 113 ns, and
    saves 2-3 ms of a pass of every strategy."""
    b00 = cell[0]
    if b00 < 0:
        return 0.0
    k = 3 * (cell[1] + b00)
    j = 3 * (cell[2] + b00) + 2
    return (p[k] + p[k + _ROW] + p[k + _SLAB] + p[k + _SLAB + _ROW]) + (
        p[j] + p[j + _ROW] + p[j + _SLAB] + p[j + _SLAB + _ROW]
    )


@njit(inline="always", nogil=True, cache=True)
def cell_value(p, cell, fraction):
    """:func:`eval_merl`'s value from a found ``cell`` (``cell[0] >= 0``, or -2: 0): the last step."""
    if cell[0] < 0:
        return 0.0, 0.0, 0.0
    return _combine(p, cell[0], cell[1], cell[2], fraction[0], fraction[1], fraction[2])


@kernel
def eval_merl_rows(wi, wo, p, keep, out, cells, fractions):
    """:func:`eval_merl` at the rows where ``keep`` holds (every row for an empty ``keep``), into ``out (n, 3)``;
    the other rows are left as they are. The same values to the bit, in three passes over blocks of
    ``MERL_BLOCK`` rows: every row's cell (:func:`find_cell`, into the scratch ``cells (MERL_BLOCK, 3)`` int64
    and ``fractions (MERL_BLOCK, 3)``), then a read of each cache line its corners lie on (:func:`read_ahead`),
    then the sums (:func:`cell_value`). Returns the reads' sum (kept: not a dead computation to the compiler).

    A table of 4.4 M cells is larger than the caches, and in a render the other stages evict it between two
    lookups: each lookup waits for memory. In one loop a lookup's hundreds of instructions keep the
    processor from reaching the next rows' reads; the second pass is a few instructions a row, so the reads
    of a whole block are in flight at once, and the sums find them in the cache."""
    every = keep.shape[0] == 0
    n = wi.shape[0]
    touched = 0.0
    for i0 in range(0, n, MERL_BLOCK):
        i1 = min(n, i0 + MERL_BLOCK)
        for i in range(i0, i1):
            cells[i - i0, 0] = -1
            if every or keep[i]:
                find_cell((wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p, cells[i - i0],
                          fractions[i - i0])  # fmt: skip
        for r in range(i1 - i0):
            touched += read_ahead(p, cells[r])
        for i in range(i0, i1):
            if cells[i - i0, 0] != -1:
                out[i, 0], out[i, 1], out[i, 2] = cell_value(p, cells[i - i0], fractions[i - i0])
    return touched


_MERL_CITATION = (
    "W. Matusik, H. Pfister, M. Brand, L. McMillan, A Data-Driven Reflectance Model, "
    "ACM Trans. Graph. 22(3), 2003."
)

MERL = Model(
    name="merl",
    label="Measured (MERL)",
    citation=_MERL_CITATION,
    params=(),
    traits=Traits.ISOTROPIC | Traits.RECIPROCAL,
    eval=eval_merl,
    doc=__doc__ or "",
    notes="Trilinear interpolation between cell centres; missing measurements left out (0 if all are). "
    "Not in the model registry: a measured BRDF is made from a file with core.merl.measured_brdf(path).",
    measured=True,
)
"""The measured 'model': declared like the analytic ones, but not registered (it needs a file, not
parameters). Every measured BRDF shares it."""

MERL_NEAREST = replace(
    MERL,
    name="merl_nearest",
    label="Measured (MERL, nearest cell)",
    eval=eval_merl_nearest,
    notes="Containing-cell lookup as MERL's reference reader; piecewise constant.",
)


class MeasuredBRDF(FileBRDF):
    """A BRDF backed by a MERL table; ``path`` says where it came from (``None`` for an in-memory table)."""

    def __init__(self, table: MerlTable, path: str | None = None, interpolate: bool = True):
        super().__init__(MERL if interpolate else MERL_NEAREST, table.kernel_vector(), table, path)


# --------------------------------------------------------------------------------------------- table


@dataclass(frozen=True)
class MerlTable:
    """A MERL table as stored: ``raw (3, 90, 90, 180)`` float64 before the channel scales; negative = missing."""

    raw: np.ndarray

    def values(self) -> np.ndarray:
        """``f_r`` per cell, ``(3, 90, 90, 180)``, with missing cells set to 0."""
        return np.where(self.raw < 0.0, 0.0, self.raw * SCALES[:, None, None, None])

    def kernel_vector(self) -> np.ndarray:
        """The kernel parameter vector of :func:`eval_merl`: scaled values (missing cells stay negative),
        RGB interleaved per cell (``p[3 k + c]``: one cache line serves a cell's three channels)."""
        scaled = (self.raw * SCALES[:, None, None, None]).reshape(3, N_CELLS)
        return np.ascontiguousarray(scaled.T).reshape(-1)

    @property
    def missing_fraction(self) -> float:
        return float(np.mean(self.raw < 0.0))


def read_merl(path: str | os.PathLike[str]) -> MerlTable:
    """Read a MERL ``.binary`` file; raises :class:`FileFormatError` naming what is wrong."""
    p = Path(path)
    where = f"MERL file '{p}'"
    check_input_file(p, where)
    try:
        size = p.stat().st_size
        with open(p, "rb") as fh:
            header = fh.read(HEADER_BYTES)
            if len(header) < HEADER_BYTES:
                raise FileFormatError(
                    f"{where} is truncated: {size} bytes, too short for the 12-byte header (three int32)"
                )
            dims = tuple(int(d) for d in np.frombuffer(header, dtype="<i4"))
            if dims != (N_THETA_H, N_THETA_D, N_PHI_D):
                raise FileFormatError(
                    f"{where} has table dimensions {dims[0]} x {dims[1]} x {dims[2]} in its header; "
                    f"expected {N_THETA_H} x {N_THETA_D} x {N_PHI_D} (theta_h x theta_d x phi_d)"
                )
            if size < FILE_BYTES:
                raise FileFormatError(
                    f"{where} is truncated: {size} bytes, expected {FILE_BYTES} "
                    f"(12-byte header + 3 x {N_CELLS} float64)"
                )
            if size > FILE_BYTES:
                raise FileFormatError(
                    f"{where} has the wrong size: {size} bytes, expected {FILE_BYTES} "
                    f"({size - FILE_BYTES} bytes of unexpected trailing data)"
                )
            data = np.fromfile(fh, dtype="<f8", count=3 * N_CELLS)
    except OSError as exc:
        raise FileFormatError(f"{where} cannot be read: {exc.strerror or exc}") from None
    if data.size != 3 * N_CELLS:  # the file changed under us
        raise FileFormatError(f"{where} is truncated: read {data.size * 8} bytes of table data")
    bad = ~np.isfinite(data)
    if bad.any():
        raise FileFormatError(
            f"{where} holds {int(bad.sum())} non-finite values (NaN or Inf) of {data.size}; "
            "a MERL table holds finite numbers (negative for missing data)"
        )
    raw = data.astype(np.float64).reshape(SHAPE)
    for c, name in enumerate("RGB"):
        if not np.any(raw[c] >= 0.0):
            raise FileFormatError(
                f"{where} holds no valid data in channel {name}: every value is negative (missing)"
            )
    return MerlTable(raw)


def measured_brdf(path: str | os.PathLike[str], interpolate: bool = True) -> MeasuredBRDF:
    """A :class:`BRDF` from a MERL file (errors as :func:`read_merl`): trilinear lookup, or the containing
    cell with ``interpolate=False``."""
    return MeasuredBRDF(read_merl(path), str(path), interpolate)


# --------------------------------------------------------------------------------------------- writer


@njit(inline="always", nogil=True, cache=True)
def _pair_from_cell(u_h, u_d, u_p):
    """The direction pair at fractional index coordinates ``(u_h, u_d, u_p)`` (cell ``i`` spans ``[i, i+1)``)
    with ``phi_h = 0``: returns ``wi, wo``."""
    s = u_h / N_THETA_H
    theta_h = s * s * HALF_PI
    theta_d = u_d / N_THETA_D * HALF_PI
    phi_d = u_p / N_PHI_D * math.pi
    sd = math.sin(theta_d)
    x = sd * math.cos(phi_d)
    y = sd * math.sin(phi_d)
    z = math.cos(theta_d)
    ct, st = math.cos(theta_h), math.sin(theta_h)
    wi = (x * ct + z * st, y, z * ct - x * st)
    k = 2.0 * (wi[0] * st + wi[2] * ct)
    wo = (k * st - wi[0], -wi[1], k * ct - wi[2])
    return wi, wo


@kernel
def _tabulate(mid, p, scales, sub, out):
    """``out (3, N_CELLS)``: the raw values of model ``mid`` (a :mod:`core.dispatch` id) with kernel
    parameters ``p`` at the cell centres (see the module docstring)."""
    for ih in range(N_THETA_H):
        for jd in range(N_THETA_D):
            for kp in range(N_PHI_D):
                idx = kp + N_PHI_D * (jd + N_THETA_D * ih)
                wi, wo = _pair_from_cell(ih + 0.5, jd + 0.5, kp + 0.5)
                if wi[2] > 0.0 and wo[2] > 0.0:
                    r, g, b = dispatch.eval_model(mid, wi, wo, p)
                else:
                    # Centre below the horizon: the mean over the valid part of the cell.
                    r = g = b = 0.0
                    count = 0
                    for a in range(sub):
                        for bb in range(sub):
                            for c in range(sub):
                                wi2, wo2 = _pair_from_cell(
                                    ih + (a + 0.5) / sub, jd + (bb + 0.5) / sub, kp + (c + 0.5) / sub
                                )
                                if wi2[2] > 0.0 and wo2[2] > 0.0:
                                    r2, g2, b2 = dispatch.eval_model(mid, wi2, wo2, p)
                                    r += r2
                                    g += g2
                                    b += b2
                                    count += 1
                    if count == 0:
                        out[0, idx] = MISSING
                        out[1, idx] = MISSING
                        out[2, idx] = MISSING
                        continue
                    r /= count
                    g /= count
                    b /= count
                out[0, idx] = r / scales[0]
                out[1, idx] = g / scales[1]
                out[2, idx] = b / scales[2]


def tabulate(brdf: BRDF, subcells: int = 4) -> MerlTable:
    """A MERL table of ``brdf`` (any model, analytic or measured): its value at every cell centre."""
    out = np.empty((3, N_CELLS), dtype=np.float64)
    _tabulate(brdf.model.id, brdf.params, SCALES, int(subcells), out)
    bad = ~np.isfinite(out)
    if bad.any():  # a model bug, but never write a file the reader would refuse
        raise FileFormatError(f"cannot export {brdf.key()}: it gives {int(bad.sum())} non-finite values")
    return MerlTable(out.reshape(SHAPE))


def cell_centre_pairs(ih: np.ndarray, jd: np.ndarray, kp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Direction pairs ``(wi, wo)``, each ``(n, 3)``, at the centres of cells ``(ih, jd, kp)`` (phi_h = 0)."""
    ih, jd, kp = np.broadcast_arrays(np.asarray(ih), np.asarray(jd), np.asarray(kp))
    s = (ih + 0.5) / N_THETA_H
    theta_h = s * s * HALF_PI
    theta_d = (jd + 0.5) / N_THETA_D * HALF_PI
    phi_d = (kp + 0.5) / N_PHI_D * np.pi
    d = np.stack([np.sin(theta_d) * np.cos(phi_d), np.sin(theta_d) * np.sin(phi_d), np.cos(theta_d)], -1)
    ct, st = np.cos(theta_h), np.sin(theta_h)
    wi = np.stack([d[..., 0] * ct + d[..., 2] * st, d[..., 1], d[..., 2] * ct - d[..., 0] * st], -1)
    h = np.stack([st, np.zeros_like(st), ct], -1)
    wo = 2.0 * np.sum(wi * h, axis=-1, keepdims=True) * h - wi
    return wi.reshape(-1, 3), wo.reshape(-1, 3)


def write_merl(path: str | os.PathLike[str], source: BRDF | MerlTable | np.ndarray) -> None:
    """Write a MERL ``.binary`` file atomically.

    ``source`` is a :class:`BRDF` (tabulated with :func:`tabulate`), a :class:`MerlTable`, or raw stored values
    ``(3, 90, 90, 180)`` (before the channel scales; negative = missing).
    """
    if isinstance(source, BRDF):
        raw = tabulate(source).raw
    elif isinstance(source, MerlTable):
        raw = source.raw
    else:
        raw = np.asarray(source, dtype=np.float64)
    if raw.size != 3 * N_CELLS:
        raise FileFormatError(f"a MERL table has 3 x {N_CELLS} values, got array of shape {raw.shape}")
    if not np.all(np.isfinite(raw)):
        raise FileFormatError("cannot write a MERL table holding NaN or Inf values")
    header = np.array([N_THETA_H, N_THETA_D, N_PHI_D], dtype="<i4")
    with atomic_write(path, "wb") as fh:
        fh.write(header.tobytes())
        fh.write(np.ascontiguousarray(raw, dtype="<f8").tobytes())


# --------------------------------------------------------------------------------------------- script


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m core.merl --export MODEL [k=v ...] --out FILE``: write a synthetic MERL file."""
    from core.brdf import make_brdf
    from core.errors import BrdfStudioError

    parser = argparse.ArgumentParser(prog="python -m core.merl", description=main.__doc__)
    parser.add_argument("--export", metavar="MODEL", required=True, help="registered model to tabulate")
    parser.add_argument("params", nargs="*", metavar="k=v", help="model parameters")
    parser.add_argument("--out", required=True, help="output .binary file")
    args = parser.parse_args(argv)
    try:
        brdf = make_brdf(args.export, args.params)
        write_merl(args.out, brdf)
        table = read_merl(args.out)
    except BrdfStudioError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return exc.exit_code
    print(f"wrote {args.out}: {brdf.key()}, missing cells {table.missing_fraction:.2%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
