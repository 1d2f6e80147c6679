"""Fused numba kernels of the adaptive sampler: the whole per-sample loop in one compiled pass.

For each row: locate the incident-angle bin, evaluate the normalizer ``I(wo)`` and the scale ``c(wo)`` from
the bin's Chebyshev tables, map the tree's frame to the row's (isotropic trees live at ``phi_o = 0`` and are
rotated; mirror-symmetric anisotropic trees cover ``0 <= phi_o <= 90`` degrees and are mirrored), then
rejection trials: a descent by mass from the root (restart on rejection), a point uniform in the leaf's
clipped box (recomputed from the leaf's position), the projection to a direction, the luminance of ``f``
times ``cos J`` against the bound.
The pdf ``f cos / I(wo)`` comes from the accepted trial's ``f`` (no second evaluation). The proof that the
density is exact is in :mod:`core.quadtree` and ``docs/adaptive.md``.

**Storage of a tree** (the packed table of :class:`core.quadtree_table.QuadtreeTable`): nodes in level order,
the children of the ``r``-th internal node at ``1 + 4 r`` (the builder's layout). Per node one ``uint32``
mass, in units ``unit`` of the bin: a leaf's mass is ``ceil(area M / unit)``, an internal node's the exact
integer sum of its children's, so the descent picks leaf ``L`` with probability exactly ``V_L / V``. A leaf
stores nothing else: its square follows from its position (root ``[-1, 1]^2``, child ``j`` is quadrant
``j`` in the order ``(x0, y0), (x0 + h, y0), (x0, y0 + h), (x0 + h, y0 + h)``), its clipped box from the
same arithmetic as :func:`core.quadtree.clip_boxes`, and its bound from ``M_L = V_L unit / area >= M``.
Which nodes are internal is one bit per node (``uint64`` words) with the count of internal nodes before
each word, so the first child is ``1 + 4 rank(k)`` (a popcount).

The ``*_impl`` functions take the model's ``eval`` kernel as their first argument; the generated modules of
:mod:`core.specialize` bind it as a global and call them, so numba caches each model's specialization on disk.
A kernel that cannot be specialized is passed to them directly (compiled once per process).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

from core.rng import next_u01

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi
INV_PI = 1.0 / math.pi
LUM_R, LUM_G, LUM_B = 0.2126, 0.7152, 0.0722
"""``core.model.LUMINANCE`` (checked by the tests)."""
MAX_TRIALS = 100_000
"""A row that has not accepted after this many trials (never seen) takes the last one, counted as a violation."""
STACK = 256
CHUNK = 4096
"""Rows per task of the threaded sampler."""
FRAME_FULL, FRAME_ISO, FRAME_MIRROR = 0, 1, 2
"""How a table's trees relate to the row's frame: bins over ``(theta_o, phi_o)`` on the whole circle; bins
over ``theta_o`` only, trees at ``phi_o = 0`` rotated to the row's ``phi_o`` (isotropic BRDFs); bins over
``(theta_o, phi_o)`` with ``phi_o`` folded into ``[0, 90]`` degrees, trees mirrored in x and/or y to the row's
quadrant (anisotropic BRDFs invariant under those mirrors, ``core.model.Traits.MIRROR_SYMMETRIC``)."""


@intrinsic
def _ctpop(typingctx, x):
    """Population count of a ``uint64`` (one instruction where the CPU has it)."""
    if x != types.uint64:
        return None

    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])

    return types.uint64(types.uint64), codegen


@njit(nogil=True, cache=True, inline="always")
def first_child(bits, cum, woff, k):
    """First child of node ``k`` of a tree whose bit words start at ``woff``; -1 for a leaf."""
    w = woff + (k >> 6)
    word = bits[w]
    sh = np.uint64(k & 63)
    if ((word >> sh) & np.uint64(1)) == np.uint64(0):
        return -1
    below = word & ((np.uint64(1) << sh) - np.uint64(1))
    return 1 + 4 * (np.int64(cum[w]) + np.int64(_ctpop(below)))


@njit(nogil=True, cache=True, inline="always")
def clip_box(a0, a1, b0, b1):
    """Bounding box ``(c0, d0, c1, d1)`` of ``[a0,a1] x [b0,b1]`` intersected with the unit disk: the same
    arithmetic as :func:`core.quadtree.clip_boxes` (the builder's areas and masses come from it)."""
    w = 1.0 if b0 <= 0.0 <= b1 else math.sqrt(max(0.0, 1.0 - min(b0 * b0, b1 * b1)))
    h = 1.0 if a0 <= 0.0 <= a1 else math.sqrt(max(0.0, 1.0 - min(a0 * a0, a1 * a1)))
    return max(a0, -w), max(b0, -h), min(a1, w), min(b1, h)


@njit(nogil=True, cache=True, inline="always")
def child_square(x0, y0, size, j):
    """Square ``(x0, y0, size)`` of child ``j``: the builder's quadrant order and arithmetic (``x0 + h`` or
    ``x0``; adding ``0.0`` is exact, as no corner is ``-0.0``), without branches."""
    h = 0.5 * size
    return x0 + h * float(j & 1), y0 + h * float((j >> 1) & 1), h


@njit(nogil=True, cache=True, inline="always")
def descend(state, mass, moff, bits, cum, woff):
    """A leaf chosen by mass from the root (one uniform per level): ``(state, leaf, x0, y0, size)``."""
    k = 0
    x0 = -1.0
    y0 = -1.0
    size = 2.0
    while True:
        c = first_child(bits, cum, woff, k)
        if c < 0:
            return state, k, x0, y0, size
        v0 = float(mass[moff + c])
        v1 = float(mass[moff + c + 1])
        v2 = float(mass[moff + c + 2])
        v3 = float(mass[moff + c + 3])
        state, u = next_u01(state)
        s = u * (v0 + v1 + v2 + v3)
        j = int(s >= v0) + int(s >= v0 + v1) + int(s >= v0 + v1 + v2)  # branch-free: the draw is random
        if mass[moff + c + j] == 0:  # rounding at the top end: the last child with mass
            for q in range(3, -1, -1):
                if mass[moff + c + q] > 0:
                    j = q
                    break
        x0, y0, size = child_square(x0, y0, size, j)
        k = c + j


@njit(nogil=True, cache=True, inline="always")
def leaf_box(mass, moff, k, unit, x0, y0, size):
    """Clipped box, area and bound ``M = V unit / area`` of leaf ``k`` with square ``(x0, y0, size)``."""
    c0, d0, c1, d1 = clip_box(x0, x0 + size, y0, y0 + size)
    area = (c1 - c0) * (d1 - d0)
    m = float(mass[moff + k]) * unit / area if area > 0.0 else 0.0
    return c0, d0, c1, d1, area, m


@njit(nogil=True, cache=True)
def tree_leaves(mass, bits, cum, unit, n_nodes):
    """Rows ``(M, x0, y0, x1, y1)`` of every leaf in level order (zeros for a leaf of mass 0), recomputed
    from the positions as the descent does."""
    sq = np.empty((n_nodes, 3))
    sq[0, 0] = -1.0
    sq[0, 1] = -1.0
    sq[0, 2] = 2.0
    out = np.zeros((n_nodes, 5))
    n = 0
    for k in range(n_nodes):
        c = first_child(bits, cum, 0, k)
        if c >= 0:
            for j in range(4):
                x0, y0, h = child_square(sq[k, 0], sq[k, 1], sq[k, 2], j)
                sq[c + j, 0] = x0
                sq[c + j, 1] = y0
                sq[c + j, 2] = h
        else:
            if mass[k] > 0:
                c0, d0, c1, d1, area, m = leaf_box(mass, 0, k, unit, sq[k, 0], sq[k, 1], sq[k, 2])
                out[n, 0] = m
                out[n, 1] = c0
                out[n, 2] = d0
                out[n, 3] = c1
                out[n, 4] = d1
            n += 1
    return out[:n]


# ------------------------------------------------------------------------------------- bins, normalizers


@njit(nogil=True, cache=True, inline="always")
def locate(wx, wy, wz, t_edges, n_phi, frame, z_min, sub, ranges):
    """``(bin, theta_o, phi_o)``; bin -1 where ``cos(theta_o) < z_min`` (the cosine fallback). The theta bin
    is ``searchsorted(t_edges, theta, "right") - 1`` clipped to the bins, found from a guess for the
    uniform part of the edges; ``phi_o`` is 0 for isotropic tables, in ``[0, 2 pi)`` for the whole circle and
    folded into ``[0, pi / 2]`` (``atan2(|y|, |x|)``) for mirrored tables (``FRAME_*``). A bin that was split
    (``sub[b] >= 0``: first child ``sub[b] >> 1``, halved dimension ``sub[b] & 1``, 0 theta, 1 phi) is
    descended to the sub-bin holding ``(theta_o, phi_o)``: the lower half is ``[lo, mid)``."""
    s = math.sqrt(wx * wx + wy * wy)
    theta = math.atan2(s, wz)
    phi = 0.0
    span = TWO_PI
    if frame == FRAME_MIRROR:
        phi = math.atan2(abs(wy), abs(wx))
        span = HALF_PI
    elif frame == FRAME_FULL:
        phi = math.atan2(wy, wx)
        if phi < 0.0:
            phi += TWO_PI
    if not (wz >= z_min) or not math.isfinite(theta):
        return -1, theta, phi
    last = t_edges.shape[0] - 2  # the last bin
    it = 0
    if last >= 1:
        it = min(max(int(theta / (t_edges[2] - t_edges[1]) + 0.5), 0), last)
    while it < last and t_edges[it + 1] <= theta:
        it += 1
    while it > 0 and t_edges[it] > theta:
        it -= 1
    b = it
    if frame != FRAME_ISO:
        ip = min(max(int(phi * (n_phi / span)), 0), n_phi - 1)
        b = it * n_phi + ip
    while sub[b] >= 0:
        dim = sub[b] & 1
        v = phi if dim == 1 else theta
        b = (sub[b] >> 1) + (1 if v >= 0.5 * (ranges[b, 2 * dim] + ranges[b, 2 * dim + 1]) else 0)
    return b, theta, phi


@njit(nogil=True, cache=True, inline="always")
def clenshaw(coef, off, stride, m, x):
    """``sum_k coef[off + k stride] T_k(x)`` for ``k < m`` (Clenshaw's recurrence)."""
    b1 = 0.0
    b2 = 0.0
    for k in range(m - 1, 0, -1):
        b1, b2 = 2.0 * x * b1 - b2 + coef[off + k * stride], b1
    return x * b1 - b2 + coef[off]


@njit(nogil=True, cache=True, inline="always")
def table_value(meta, coef, b, theta, phi, wp):
    """The Chebyshev interpolant of bin ``b`` at ``(theta, phi)`` from its coefficients (``meta`` as in
    :func:`core.quadtree.normalizer_values`, coefficients at ``offset + k_theta * m_phi + k_phi``, see
    :func:`chebyshev_coefficients`); ``wp`` is scratch for ``T_k(x_phi)``."""
    off = int(meta[b, 0])
    mt = int(meta[b, 1])
    mp = int(meta[b, 2])
    xt = (2.0 * theta - meta[b, 3] - meta[b, 4]) / (meta[b, 4] - meta[b, 3])
    if mp <= 1:
        return clenshaw(coef, off, 1, mt, xt)
    xp = (2.0 * phi - meta[b, 5] - meta[b, 6]) / (meta[b, 6] - meta[b, 5])
    wp[0] = 1.0
    if mp > 1:
        wp[1] = xp
    for q in range(2, mp):
        wp[q] = 2.0 * xp * wp[q - 1] - wp[q - 2]
    b1 = 0.0
    b2 = 0.0
    for k in range(mt - 1, -1, -1):
        ck = 0.0
        for q in range(mp):
            ck += coef[off + k * mp + q] * wp[q]
        if k == 0:
            return xt * b1 - b2 + ck
        b1, b2 = 2.0 * xt * b1 - b2 + ck, b1
    return 0.0


@njit(nogil=True, cache=True, inline="always")
def bin_values(meta, coef, c_meta, c_coef, b, theta, phi, wp):
    """``(I(wo), c(wo) before its floor)`` of bin ``b``: one recurrence when both tables have the same
    number of theta coefficients and no phi dependence (isotropic bins)."""
    mt = int(meta[b, 1])
    if int(meta[b, 2]) <= 1 and int(c_meta[b, 2]) <= 1 and int(c_meta[b, 1]) == mt:
        x = (2.0 * theta - meta[b, 3] - meta[b, 4]) / (meta[b, 4] - meta[b, 3])
        off = int(meta[b, 0])
        coff = int(c_meta[b, 0])
        b1 = 0.0
        b2 = 0.0
        e1 = 0.0
        e2 = 0.0
        for k in range(mt - 1, 0, -1):
            b1, b2 = 2.0 * x * b1 - b2 + coef[off + k], b1
            e1, e2 = 2.0 * x * e1 - e2 + c_coef[coff + k], e1
        return x * b1 - b2 + coef[off], x * e1 - e2 + c_coef[coff]
    return table_value(meta, coef, b, theta, phi, wp), table_value(c_meta, c_coef, b, theta, phi, wp)


@njit(nogil=True, cache=True, inline="always")
def row_setup(wx, wy, wz, tab, wp):
    """``(bin, I(wo), c(wo), cos, sin)`` of a row: bin -1 (cosine fallback) beyond the last bin or where
    ``I(wo) <= 0``, -2 - bin where the row's bin is not built yet; ``cos, sin`` rotate the isotropic tree's
    frame (``phi_o = 0``) to the row's, and for a mirrored table they are the signs of the row's ``x`` and
    ``y`` (the mirrors from the tree's quadrant to the row's)."""
    (t_edges, n_phi, frame, z_min, sub, ranges, node_off, word_off, proj_of, unit_of,
     mass, bits, cum, meta, coef, c_meta, c_coef, c_floor, m_max) = tab  # fmt: skip
    b, theta, phi = locate(wx, wy, wz, t_edges, n_phi, frame, z_min, sub, ranges)
    if b < 0:
        return -1, 0.0, 1.0, 1.0, 0.0
    if node_off[b] < 0:
        return -2 - b, 0.0, 1.0, 1.0, 0.0
    norm, scale = bin_values(meta, coef, c_meta, c_coef, b, theta, phi, wp)
    if not (norm > 0.0):
        return -1, 0.0, 1.0, 1.0, 0.0
    scale = max(scale, c_floor[b])
    cr = 1.0
    sr = 0.0
    if frame == FRAME_ISO:
        s = math.sqrt(wx * wx + wy * wy)
        if s > 0.0:
            cr = wx / s
            sr = wy / s
    elif frame == FRAME_MIRROR:
        cr = -1.0 if wx < 0.0 else 1.0
        sr = -1.0 if wy < 0.0 else 1.0
    return b, norm, scale, cr, sr


@njit(nogil=True, cache=True)
def setup_rows(wo, tab):
    """``bins, I(wo), c(wo)`` per row (the Python side's view of :func:`row_setup`)."""
    n = wo.shape[0]
    bins = np.empty(n, dtype=np.int64)
    norm = np.empty(n)
    scale = np.empty(n)
    wp = np.empty(tab[18])
    for i in range(n):
        b, v, c, _, _ = row_setup(wo[i, 0], wo[i, 1], wo[i, 2], tab, wp)
        bins[i] = b
        norm[i] = v
        scale[i] = c
    return bins, norm, scale


@njit(nogil=True, cache=True)
def locate_rows(wo, t_edges, n_phi, frame, z_min, sub, ranges):
    n = wo.shape[0]
    bins = np.empty(n, dtype=np.int64)
    theta = np.empty(n)
    phi = np.empty(n)
    for i in range(n):
        bins[i], theta[i], phi[i] = locate(
            wo[i, 0], wo[i, 1], wo[i, 2], t_edges, n_phi, frame, z_min, sub, ranges
        )
    return bins, theta, phi


@njit(nogil=True, cache=True)
def bins_present(wo, t_edges, n_phi, frame, z_min, sub, ranges):
    """Which bins the rows fall in (a pass before the tables are built: no sort, no bin array)."""
    out = np.zeros(sub.shape[0], dtype=np.bool_)
    for i in range(wo.shape[0]):
        b, _, _ = locate(wo[i, 0], wo[i, 1], wo[i, 2], t_edges, n_phi, frame, z_min, sub, ranges)
        if b >= 0:
            out[b] = True
    return out


@njit(nogil=True, cache=True)
def values_rows(meta, coef, bins, theta, phi, m_max):
    """Chebyshev table values per row (0 where ``bins < 0``)."""
    out = np.zeros(bins.shape[0])
    wp = np.empty(m_max)
    for i in range(bins.shape[0]):
        if bins[i] >= 0:
            out[i] = table_value(meta, coef, bins[i], theta[i], phi[i], wp)
    return out


# ------------------------------------------------------------------------------------------ projections


@njit(nogil=True, cache=True, inline="always")
def project(X, Y, proj):
    """Direction ``(x, y, z)`` of a disk point and the factor ``cos(theta_i) J`` (0 outside the disk):
    ``proj`` 0 equidistant, 1 orthographic (``core.quadtree.PROJECTIONS``)."""
    r2 = X * X + Y * Y
    if not (r2 < 1.0):
        return 0.0, 0.0, 1.0, 0.0
    if proj == 1:
        return X, Y, math.sqrt(max(0.0, 1.0 - r2)), 1.0
    rho = math.sqrt(r2)
    theta = HALF_PI * min(rho, 1.0)
    scale = math.sin(theta) / rho if rho > 0.0 else HALF_PI
    z = math.cos(theta)
    return X * scale, Y * scale, z, z * HALF_PI * scale


# ----------------------------------------------------------------------------------------- the samplers


@njit(nogil=True, cache=True, inline="always")
def trial_direction(X, Y, proj, cr, sr, frame):
    """World direction of disk point ``(X, Y)`` and the factor ``cos J`` (the eval stays in the callers:
    a kernel passed on between compiled functions would keep numba from caching them); ``cr, sr`` from
    :func:`row_setup` (a rotation, or the mirrors' signs)."""
    ix, iy, iz, factor = project(X, Y, proj)
    if frame == FRAME_ISO:
        ix, iy = cr * ix - sr * iy, sr * ix + cr * iy
    elif frame == FRAME_MIRROR:
        ix, iy = cr * ix, sr * iy
    return ix, iy, iz, factor


# ------------------------------------------------------------------------------- per-model specialization

TEMPLATE = '''
import math

import numpy as np
from numba import njit, prange

from core.quadtree_kernels import (
    CHUNK,
    INV_PI,
    LUM_B,
    LUM_G,
    LUM_R,
    MAX_TRIALS,
    STACK,
    TWO_PI,
    child_square,
    descend,
    first_child,
    leaf_box,
    row_setup,
    trial_direction,
)
from core.rng import next_u01, stream


@njit(nogil=True, cache=True, inline="always")
def luminance_f(ix, iy, iz, wx, wy, wz, p):
    """The luminance of ``f_r(wo, wi)``."""
    r, g, b = _eval((ix, iy, iz), (wx, wy, wz), p)
    return LUM_R * r + LUM_G * g + LUM_B * b


@njit(nogil=True, cache=True, inline="always")
def trial(X, Y, proj, cr, sr, frame, wx, wy, wz, p):
    """A trial at disk point ``(X, Y)``: its direction ``wi``, the luminance ``f`` there and ``g = f cos J``."""
    ix, iy, iz, factor = trial_direction(X, Y, proj, cr, sr, frame)
    f = luminance_f(ix, iy, iz, wx, wy, wz, p) if factor > 0.0 else 0.0
    return ix, iy, iz, f, f * factor


@njit(nogil=True, cache=True)
def sample_range(lo, hi, wo, p, seed, tab, wi_out, pdf_out, trials_out, missing):
    """One sample per row ``lo <= i < hi``, sample ``i`` from stream ``(seed, i)``. Returns
    ``(violations, skipped)``: rows whose bin is not built yet are skipped and their bins flagged in
    ``missing`` (the caller builds them and runs again)."""
    (t_edges, n_phi, frame, z_min, sub, ranges, node_off, word_off, proj_of, unit_of,
     mass, bits, cum, meta, coef, c_meta, c_coef, c_floor, m_max) = tab  # fmt: skip
    wp = np.empty(m_max)
    viol = 0
    skipped = 0
    for i in range(lo, hi):
        wx, wy, wz = wo[i, 0], wo[i, 1], wo[i, 2]
        state = stream(seed, i)
        b, norm, scale, cr, sr = row_setup(wx, wy, wz, tab, wp)
        if b <= -2:
            missing[-2 - b] = True
            skipped += 1
            continue
        if b < 0:  # the cosine density
            state, u1 = next_u01(state)
            state, u2 = next_u01(state)
            r = math.sqrt(u1)
            ph = TWO_PI * u2
            z = math.sqrt(max(0.0, 1.0 - u1))
            wi_out[i, 0] = r * math.cos(ph)
            wi_out[i, 1] = r * math.sin(ph)
            wi_out[i, 2] = z
            pdf_out[i] = z * INV_PI if z > 0.0 else 0.0
            trials_out[i] = 1
            continue
        moff = node_off[b]
        woff = word_off[b]
        proj = proj_of[b]
        unit = unit_of[b]
        trials = 0
        while True:
            state, k, x0, y0, size = descend(state, mass, moff, bits, cum, woff)
            state, a = next_u01(state)
            state, c = next_u01(state)
            state, u3 = next_u01(state)
            trials += 1
            c0, d0, c1, d1, area, m = leaf_box(mass, moff, k, unit, x0, y0, size)
            X = c0 + (c1 - c0) * a
            Y = d0 + (d1 - d0) * c
            ix, iy, iz, f, g = trial(X, Y, proj, cr, sr, frame, wx, wy, wz, p)
            bound = m * scale
            if g > bound:
                viol += 1
            accept = u3 * bound < g
            if accept or trials >= MAX_TRIALS:
                if not accept:
                    viol += 1
                wi_out[i, 0] = ix
                wi_out[i, 1] = iy
                wi_out[i, 2] = iz
                pdf_out[i] = f * iz / norm if iz > 0.0 else 0.0
                trials_out[i] = trials
                break
    return viol, skipped


@njit(nogil=True, cache=True)
def sample_rows(wo, p, seed, tab, wi_out, pdf_out, trials_out, missing):
    """:func:`sample_range` over every row (one thread)."""
    return sample_range(0, wo.shape[0], wo, p, seed, tab, wi_out, pdf_out, trials_out, missing)


@njit(nogil=True, cache=True, parallel=True)
def sample_rows_parallel(wo, p, seed, tab, wi_out, pdf_out, trials_out, missing):
    """:func:`sample_range` over chunks of rows on numba's threads (the same samples as one thread)."""
    n = wo.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    viol = 0
    skipped = 0
    for c in prange(chunks):
        lo = c * CHUNK
        hi = min(n, lo + CHUNK)
        v, s = sample_range(lo, hi, wo, p, seed, tab, wi_out, pdf_out, trials_out, missing)
        viol += v
        skipped += s
    return viol, skipped


@njit(nogil=True, cache=True)
def sample_batch(wo, p, seed, n, tab, wi_out, pdf_out):
    """``n`` samples for one ``wo (3,)`` by the seed's batch variant: each round splits the pending count
    from the root among the children by systematic rounding (one uniform per node, ``E[n_c] = k V_c / V``,
    the counts sum to ``k``), runs the leaves' trials, and the rejected ones make the next round (round
    ``r`` draws from stream ``(seed, r)``). Accepted samples are written in order; returns
    ``(filled, trials, violations)``. The caller checks that the row's bin is not the fallback."""
    (t_edges, n_phi, frame, z_min, sub, ranges, node_off, word_off, proj_of, unit_of,
     mass, bits, cum, meta, coef, c_meta, c_coef, c_floor, m_max) = tab  # fmt: skip
    wp = np.empty(m_max)
    wx, wy, wz = wo[0], wo[1], wo[2]
    b, norm, scale, cr, sr = row_setup(wx, wy, wz, tab, wp)
    if b < 0:
        return 0, 0, 0
    moff = node_off[b]
    woff = word_off[b]
    proj = proj_of[b]
    unit = unit_of[b]
    s_node = np.empty(STACK, dtype=np.int64)
    s_cnt = np.empty(STACK, dtype=np.int64)
    s_sq = np.empty((STACK, 3))
    filled = 0
    trials = 0
    viol = 0
    rnd = 0
    while filled < n and rnd < MAX_TRIALS:
        state = stream(seed, rnd)
        rnd += 1
        s_node[0] = 0
        s_cnt[0] = n - filled
        s_sq[0, 0] = -1.0
        s_sq[0, 1] = -1.0
        s_sq[0, 2] = 2.0
        sp = 1
        while sp > 0:
            sp -= 1
            k = s_node[sp]
            cnt = s_cnt[sp]
            x0, y0, size = s_sq[sp, 0], s_sq[sp, 1], s_sq[sp, 2]
            ch = first_child(bits, cum, woff, k)
            if ch >= 0:
                tot = 0.0
                last = -1
                for j in range(4):
                    tot += float(mass[moff + ch + j])
                    if mass[moff + ch + j] > 0:
                        last = j
                state, u = next_u01(state)
                cum_v = 0.0
                prev = 0.0
                assigned = 0
                for j in range(4):
                    v = mass[moff + ch + j]
                    if v == 0:
                        continue
                    cum_v += float(v)
                    if j == last:
                        nj = cnt - assigned
                    else:
                        nxt = math.floor(cnt * (cum_v / tot) + u)
                        nj = int(nxt - prev)
                        prev = nxt
                    if nj > 0:
                        cx, cy, ch_size = child_square(x0, y0, size, j)
                        s_node[sp] = ch + j
                        s_cnt[sp] = nj
                        s_sq[sp, 0] = cx
                        s_sq[sp, 1] = cy
                        s_sq[sp, 2] = ch_size
                        sp += 1
                        assigned += nj
            else:
                c0, d0, c1, d1, area, m = leaf_box(mass, moff, k, unit, x0, y0, size)
                bound = m * scale
                for _ in range(cnt):
                    state, a = next_u01(state)
                    state, c = next_u01(state)
                    state, u3 = next_u01(state)
                    trials += 1
                    X = c0 + (c1 - c0) * a
                    Y = d0 + (d1 - d0) * c
                    ix, iy, iz, f, g = trial(X, Y, proj, cr, sr, frame, wx, wy, wz, p)
                    if g > bound:
                        viol += 1
                    if u3 * bound < g and filled < n:
                        wi_out[filled, 0] = ix
                        wi_out[filled, 1] = iy
                        wi_out[filled, 2] = iz
                        pdf_out[filled] = f * iz / norm if iz > 0.0 else 0.0
                        filled += 1
    return filled, trials, viol


@njit(nogil=True, cache=True)
def pdf_rows(wo, wi, p, tab, out, missing):
    """Density per unit solid angle of the samples: ``f cos / I(wo)`` (``cos / pi`` for the fallback rows),
    with the same arithmetic as the samplers, so it equals the pdf returned with a sample bit for bit.
    Returns the number of rows skipped because their bin is not built yet (flagged in ``missing``)."""
    wp = np.empty(tab[18])
    skipped = 0
    for i in range(wo.shape[0]):
        wx, wy, wz = wo[i, 0], wo[i, 1], wo[i, 2]
        iz = wi[i, 2]
        b, norm, _, _, _ = row_setup(wx, wy, wz, tab, wp)
        if b <= -2:
            missing[-2 - b] = True
            skipped += 1
        elif not (iz > 0.0):
            out[i] = 0.0
        elif b < 0:
            out[i] = iz * INV_PI
        else:
            out[i] = luminance_f(wi[i, 0], wi[i, 1], iz, wx, wy, wz, p) * iz / norm
    return skipped
'''
"""The fused per-sample loops: the source of the generated module per model kernel
(:func:`core.specialize.specialize` binds ``_eval`` to ``model.eval`` as a global, so numba caches the module
on disk). A kernel passed as an argument instead would keep numba from caching the loops."""

_GENERIC: dict[tuple[int, int], Any] = {}


def specialized(template: str, kernel: Any) -> Any:
    """The module of ``template`` with ``_eval`` bound to a model's ``eval`` kernel: its generated,
    disk-cached module (:func:`core.specialize.specialize`), or, for a kernel that cannot be imported by name
    (a closure), the same source compiled with the kernel in its namespace (once per process, not cached)."""
    from core.specialize import specialize

    mod = specialize(template, _eval=kernel)
    if mod is not None:
        return mod
    key = (id(template), id(kernel))
    if key not in _GENERIC:
        namespace: dict[str, Any] = {"_eval": kernel, "__name__": f"{__name__}._generic_{key[1]:x}"}
        exec(
            compile(template.replace("cache=True", "cache=False"), f"<{__name__} generic>", "exec"), namespace
        )
        _GENERIC[key] = SimpleNamespace(**namespace, kernel=kernel)
    return _GENERIC[key]


def model_kernels(kernel: Any) -> Any:
    """The fused entry points ``sample_rows, sample_batch, pdf_rows`` for a model's ``eval`` kernel."""
    return specialized(TEMPLATE, kernel)


def chebyshev_coefficients(vals: np.ndarray, mt: int, mp: int) -> np.ndarray:
    """Coefficients ``c[k_theta, k_phi]`` (flattened) of the tensor Chebyshev series through values at the
    Chebyshev points of the first kind (``x_j = cos((2j + 1) pi / (2m))``, the order of
    :func:`core.quadtree.normalizer_values`): the same interpolant, evaluated by Clenshaw's recurrence."""
    v = np.asarray(vals, dtype=np.float64).reshape(mt, mp)

    def matrix(m: int) -> np.ndarray:
        j = np.arange(m)
        c = (2.0 / m) * np.cos(np.outer(np.arange(m), (2 * j + 1) * np.pi / (2 * m)))
        c[0] *= 0.5
        return c

    return np.ascontiguousarray((matrix(mt) @ v @ matrix(mp).T).ravel())
