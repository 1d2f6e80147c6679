"""The adaptive sampler's draws and densities: one compiled loop over a batch of outgoing directions.

Two modes share the table (:class:`~core.sampling.adaptive.table.AdaptiveTable`):

``exact`` (the seed's)
    The node whose cell holds ``wo``; a leaf chosen by its envelope mass ``V_L = area_L M_L`` (descending by
    the children's masses); a uniform point of the leaf, accepted with probability ``g / (c M_L)``,
    ``c = I(wo)`` the interpolated normalizer; on rejection the draw restarts from the root. The accepted
    point has density exactly ``g / I`` on the square: ``pdf = f cos / I(wo)`` per unit solid angle, and the
    weight ``f cos / pdf = I(wo)`` is the same for every sample (the zero-variance property). Every trial with
    ``g > c M_L`` is counted (a bound that did not hold); the tests assert there are none.

``warp`` (rejection-free)
    The two nodes around ``wo``'s polar angle (four with the two around its azimuth), one chosen with its
    linear weight; a leaf chosen by the bilinear density's masses; the point warped inside the leaf by the
    bilinear density of its corners (one square root per axis). The density is the weighted sum of the
    chosen nodes' densities at the drawn direction, ``pdf = sum_t w_t q_t`` (Mitsuba's conditional warps
    blend the same way): exact for the samples it makes, with no bound and one evaluation of ``f``.

Every draw returns what it computed: the direction, its pdf, and ``f`` (RGB) there.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from core.dispatch import eval_model
from core.rng import next_u01, stream
from core.sampling.adaptive.layout import FULL, ISOTROPIC, MIRROR, TWO_PI, locate, normalizer_at
from core.sampling.adaptive.maps import INV_PI, ORTHOGRAPHIC, PI, direction_to_square, square_to_direction
from core.sampling.adaptive.target import luminance3

EXACT = 0
WARP = 1
MODES = ("exact", "warp")

MAX_TRIALS = 100_000
"""An exact draw gives up after this many trials and takes the cosine density's sample (counted: never
reached with an envelope that accepts ``>= 1 / n_max``)."""


@njit(inline="always", nogil=True, cache=True)
def _frame(symmetry, wx, wy, wz):
    """``(theta, phi, cos, sin, sx, sy)``: polar angle, the azimuth the trees see (folded into the quadrant
    when mirror-symmetric), the rotation to the tree frame and the mirror signs."""
    rho = math.sqrt(wx * wx + wy * wy)
    theta = math.atan2(rho, wz)
    sx = 1.0
    sy = 1.0
    if symmetry == MIRROR:
        if wx < 0.0:
            sx = -1.0
        if wy < 0.0:
            sy = -1.0
        ax = abs(wx)
        ay = abs(wy)
        phi = math.atan2(ay, ax)
        if rho > 0.0:
            return theta, phi, ax / rho, ay / rho, sx, sy
        return theta, 0.0, 1.0, 0.0, sx, sy
    phi = math.atan2(wy, wx)
    if phi < 0.0:
        phi += TWO_PI
    if rho > 0.0:
        return theta, phi, wx / rho, wy / rho, sx, sy
    return theta, 0.0, 1.0, 0.0, sx, sy


@njit(inline="always", nogil=True, cache=True)
def _to_local(x, y, z, c, s, sx, sy):
    return sx * (c * x - s * y), sy * (s * x + c * y), z


@njit(inline="always", nogil=True, cache=True)
def _to_tree(wx, wy, wz, c, s, sx, sy):
    x = sx * wx
    y = sy * wy
    return c * x + s * y, -s * x + c * y, wz


@njit(inline="always", nogil=True, cache=True)
def _phi_node(table, phi):
    """The exact mode's azimuth node: the cell holding ``phi``."""
    j = table.phis.shape[0]
    if table.symmetry == ISOTROPIC or j == 1:
        return 0
    if table.symmetry == FULL:
        return int(math.floor(phi / TWO_PI * j + 0.5)) % j
    return locate(table.phi_edges, phi)


@njit(inline="always", nogil=True, cache=True)
def _sample_linear(u, a, b):
    """``t`` in ``[0, 1]`` with density proportional to ``(1 - t) a + t b`` (``a, b >= 0``)."""
    if a + b <= 0.0:
        return u
    return min(u * (a + b) / (a + math.sqrt((1.0 - u) * a * a + u * b * b)), 1.0)


@njit(inline="always", nogil=True, cache=True)
def _descend(masses, child, root, u):
    """A leaf chosen by ``masses`` from ``root``: ``(leaf, x0, y0, h)``."""
    node = root
    x0 = 0.0
    y0 = 0.0
    h = 1.0
    while True:
        c = child[node]
        if c < 0:
            return -1 - c, x0, y0, h
        m0 = masses[c]
        m1 = masses[c + 1]
        m2 = masses[c + 2]
        m3 = masses[c + 3]
        t = u * (m0 + m1 + m2 + m3)
        if t < m0:
            q = 0
            u = t / m0
        elif t < m0 + m1:
            q = 1
            u = (t - m0) / m1
        elif t < m0 + m1 + m2:
            q = 2
            u = (t - m0 - m1) / m2
        else:
            q = 3
            u = min((t - m0 - m1 - m2) / m3, 0.9999999999999999) if m3 > 0.0 else 0.5
        h *= 0.5
        x0 += h * (q % 2)
        y0 += h * (q // 2)
        node = c + q


@njit(inline="always", nogil=True, cache=True)
def _warp_density(table, t, a, b):
    """The rejection-free density of tree ``t`` at square point ``(a, b)`` (per unit square area)."""
    node = table.root[t]
    x0 = 0.0
    y0 = 0.0
    h = 1.0
    prob = 1.0
    while True:
        c = table.child[node]
        if c < 0:
            break
        h *= 0.5
        qi = 1 if a >= x0 + h else 0
        qj = 1 if b >= y0 + h else 0
        q = qj * 2 + qi
        s = table.mass[c] + table.mass[c + 1] + table.mass[c + 2] + table.mass[c + 3]
        prob *= table.mass[c + q] / s
        x0 += h * qi
        y0 += h * qj
        node = c + q
    leaf = -1 - c
    tx = min(max((a - x0) / h, 0.0), 1.0)
    ty = min(max((b - y0) / h, 0.0), 1.0)
    v0 = table.corners[leaf, 0]
    v1 = table.corners[leaf, 1]
    v2 = table.corners[leaf, 2]
    v3 = table.corners[leaf, 3]
    mean = 0.25 * (v0 + v1 + v2 + v3)
    if mean <= 0.0:
        return 0.0
    bil = (1.0 - tx) * (1.0 - ty) * v0 + tx * (1.0 - ty) * v1 + (1.0 - tx) * ty * v2 + tx * ty * v3
    return prob * bil / (mean * h * h)


@njit(inline="always", nogil=True, cache=True)
def _brackets(table, theta, phi):
    """The rejection-free mode's nodes around ``(theta, phi)``: up to four trees and their weights."""
    k = table.thetas.shape[0]
    j = table.phis.shape[0]
    if theta >= table.thetas[k - 1]:
        k0 = k - 1
        k1 = k - 1
        wt = 0.0
    else:
        k0 = locate(table.thetas, theta)
        k1 = k0 + 1
        wt = (theta - table.thetas[k0]) / (table.thetas[k1] - table.thetas[k0])
        wt = min(max(wt, 0.0), 1.0)
    if table.symmetry == ISOTROPIC or j == 1:
        j0 = 0
        j1 = 0
        wp = 0.0
    elif table.symmetry == MIRROR:
        j0 = locate(table.phis, phi)
        j1 = j0 + 1
        wp = min(max((phi - table.phis[j0]) / (table.phis[j1] - table.phis[j0]), 0.0), 1.0)
    else:
        x = phi / TWO_PI * j
        fl = math.floor(x)
        j0 = int(fl) % j
        j1 = (j0 + 1) % j
        wp = x - fl
    trees = (k0 * j + j0, k1 * j + j0, k0 * j + j1, k1 * j + j1)
    weights = ((1.0 - wt) * (1.0 - wp), wt * (1.0 - wp), (1.0 - wt) * wp, wt * wp)
    return trees, weights


@njit(inline="always", nogil=True, cache=True)
def _warp_pdf_tree(table, trees, weights, x, y, z):
    """The rejection-free mode's pdf (per unit solid angle) of tree-frame direction ``(x, y, z)``."""
    if z <= 0.0:
        return 0.0
    pdf = 0.0
    for i in range(4):
        w = weights[i]
        if w <= 0.0:
            continue
        t = trees[i]
        a, b, jac = direction_to_square(x, y, z, table.projection[t])
        pdf += w * _warp_density(table, t, a, b) * INV_PI * jac
    return pdf


@njit(inline="always", nogil=True, cache=True)
def _g_scale(projection, z, jac):
    """``g / (pi f_lum)``: ``cos / (dA/d(omega))`` (1 on the orthographic disk)."""
    if projection == ORTHOGRAPHIC:
        return 1.0
    return z / jac if jac > 0.0 else 0.0


@njit(inline="always", nogil=True, cache=True)
def _cosine(state):
    state, u1 = next_u01(state)
    state, u2 = next_u01(state)
    r = math.sqrt(u1)
    ph = TWO_PI * u2
    return state, r * math.cos(ph), r * math.sin(ph), math.sqrt(max(0.0, 1.0 - u1))


@njit(inline="always", nogil=True, cache=True)
def _sample_row(table, mid, p, mode, wx, wy, wz, state, out_wi, out_f, i):
    """One draw for row ``i``; writes ``out_wi[i]``, ``out_f[i]``; returns ``(pdf, trials, violations)``."""
    wo = (wx, wy, wz)
    theta, phi, c, s, sx, sy = _frame(table.symmetry, wx, wy, wz)
    if mode == WARP and wz > 0.0:
        trees, weights = _brackets(table, theta, phi)
        state, u = next_u01(state)
        pick = 3
        acc = 0.0
        for q in range(4):
            acc += weights[q]
            if u < acc:
                pick = q
                break
        while weights[pick] <= 0.0:
            pick -= 1
        t = trees[pick]
        state, u = next_u01(state)
        leaf, x0, y0, h = _descend(table.mass, table.child, table.root[t], u)
        v0 = table.corners[leaf, 0]
        v1 = table.corners[leaf, 1]
        v2 = table.corners[leaf, 2]
        v3 = table.corners[leaf, 3]
        state, u2 = next_u01(state)
        state, u3 = next_u01(state)
        tx = _sample_linear(u2, v0 + v2, v1 + v3)
        ty = _sample_linear(u3, (1.0 - tx) * v0 + tx * v1, (1.0 - tx) * v2 + tx * v3)
        x, y, z, _ = square_to_direction(x0 + tx * h, y0 + ty * h, table.projection[t])
        lx, ly, lz = _to_local(x, y, z, c, s, sx, sy)
        r, g, b = eval_model(mid, (lx, ly, lz), wo, p)
        out_wi[i, 0] = lx
        out_wi[i, 1] = ly
        out_wi[i, 2] = lz
        out_f[i, 0] = r
        out_f[i, 1] = g
        out_f[i, 2] = b
        tx_, ty_, tz_ = _to_tree(lx, ly, lz, c, s, sx, sy)
        return _warp_pdf_tree(table, trees, weights, tx_, ty_, tz_), 1, 0
    norm = 0.0
    if mode == EXACT and wz > 0.0 and theta <= table.theta_max:
        norm = normalizer_at(table.symmetry, table.norm_s, table.norm, table.norm_log, wz, phi)
    if norm > 0.0:
        k = locate(table.theta_edges, theta)
        t = k * table.phis.shape[0] + _phi_node(table, phi)
        proj = table.projection[t]
        violations = 0
        for trial in range(1, MAX_TRIALS + 1):
            state, u = next_u01(state)
            leaf, x0, y0, h = _descend(table.envelope, table.child, table.root[t], u)
            state, u2 = next_u01(state)
            state, u3 = next_u01(state)
            state, u4 = next_u01(state)
            x, y, z, jac = square_to_direction(x0 + u2 * h, y0 + u3 * h, proj)
            lx, ly, lz = _to_local(x, y, z, c, s, sx, sy)
            r, g, b = eval_model(mid, (lx, ly, lz), wo, p)
            lum = luminance3(r, g, b)
            if not lum > 0.0 or z <= 0.0:
                continue
            gn = PI * lum * _g_scale(proj, z, jac) / norm
            bound = table.bound[leaf]
            if gn > bound:
                violations += 1
            if u4 * bound < gn:
                out_wi[i, 0] = lx
                out_wi[i, 1] = ly
                out_wi[i, 2] = lz
                out_f[i, 0] = r
                out_f[i, 1] = g
                out_f[i, 2] = b
                return lum * lz / norm, trial, violations
        trials = MAX_TRIALS + 1
    else:
        trials = 1
        violations = 0
    # the cosine density: beyond the last node, at or below the horizon, or where I(wo) = 0
    state, x, y, z = _cosine(state)
    out_wi[i, 0] = x
    out_wi[i, 1] = y
    out_wi[i, 2] = z
    r, g, b = eval_model(mid, (x, y, z), wo, p)
    out_f[i, 0] = r
    out_f[i, 1] = g
    out_f[i, 2] = b
    return z * INV_PI, trials, violations


@njit(nogil=True, cache=True)
def sample_rows(table, mid, p, mode, wo, seed, out_wi, out_pdf, out_f, out_trials):
    """One draw per row of ``wo (n, 3)`` (row ``i`` from its own random stream); returns the number of
    trials that found ``g`` above its bound (must be 0)."""
    violations = 0
    for i in range(wo.shape[0]):
        state = stream(seed, i)
        pdf, trials, v = _sample_row(table, mid, p, mode, wo[i, 0], wo[i, 1], wo[i, 2], state, out_wi, out_f, i)
        out_pdf[i] = pdf
        out_trials[i] = trials
        violations += v
    return violations


@njit(nogil=True, cache=True, parallel=True)
def sample_rows_parallel(table, mid, p, mode, wo, seed, out_wi, out_pdf, out_f, out_trials):
    """:func:`sample_rows` on numba's threads (the same samples)."""
    n = wo.shape[0]
    viol = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        state = stream(seed, i)
        pdf, trials, v = _sample_row(table, mid, p, mode, wo[i, 0], wo[i, 1], wo[i, 2], state, out_wi, out_f, i)
        out_pdf[i] = pdf
        out_trials[i] = trials
        viol[i] = v
    return viol.sum()


@njit(inline="always", nogil=True, cache=True)
def _pdf_row(table, mid, p, mode, wo, wi, out_f, i):
    """The pdf of ``wi`` for ``wo`` (and ``f`` there, in ``out_f[i]``)."""
    wx, wy, wz = wo
    r, g, b = eval_model(mid, wi, wo, p)
    out_f[i, 0] = r
    out_f[i, 1] = g
    out_f[i, 2] = b
    theta, phi, c, s, sx, sy = _frame(table.symmetry, wx, wy, wz)
    if mode == WARP and wz > 0.0:
        trees, weights = _brackets(table, theta, phi)
        x, y, z = _to_tree(wi[0], wi[1], wi[2], c, s, sx, sy)
        return _warp_pdf_tree(table, trees, weights, x, y, z)
    norm = 0.0
    if mode == EXACT and wz > 0.0 and theta <= table.theta_max:
        norm = normalizer_at(table.symmetry, table.norm_s, table.norm, table.norm_log, wz, phi)
    if norm > 0.0:
        if wi[2] <= 0.0:
            return 0.0
        lum = luminance3(r, g, b)
        return max(lum, 0.0) * wi[2] / norm
    return wi[2] * INV_PI if wi[2] > 0.0 else 0.0


@njit(nogil=True, cache=True)
def pdf_rows(table, mid, p, mode, wo, wi, out_pdf, out_f):
    """``pdf(wo[i], wi[i])`` per unit solid angle, and ``f`` there."""
    for i in range(wo.shape[0]):
        out_pdf[i] = _pdf_row(table, mid, p, mode, (wo[i, 0], wo[i, 1], wo[i, 2]),
                              (wi[i, 0], wi[i, 1], wi[i, 2]), out_f, i)  # fmt: skip


@njit(nogil=True, cache=True)
def normalizer_rows(table, wo, out):
    """The exact mode's ``I(wo)`` per row (0 where it draws the cosine density)."""
    for i in range(wo.shape[0]):
        theta, phi, _, _, _, _ = _frame(table.symmetry, wo[i, 0], wo[i, 1], wo[i, 2])
        if wo[i, 2] > 0.0 and theta <= table.theta_max:
            out[i] = max(normalizer_at(table.symmetry, table.norm_s, table.norm, table.norm_log, wo[i, 2], phi), 0.0)
        else:
            out[i] = 0.0


@njit(nogil=True, cache=True)
def acceptance_rows(table, wo, out):
    """The exact mode's acceptance ``I(wo) / (c V)`` per row: ``1 / V`` of the tree serving it (``c = I``)."""
    for i in range(wo.shape[0]):
        theta, phi, _, _, _, _ = _frame(table.symmetry, wo[i, 0], wo[i, 1], wo[i, 2])
        k = locate(table.theta_edges, theta)
        t = k * table.phis.shape[0] + _phi_node(table, phi)
        v = table.envelope[table.root[t]]
        out[i] = 1.0 / v if v > 0.0 else 0.0
