"""The adaptive sampler's draws and densities: one compiled loop over a batch of outgoing directions.

Both modes use the tree of the node whose cell holds ``wo`` (:class:`~core.sampling.adaptive.table.
AdaptiveTable`):

``exact`` (the seed's)
    A leaf chosen by its envelope mass ``V_L = K_L q_L`` (``q_L`` its mass under the rejection-free density
    ``q``, ``K_L`` a bound of ``g / (c q)`` on it; descending by the children's masses); a point of the leaf
    drawn from ``q`` (the rejection-free mode's warp), accepted with probability ``g / (c K_L q)``,
    ``c = I(wo)`` the interpolated normalizer; on rejection the draw restarts from the root. The accepted
    point has density exactly ``g / I`` on the square: ``pdf = f cos / I(wo)`` per unit solid angle, and the
    weight ``f cos / pdf = I(wo)`` is the same for every sample (the zero-variance property). The seed's
    envelope is constant on a leaf (``M_L``); a bilinear one follows the lobe inside the leaf, so the same
    acceptance takes far fewer leaves. Every trial with ``g > c K_L q`` is counted (a bound that did not
    hold); the tests assert there are none.

``warp`` (rejection-free)
    A leaf chosen by the bilinear density's masses; the point warped inside the leaf by the bilinear
    density of its corners (a square root per axis). The density on the square is the leaf's probability
    (the product of the children's shares along its path) times the bilinear density, so the pdf is exact
    for the samples it makes, with no bound and one evaluation of ``f``.
    (Blending the two nodes around ``wo``, as Mitsuba's conditional warps do, was tried: it needs a second
    tree's density at every sample, a third more time per sample, for a variance the layout's refinement
    already bounds at the cells' edges.)

Every draw returns what it computed: the direction, its pdf, and ``f`` (RGB) there.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.dispatch import eval_model
from core.rng import next_u01, stream
from core.sampling.adaptive.layout import FULL, ISOTROPIC, MIRROR, TWO_PI, locate, normalizer_at
from core.sampling.adaptive.maps import (
    HALF_VECTOR,
    INV_PI,
    ORTHOGRAPHIC,
    PI,
    direction_to_square,
    square_to_direction,
)
from core.sampling.adaptive.target import luminance3

EXACT = 0
WARP = 1
MODES = ("exact", "warp")

MAX_TRIALS = 100_000
"""An exact draw gives up after this many trials and takes the cosine density's sample (counted: never
reached with an envelope that accepts ``>= 1 / n_max``)."""


@njit(nogil=True, cache=True)
def _eval(mid, wi, wo, p):
    """The model switch, compiled once for every draw kernel here (inlined, its four call sites in
    :func:`_sample_row` made each kernel four copies of the switch: minutes of compiling, ~5 ns a call
    saved)."""
    return eval_model(mid, wi, wo, p)


@njit(inline="always", nogil=True, cache=True)
def _frame(symmetry, wx, wy, wz):
    """``(mu, phi, cos, sin, sx, sy)``: ``-cos theta``, the azimuth the trees see (folded into the quadrant
    when mirror-symmetric; not computed for an isotropic table, which does not need it), the rotation to the
    tree frame and the mirror signs."""
    rho = math.sqrt(wx * wx + wy * wy)
    theta = -wz
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
    if symmetry == ISOTROPIC:
        phi = 0.0
    else:
        phi = math.atan2(wy, wx)
        if phi < 0.0:
            phi += TWO_PI
    if rho > 0.0:
        return theta, phi, wx / rho, wy / rho, sx, sy
    return theta, 0.0, 1.0, 0.0, sx, sy


@njit(inline="always", nogil=True, cache=True)
def _tree_frame(table, wx, wy, wz):
    """The tree serving ``wo`` and its frame: ``(t, mu, phi, cos, sin, sx, sy)`` (no turn for a tree kept in
    the local frame)."""
    mu, phi, c, s, sx, sy = _frame(table.symmetry, wx, wy, wz)
    t = _node(table, mu, phi)
    if table.follow[t] == 0:
        return t, mu, phi, 1.0, 0.0, sx, sy
    return t, mu, phi, c, s, sx, sy


@njit(inline="always", nogil=True, cache=True)
def _reflect(hx, hy, hz, wx, wy, wz):
    """``wi = 2 (wo.h) h - wo`` and ``wo.h``."""
    d = hx * wx + hy * wy + hz * wz
    return 2.0 * d * hx - wx, 2.0 * d * hy - wy, 2.0 * d * hz - wz, d


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
    """A leaf chosen by ``masses`` from ``root``: ``(leaf, x0, y0, h, prob)``, ``prob`` its probability."""
    node = root
    x0 = 0.0
    y0 = 0.0
    h = 1.0
    prob = 1.0
    while True:
        c = child[node]
        if c < 0:
            return -1 - c, x0, y0, h, prob
        m0 = np.float64(masses[c])  # float64 sums of float32 masses are exact: the shares are the stored ones
        m1 = m0 + np.float64(masses[c + 1])
        m2 = m1 + np.float64(masses[c + 2])
        m3 = m2 + np.float64(masses[c + 3])
        t = u * m3
        q = int(t >= m0) + int(t >= m1) + int(t >= m2)
        if q == 0:
            u = t / m0
        elif q == 1:
            u = (t - m0) / (m1 - m0)
        elif q == 2:
            u = (t - m1) / (m2 - m1)
        else:
            d = m3 - m2
            u = min((t - m2) / d, 0.9999999999999999) if d > 0.0 else 0.5
        prob *= (m1 - m0 if q == 1 else m2 - m1 if q == 2 else m3 - m2 if q == 3 else m0) / m3
        h *= 0.5
        x0 += h * (q & 1)
        y0 += h * (q >> 1)
        node = c + q


@njit(inline="always", nogil=True, cache=True)
def _leaf_at(masses, child, root, a, b):
    """The leaf holding square point ``(a, b)``: ``(leaf, x0, y0, h, prob)``, ``prob`` the probability
    :func:`_descend` reaches it with (the product of the children's shares along the path, from the same
    stored masses: the pdf is the density of the draws whatever the masses' precision)."""
    node = root
    x0 = 0.0
    y0 = 0.0
    h = 1.0
    prob = 1.0
    while True:
        c = child[node]
        if c < 0:
            return -1 - c, x0, y0, h, prob
        h *= 0.5
        qi = int(a >= x0 + h)
        qj = int(b >= y0 + h)
        x0 += h * qi
        y0 += h * qj
        q = qi + 2 * qj
        total = np.float64(masses[c]) + np.float64(masses[c + 1]) + np.float64(masses[c + 2])
        total += np.float64(masses[c + 3])
        prob *= np.float64(masses[c + q]) / total
        node = c + q


@njit(inline="always", nogil=True, cache=True)
def _bilinear(corners, leaf, tx, ty):
    return (
        (1.0 - tx) * (1.0 - ty) * corners[leaf, 0]
        + tx * (1.0 - ty) * corners[leaf, 1]
        + (1.0 - tx) * ty * corners[leaf, 2]
        + tx * ty * corners[leaf, 3]
    )


@njit(inline="always", nogil=True, cache=True)
def _leaf_density(corners, leaf, tx, ty, h):
    """The bilinear density of a leaf of side ``h`` at its point ``(tx, ty)`` (per unit square area; it
    integrates to 1 over the leaf)."""
    mean = 0.25 * (corners[leaf, 0] + corners[leaf, 1] + corners[leaf, 2] + corners[leaf, 3])
    return _bilinear(corners, leaf, tx, ty) / (mean * h * h)


@njit(inline="always", nogil=True, cache=True)
def _warp_pdf(table, t, x, y, z):
    """The rejection-free density of tree ``t`` at the tree-frame direction ``(x, y, z)``, per unit solid
    angle: the leaf's probability times its bilinear density on the square, times ``dA/d(omega) / pi``."""
    if z <= 0.0:
        return 0.0
    a, b, jac = direction_to_square(x, y, z, table.projection[t])
    leaf, x0, y0, h, prob = _leaf_at(table.mass, table.child, table.root[t], a, b)
    tx = min(max((a - x0) / h, 0.0), 1.0)
    ty = min(max((b - y0) / h, 0.0), 1.0)
    return prob * _leaf_density(table.corners, leaf, tx, ty, h) * INV_PI * jac


@njit(inline="always", nogil=True, cache=True)
def _node(table, mu, phi):
    """The tree of the node whose cell holds ``(mu, phi)`` (``mu = -cos theta``)."""
    lut = table.cell_lut
    n = lut.shape[0]
    k = lut[min(max(int((mu + 1.0) * n), 0), n - 1)]
    last = table.cell_mu.shape[0] - 2
    while k < last and mu >= table.cell_mu[k + 1]:
        k += 1
    return k * table.phis.shape[0] + _phi_node(table, phi)


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
    if table.flat:  # a Lambertian BRDF: the trees' density is the cosine-weighted hemisphere's
        state, x, y, z = _cosine(state)
        out_wi[i, 0] = x
        out_wi[i, 1] = y
        out_wi[i, 2] = z
        r, g, b = _eval(mid, (x, y, z), wo, p)
        out_f[i, 0] = r
        out_f[i, 1] = g
        out_f[i, 2] = b
        return z * INV_PI, 1, 0
    t, theta, phi, c, s, sx, sy = _tree_frame(table, wx, wy, wz)
    if mode == WARP and wz > 0.0:
        root = table.root[t]
        state, u = next_u01(state)
        leaf, x0, y0, h, prob = _descend(table.mass, table.child, root, u)
        v0 = table.corners[leaf, 0]
        v1 = table.corners[leaf, 1]
        v2 = table.corners[leaf, 2]
        v3 = table.corners[leaf, 3]
        state, u2 = next_u01(state)
        state, u3 = next_u01(state)
        tx = _sample_linear(u2, v0 + v2, v1 + v3)
        ty = _sample_linear(u3, (1.0 - tx) * v0 + tx * v1, (1.0 - tx) * v2 + tx * v3)
        proj = table.projection[t]
        x, y, z, jac = square_to_direction(x0 + tx * h, y0 + ty * h, proj)
        lx, ly, lz = _to_local(x, y, z, c, s, sx, sy)
        d = 0.25
        if proj == HALF_VECTOR:
            lx, ly, lz, d = _reflect(lx, ly, lz, wx, wy, wz)
        r, g, b = _eval(mid, (lx, ly, lz), wo, p)
        out_wi[i, 0] = lx
        out_wi[i, 1] = ly
        out_wi[i, 2] = lz
        out_f[i, 0] = r
        out_f[i, 1] = g
        out_f[i, 2] = b
        if z <= 0.0 or d == 0.0:
            return 0.0, 1, 0
        # per solid angle of wi: on the square, then on the disk, per solid angle of the point (and of wi
        # through h: d(omega_i) = 4 |wo.h| d(omega_h); d = 1/4 makes that factor 1 for a wi tree)
        return prob * _leaf_density(table.corners, leaf, tx, ty, h) * INV_PI * jac / (4.0 * abs(d)), 1, 0
    norm = 0.0
    if mode == EXACT and wz >= table.cos_min:
        norm = normalizer_at(table.symmetry, table.norm, table.norm_ds, table.norm_log, wz, phi)
    if norm > 0.0:
        proj = table.projection[t]
        violations = 0
        for trial in range(1, MAX_TRIALS + 1):
            state, u = next_u01(state)
            leaf, x0, y0, h, _ = _descend(table.envelope, table.child, table.root[t], u)
            v0 = table.corners[leaf, 0]
            v1 = table.corners[leaf, 1]
            v2 = table.corners[leaf, 2]
            v3 = table.corners[leaf, 3]
            state, u2 = next_u01(state)
            state, u3 = next_u01(state)
            state, u4 = next_u01(state)
            tx = _sample_linear(u2, v0 + v2, v1 + v3)
            ty = _sample_linear(u3, (1.0 - tx) * v0 + tx * v1, (1.0 - tx) * v2 + tx * v3)
            x, y, z, jac = square_to_direction(x0 + tx * h, y0 + ty * h, proj)
            lx, ly, lz = _to_local(x, y, z, c, s, sx, sy)
            if proj == HALF_VECTOR:
                lx, ly, lz, d = _reflect(lx, ly, lz, wx, wy, wz)
                if d <= 0.0 or lz <= 0.0:
                    continue
                scale = 4.0 * d * lz / jac
            else:
                scale = _g_scale(proj, z, jac)
            r, g, b = _eval(mid, (lx, ly, lz), wo, p)
            lum = luminance3(r, g, b)
            if not lum > 0.0 or z <= 0.0:
                continue
            gn = PI * lum * scale / norm
            bound = table.bound[leaf] * _bilinear(table.corners, leaf, tx, ty)
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
    r, g, b = _eval(mid, (x, y, z), wo, p)
    out_f[i, 0] = r
    out_f[i, 1] = g
    out_f[i, 2] = b
    return z * INV_PI, trials, violations


@njit(nogil=True, cache=True)
def sample_rows(table, mid, p, mode, wo, seed, offset, out_wi, out_pdf, out_f, out_trials):
    """One draw per row of ``wo (n, 3)``, row ``i`` from random stream ``offset + i`` (so that chunks drawn on
    several threads give the draws of one call); returns the number of trials that found ``g`` above its
    bound (must be 0). Releases the GIL."""
    violations = 0
    for i in range(wo.shape[0]):
        state = stream(seed, offset + i)
        pdf, trials, v = _sample_row(
            table, mid, p, mode, wo[i, 0], wo[i, 1], wo[i, 2], state, out_wi, out_f, i
        )
        out_pdf[i] = pdf
        out_trials[i] = trials
        violations += v
    return violations


@njit(inline="always", nogil=True, cache=True)
def _pdf_row(table, mid, p, mode, wo, wi, out_f, i):
    """The pdf of ``wi`` for ``wo`` (and ``f`` there, in ``out_f[i]``)."""
    wx, wy, wz = wo
    r, g, b = _eval(mid, wi, wo, p)
    out_f[i, 0] = r
    out_f[i, 1] = g
    out_f[i, 2] = b
    if table.flat:
        return wi[2] * INV_PI if wi[2] > 0.0 else 0.0
    t, theta, phi, c, s, sx, sy = _tree_frame(table, wx, wy, wz)
    if mode == WARP and wz > 0.0:
        if table.projection[t] == HALF_VECTOR:
            hx = wi[0] + wx
            hy = wi[1] + wy
            hz = wi[2] + wz
            n = math.sqrt(hx * hx + hy * hy + hz * hz)
            if n == 0.0:
                return 0.0
            if hz < 0.0:
                n = -n
            hx /= n
            hy /= n
            hz /= n
            d = abs(hx * wx + hy * wy + hz * wz)
            if d == 0.0:
                return 0.0
            x, y, z = _to_tree(hx, hy, hz, c, s, sx, sy)
            return _warp_pdf(table, t, x, y, z) / (4.0 * d)
        x, y, z = _to_tree(wi[0], wi[1], wi[2], c, s, sx, sy)
        return _warp_pdf(table, t, x, y, z)
    norm = 0.0
    if mode == EXACT and wz >= table.cos_min:
        norm = normalizer_at(table.symmetry, table.norm, table.norm_ds, table.norm_log, wz, phi)
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
        if wo[i, 2] >= table.cos_min:
            out[i] = max(
                normalizer_at(table.symmetry, table.norm, table.norm_ds, table.norm_log, wo[i, 2], phi), 0.0
            )
        else:
            out[i] = 0.0


@njit(nogil=True, cache=True)
def acceptance_rows(table, wo, out):
    """The exact mode's acceptance ``I(wo) / (c V)`` per row: ``1 / V`` of the tree serving it (``c = I``)."""
    for i in range(wo.shape[0]):
        theta, phi, _, _, _, _ = _frame(table.symmetry, wo[i, 0], wo[i, 1], wo[i, 2])
        t = _node(table, theta, phi)
        v = table.envelope[table.root[t]]
        out[i] = 1.0 / v if v > 0.0 else 0.0
