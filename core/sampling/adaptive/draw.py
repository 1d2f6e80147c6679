"""The adaptive sampler's draws and densities: one compiled loop over a batch of outgoing directions.

Both modes use the tree of the node whose cell holds ``wo`` (:class:`~core.sampling.adaptive.records.
AdaptiveTable`):

``exact`` (the seed's)
    A leaf chosen with probability ``P_L``, the stored ``K_L q_L / V`` (``q_L`` its mass under the
    rejection-free density ``q``, ``K_L`` a bound of ``g / (c q)`` on it, ``V`` their sum); a point of the
    leaf drawn from ``q`` (the rejection-free mode's warp), so that the trial has density
    ``p(s) = P_L q(s) / q_L`` on the square; accepted with probability ``g / (c V p)``, ``c = I(wo)`` the
    interpolated normalizer; on rejection the draw starts again. The accepted point has density exactly
    ``g / I`` on the square whatever rounding made the stored ``P_L`` (``V p`` is the envelope the trials
    were drawn under, ``K_L q`` to that rounding): ``pdf = f cos / I(wo)`` per unit solid angle, and the
    weight ``f cos / pdf = I(wo)`` is the same for every sample (the zero-variance property). The seed's
    envelope is constant on a leaf (``M_L``); a bilinear one follows the lobe inside the leaf, so the same
    acceptance takes far fewer leaves. Every trial with ``g > c V p`` is counted (a bound that did not
    hold).

``warp`` (rejection-free)
    A leaf chosen with probability ``P_L = q_L``; the point warped inside the leaf by the bilinear density
    of its corners (a square root per axis). The density on the square is ``P_L`` times the leaf's bilinear
    density, so the pdf is exact for the samples it makes, with no bound and one evaluation of ``f``.
    (Blending the two nodes around ``wo``, as Mitsuba's conditional warps do, was tried: it needs a second
    tree's density at every sample, a third more time per sample, for a variance the layout's refinement
    already bounds at the cells' edges.)

Choosing the leaf: one uniform ``u``, a guide table (Chen and Asau) to the first candidate of the tree's
cumulative ``P_L`` (whole units of ``2^-31``), a step or two along it; ``P_L`` is the difference of two
entries, the length of the interval of ``u`` that chooses the leaf, exactly (``u 2^31`` is exact for a
uniform on the ``2^-53`` grid, and its integer part is compared with the integer entries). The table
replaces a descent of the tree (one uniform and four masses a level, 15 ns a level); the tree is only read by
the rejection-free mode's ``pdf``, to locate a given direction.

Every draw returns what it computed: the direction, its pdf, and ``f`` (RGB) there.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.dispatch import eval_model
from core.jit import kernel
from core.rng import next_u01, stream
from core.sampling.adaptive.frames import (
    _fold,
    _reflect,
    _to_local,
    _to_tree,
    _tree_frame,
)
from core.sampling.adaptive.layout import TWO_PI, normalizer_at
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

NO_MODEL = -1
"""A model id no switch knows (``f = 0``): the rejection-free draws and densities with ``f`` left to the caller
(:meth:`~core.sampling.adaptive.sampler.AdaptiveSampler._f_apart`); never the exact mode's, whose density and
acceptance are made of ``f``."""

MAX_TRIALS = 100_000
"""An exact draw gives up after this many trials and takes the cosine density's sample (counted: never
reached with an envelope that accepts ``>= 1 / n_max``)."""


@kernel
def _eval(mid, wi, wo, p):
    """The model switch, compiled once for every draw kernel here (inlined, its four call sites in
    :func:`sample_rows` made each kernel four copies of the switch: minutes of compiling, ~5 ns a call
    saved)."""
    return eval_model(mid, wi, wo, p)


# The kernels take the table (a tuple of 17 arrays) and hand the functions they call per row only the arrays
# they need: a table passed to a function inlined by numba is copied with a reference count taken and dropped
# on every array (~50 ns a call), and to one that is not, copied by value (~120 ns): handed only its arrays,
# the tree lookup per row takes 4 ns instead of 56, and a rejection-free draw of Phong with f half the time
# (the row loops written out, :func:`sample_rows`).
CDF_UNIT = 4.656612873077393e-10
"""``2^-31``: the stored ``cdf``'s unit (:data:`~core.sampling.adaptive.pack.CDF_ONE`)."""
CDF_SCALE = 2147483648.0
"""``2^31``: ``u * CDF_SCALE`` is exact for a uniform on the ``2^-53`` grid."""
ONE_BELOW = 0.9999999999999999
"""The largest double below 1: a rescaled coordinate stays in ``[0, 1)``."""


@njit(inline="always", nogil=True, cache=True)
def _leaf_probability(cdf, start, leaf):
    """A leaf's probability: its interval of ``cdf`` (the one :func:`_pick_leaf` chooses it by)."""
    if leaf == start:
        return np.int64(cdf[leaf]) * CDF_UNIT
    return (np.int64(cdf[leaf]) - np.int64(cdf[leaf - 1])) * CDF_UNIT


@njit(inline="always", nogil=True, cache=True)
def _pick_leaf(cdf, guide, start, end, u):
    """The leaf of ``start : end`` (one tree's, global indices) whose ``cdf`` interval holds ``u``, and its
    probability, the interval's length: the guide table's entry, then a step or two (the steps back undo a
    bucket index rounded up). ``u 2^31`` is exact and its integer part is compared with the stored integer
    counts, so the probability is exactly the count's difference times ``2^-31``."""
    n = end - start
    x = np.int64(u * CDF_SCALE)
    j = start + np.int64(guide[start + min(int(u * n), n - 1)])
    while np.int64(cdf[j]) <= x:
        j += 1
    while j > start and np.int64(cdf[j - 1]) > x:
        j -= 1
    return j, _leaf_probability(cdf, start, j)


@njit(inline="always", nogil=True, cache=True)
def _leaf_box(leaf_cell, leaf):
    """``(x0, y0, h)`` of a leaf from its packed cell (:attr:`~core.sampling.adaptive.records.AdaptiveTable.
    leaf_cell`): exact, the origins are multiples of ``2^-14``."""
    c = np.int64(leaf_cell[leaf])
    return (
        (c & 16383) * 6.103515625e-05,
        ((c >> 14) & 16383) * 6.103515625e-05,
        (np.int64(1) << (14 - (c >> 28))) * 6.103515625e-05,
    )


@njit(inline="always", nogil=True, cache=True)
def _leaf_at(child, root, a, b):
    """The leaf holding square point ``(a, b)``: ``(leaf, x0, y0, h)``."""
    node = root
    x0 = 0.0
    y0 = 0.0
    h = 1.0
    while True:
        c = child[node]
        if c < 0:
            return -1 - c, x0, y0, h
        h *= 0.5
        qi = int(a >= x0 + h)
        qj = int(b >= y0 + h)
        x0 += h * qi
        y0 += h * qj
        node = c + qi + 2 * qj


@njit(inline="always", nogil=True, cache=True)
def descend_at(child, node_mass, root, a, b):
    """The leaf a caller's point ``(a, b)`` of the unit square reaches by descending the tree at ``root``,
    both coordinates at every level, and what is left of them inside it: ``(leaf, a', b')``.

    At a node, ``a`` chooses the column of children (left or right) by the columns' masses, ``b`` the child
    in that column by theirs, and each is rescaled to what is left of it inside its choice (hierarchical
    sample warping, as Mitsuba 3's ``Hierarchical2D`` descends its levels). A leaf is reached with
    probability its mass over the root's, the ``cdf`` interval :func:`_pick_leaf` would choose it by (to the
    rounding of a product per level), and ``(a', b')`` is uniform on the square given the leaf; the map is
    monotone in each coordinate inside every node, so a stratified set of points gives a stratified set of
    leaves in both directions, not only along the leaves' order as one number's choice does. Children of
    no mass are never chosen.

    Each coordinate is carried as a fraction (``a = xn / xd``): a level multiplies, and the two divisions
    are made once, at the leaf (two divisions a level, each level's test waiting on them: a placed draw
    3-6 % slower). The choices are branches: written as 0/1 factors they lengthen each level's chain, and a
    pass takes 2 ms more (``bench/render_stages.py``)."""
    xn = a
    xd = 1.0
    yn = b
    yd = 1.0
    node = root
    while True:
        c = child[node]
        if c < 0:
            return -1 - c, min(xn / xd, ONE_BELOW), min(yn / yd, ONE_BELOW)
        m0 = np.float64(node_mass[c])
        m1 = np.float64(node_mass[c + 1])
        m2 = np.float64(node_mass[c + 2])
        m3 = np.float64(node_mass[c + 3])
        left = m0 + m2
        right = m1 + m3
        xa = xn * (left + right)
        xl = left * xd
        qi = xa >= xl and right > 0.0
        column = right if qi else left
        xn = xa - xl if qi else xa
        xd *= column
        low = m1 if qi else m0
        high = m3 if qi else m2
        yb = yn * column
        yl = low * yd
        qj = yb >= yl and high > 0.0
        yn = yb - yl if qj else yb
        yd *= high if qj else low
        node = c + int(qi) + 2 * int(qj)


@njit(inline="always", nogil=True, cache=True)
def _bilinear_density(v0, v1, v2, v3, tx, ty):
    """The bilinear density of corner values ``v`` at ``(tx, ty)`` of the unit leaf (it integrates to 1)."""
    low = (1.0 - tx) * v0 + tx * v1
    high = (1.0 - tx) * v2 + tx * v3
    return 4.0 * ((1.0 - ty) * low + ty * high) / (((v0 + v1) + v2) + v3)


@njit(inline="always", nogil=True, cache=True)
def _warp_in_leaf(corners, leaf, state):
    """A point ``(tx, ty)`` of the unit leaf drawn from its bilinear density, and that density there (per
    unit leaf area): ``(state, tx, ty, density)``.

    The bilinear density is the mixture of its four corners' products of ramps, ``v_k / sum v`` times
    ``4 (1 - tx) (1 - ty)``, ``4 tx (1 - ty)``, ...: a corner chosen by its value, then each coordinate
    drawn from its ramp by one square root (``t = sqrt(u)`` has density ``2 t``). The same density as
    inverting the marginal and then the conditional, without that warp's chain of two square roots and two
    divisions, each waiting on the last: the two roots here are independent."""
    v0 = np.float64(corners[leaf, 0])
    v1 = np.float64(corners[leaf, 1])
    v2 = np.float64(corners[leaf, 2])
    v3 = np.float64(corners[leaf, 3])
    state, u0 = next_u01(state)
    state, u1 = next_u01(state)
    state, u2 = next_u01(state)
    c1 = v0 + v1
    c2 = c1 + v2
    x = u0 * (c2 + v3)  # < the sum, so a corner of value 0 is never chosen
    k = int(x >= v0) + int(x >= c1) + int(x >= c2)
    rx = math.sqrt(u1)
    ry = math.sqrt(u2)
    tx = rx if k & 1 else 1.0 - rx
    ty = ry if k >> 1 else 1.0 - ry
    return state, tx, ty, _bilinear_density(v0, v1, v2, v3, tx, ty)


@njit(inline="always", nogil=True, cache=True)
def _ramp_inverse(a, b, u):
    """The point ``t`` of ``[0, 1]`` where the linear density from ``a`` to ``b`` (``a, b >= 0``, not both 0)
    has CDF ``u``: the root of ``(b - a) t^2 + 2 a t = u (a + b)``, in the form without cancellation (0 at
    ``u = 0``, also where ``a = 0``)."""
    den = a + math.sqrt(a * a + u * (b * b - a * a))
    return u * (a + b) / den if den > 0.0 else 0.0


@njit(inline="always", nogil=True, cache=True)
def _warp_in_leaf_at(corners, leaf, r, v):
    """A point ``(tx, ty)`` of the unit leaf from its bilinear density by inversion, the marginal of ``tx``
    from ``r`` and then the conditional of ``ty`` from ``v``, and that density there: the density of
    :func:`_warp_in_leaf`, continuous in ``(r, v)``, so stratified points stay stratified (a caller's
    low-discrepancy points; :func:`sample_rows`)."""
    v0 = np.float64(corners[leaf, 0])
    v1 = np.float64(corners[leaf, 1])
    v2 = np.float64(corners[leaf, 2])
    v3 = np.float64(corners[leaf, 3])
    tx = min(max(_ramp_inverse(v0 + v2, v1 + v3, r), 0.0), 1.0)
    low = (1.0 - tx) * v0 + tx * v1
    high = (1.0 - tx) * v2 + tx * v3
    ty = min(max(_ramp_inverse(low, high, v), 0.0), 1.0) if low + high > 0.0 else v
    return tx, ty, _bilinear_density(v0, v1, v2, v3, tx, ty)


@njit(inline="always", nogil=True, cache=True)
def _leaf_density(corners, leaf, tx, ty, h):
    """The bilinear density of a leaf of side ``h`` at its point ``(tx, ty)`` (per unit square area; it
    integrates to 1 over the leaf), in the arithmetic of :func:`_warp_in_leaf`."""
    v0 = np.float64(corners[leaf, 0])
    v1 = np.float64(corners[leaf, 1])
    v2 = np.float64(corners[leaf, 2])
    v3 = np.float64(corners[leaf, 3])
    return _bilinear_density(v0, v1, v2, v3, tx, ty) / (h * h)


@njit(inline="always", nogil=True, cache=True)
def _warp_pdf(projection, child, corners, cdf, root, start, x, y, z):
    """The rejection-free density of the tree at ``root`` (its leaves from ``start``) at the tree-frame
    direction ``(x, y, z)``, per unit solid angle: the leaf's probability times its bilinear density on the
    square, times ``dA/d(omega) / pi``."""
    if z <= 0.0:
        return 0.0
    a, b, jac = direction_to_square(x, y, z, projection)
    leaf, x0, y0, h = _leaf_at(child, root, a, b)
    tx = min(max((a - x0) / h, 0.0), 1.0)
    ty = min(max((b - y0) / h, 0.0), 1.0)
    return _leaf_probability(cdf, start, leaf) * _leaf_density(corners, leaf, tx, ty, h) * INV_PI * jac


@njit(inline="always", nogil=True, cache=True)
def _g_scale(projection, z, jac):
    """``g / (pi f_lum)``: ``cos / (dA/d(omega))`` (1 on the orthographic disk)."""
    if projection == ORTHOGRAPHIC:
        return 1.0
    return z / jac if jac > 0.0 else 0.0


@njit(inline="always", nogil=True, cache=True)
def _cosine_at(u1, u2):
    r = math.sqrt(u1)
    ph = TWO_PI * u2
    return r * math.cos(ph), r * math.sin(ph), math.sqrt(max(0.0, 1.0 - u1))


@njit(inline="always", nogil=True, cache=True)
def _cosine(state):
    state, u1 = next_u01(state)
    state, u2 = next_u01(state)
    x, y, z = _cosine_at(u1, u2)
    return state, x, y, z


@kernel
def sample_rows(table, mid, p, mode, wo, seed, offset, out_wi, out_pdf, out_f, out_trials, points):
    """One draw per row of ``wo (n, 3)``, row ``i`` from random stream ``offset + i`` (so that chunks drawn on
    several threads give the draws of one call); writes ``out_wi``, ``out_pdf``, ``out_f`` (``f`` at the draw)
    and ``out_trials``; returns the number of trials that found ``g`` above its bound. Releases the GIL.

    ``points (n, 2)`` (or ``(0, 2)``: none): a caller's uniforms for each row's first proposal. The
    rejection-free mode descends the tree by both numbers (:func:`descend_at`) and inverts the leaf's
    bilinear density with what is left of them (:func:`_warp_in_leaf_at`); the exact mode, whose tables keep
    no tree, takes the leaf from ``points[i, 0]`` and its point in the leaf from what is left of that number
    inside the leaf's interval and ``points[i, 1]``; a row drawn from the cosine density takes its point from
    both. The density of a proposal does not change (each point is uniform); the exact mode's acceptance
    test and every later trial draw from the row's stream.

    The row's draw is written out in the loop, not in a function called per row: numba takes and drops a
    reference on every array handed to a function whose body it cannot prune (loops, branches), and the
    fourteen arrays of the table made that ~110 ns a row (the Lambertian path: 190 ns against 60). Every
    proposal of a row (a tree's trial, or the cosine density's draw) goes through one loop with one
    evaluation of ``f``, so that the model switch is inlined once: a call to it cost 12-35 ns a draw of a
    cheap model, four inlined copies minutes of compiling."""
    violations = 0
    flat, symmetry, follow = table.flat, table.symmetry, table.follow
    cell_lut, cell_mu, phis = table.cell_lut, table.cell_mu, table.phis
    edge_cos, edge_sin = table.edge_cos, table.edge_sin
    projection, leaf_base, leaf_cell = table.projection, table.leaf_base, table.leaf_cell
    cdf, guide, corners, total, cos_min = table.cdf, table.guide, table.corners, table.total, table.cos_min
    norm_table, norm_log = table.norm, table.norm_log
    root, child, node_mass = table.root, table.child, table.node_mass
    placed = points.shape[0] > 0
    # a rejection-free table's first proposal descends its tree by both of the point's numbers; the exact
    # mode's tables keep no tree (their first proposal takes its leaf by the point's first number)
    descend = mode == WARP and node_mass.shape[0] > 0
    for i in range(wo.shape[0]):
        state = stream(seed, offset + i)
        wx = wo[i, 0]
        wy = wo[i, 1]
        wz = wo[i, 2]
        # what the row draws from: the tree (warp or exact), or the cosine density (a Lambertian BRDF, whose
        # trees' density it is; in the exact mode beyond the last node, at or below the horizon, where
        # I(wo) = 0, or after MAX_TRIALS rejections)
        tree = False
        t = 0
        c = 1.0
        s = 0.0
        sx = 1.0
        sy = 1.0
        norm = 0.0
        pi_over_norm = 0.0  # PI / norm, once a row: a trial multiplies
        if not flat:
            t, c, s, sx, sy, cos_o, sin_o = _tree_frame(
                symmetry, follow, cell_lut, cell_mu, phis, edge_cos, edge_sin, wx, wy, wz
            )
            if mode == WARP:
                tree = wz > 0.0
            elif wz >= cos_min:
                norm = normalizer_at(symmetry, norm_table, norm_log, wz, cos_o, sin_o)
                tree = norm > 0.0
                if tree:
                    pi_over_norm = PI / norm
        proj = projection[t]
        start = leaf_base[t]
        end = leaf_base[t + 1]
        envelope = total[t]
        trials = 0
        while True:
            trials += 1
            if trials > MAX_TRIALS:
                tree = False
            u4 = 0.0
            prob = 0.0
            density = 0.0
            h = 1.0
            z = 0.0
            jac = 0.0
            d = 0.25
            first = placed and trials == 1
            if tree:
                if first and descend:
                    # both of the point's numbers down the tree, then inverted inside the leaf
                    leaf, r, v = descend_at(child, node_mass, root[t], points[i, 0], points[i, 1])
                    prob = _leaf_probability(cdf, start, leaf)
                    x0, y0, h = _leaf_box(leaf_cell, leaf)
                    tx, ty, density = _warp_in_leaf_at(corners, leaf, r, v)
                else:
                    if first:
                        u = points[i, 0]
                    else:
                        state, u = next_u01(state)
                    leaf, prob = _pick_leaf(cdf, guide, start, end, u)
                    x0, y0, h = _leaf_box(leaf_cell, leaf)
                    if first:
                        # u's place inside the leaf's interval of the cdf: uniform, and as stratified as u
                        lo = 0.0 if leaf == start else np.float64(np.int64(cdf[leaf - 1]))
                        r = min(max((u * CDF_SCALE - lo) / (prob * CDF_SCALE), 0.0), 1.0)
                        tx, ty, density = _warp_in_leaf_at(corners, leaf, r, points[i, 1])
                    else:
                        state, tx, ty, density = _warp_in_leaf(corners, leaf, state)
                if mode == EXACT:
                    state, u4 = next_u01(state)
                x, y, z, jac = square_to_direction(x0 + tx * h, y0 + ty * h, proj)
                lx, ly, lz = _to_local(x, y, z, c, s, sx, sy)
                if proj == HALF_VECTOR:
                    lx, ly, lz, d = _reflect(lx, ly, lz, wx, wy, wz)
            elif first:
                lx, ly, lz = _cosine_at(points[i, 0], points[i, 1])
            else:
                state, lx, ly, lz = _cosine(state)
            r, g, b = eval_model(mid, (lx, ly, lz), (wx, wy, wz), p)
            if tree and mode == EXACT:
                if proj == HALF_VECTOR:
                    if d <= 0.0 or lz <= 0.0:
                        continue
                    scale = 4.0 * d * lz / jac
                else:
                    scale = _g_scale(proj, z, jac)
                lum = luminance3(r, g, b)
                if not lum > 0.0 or z <= 0.0:
                    continue
                # g / c against the trial's own density on the square times V (K_L q up to the rounding of the
                # stored leaf probabilities, and exactly the envelope the trials were drawn under), both times
                # the leaf's area h^2: a power of 2, so the comparisons are those of bound = V p q / h^2
                gn_area = lum * scale * pi_over_norm * (h * h)
                bound_area = envelope * prob * density
                if gn_area > bound_area:
                    violations += 1
                if not u4 * bound_area < gn_area:
                    continue
                pdf = lum * lz / norm
            elif tree:
                # per solid angle of wi: on the square, then on the disk, per solid angle of the point (and of
                # wi through h: d(omega_i) = 4 |wo.h| d(omega_h); d = 1/4 makes that 1 for wi)
                pdf = 0.0 if z <= 0.0 or d == 0.0 else prob * density * INV_PI * jac / (h * h * 4.0 * abs(d))
            else:
                pdf = lz * INV_PI
            out_wi[i, 0] = lx
            out_wi[i, 1] = ly
            out_wi[i, 2] = lz
            out_f[i, 0] = r
            out_f[i, 1] = g
            out_f[i, 2] = b
            out_pdf[i] = pdf
            out_trials[i] = trials
            break
    return violations


@kernel
def pdf_rows(table, mid, p, mode, wo, wi, mask, out_pdf, out_f):
    """``pdf(wo[i], wi[i])`` per unit solid angle, and ``f`` there (the loop written out as in
    :func:`sample_rows`), at the rows where ``mask`` (bool) holds; an empty ``mask`` means every row (rows
    left out are not written: a renderer's light samples that a material's rows did not make)."""
    every = mask.shape[0] == 0
    flat, symmetry, follow = table.flat, table.symmetry, table.follow
    cell_lut, cell_mu, phis = table.cell_lut, table.cell_mu, table.phis
    edge_cos, edge_sin = table.edge_cos, table.edge_sin
    projection, root, child, leaf_base = table.projection, table.root, table.child, table.leaf_base
    corners, cdf, cos_min = table.corners, table.cdf, table.cos_min
    norm_table, norm_log = table.norm, table.norm_log
    for i in range(wo.shape[0]):
        if not every and not mask[i]:
            continue
        wx = wo[i, 0]
        wy = wo[i, 1]
        wz = wo[i, 2]
        ix = wi[i, 0]
        iy = wi[i, 1]
        iz = wi[i, 2]
        r, g, b = _eval(mid, (ix, iy, iz), (wx, wy, wz), p)
        out_f[i, 0] = r
        out_f[i, 1] = g
        out_f[i, 2] = b
        cosine = iz * INV_PI if iz > 0.0 else 0.0
        if flat:
            out_pdf[i] = cosine
            continue
        t, c, s, sx, sy, cos_o, sin_o = _tree_frame(
            symmetry, follow, cell_lut, cell_mu, phis, edge_cos, edge_sin, wx, wy, wz
        )
        if mode == WARP and wz > 0.0:
            if projection[t] == HALF_VECTOR:
                hx = ix + wx
                hy = iy + wy
                hz = iz + wz
                n = math.sqrt(hx * hx + hy * hy + hz * hz)
                if n == 0.0:
                    out_pdf[i] = 0.0
                    continue
                if hz < 0.0:
                    n = -n
                hx /= n
                hy /= n
                hz /= n
                d = abs(hx * wx + hy * wy + hz * wz)
                if d == 0.0:
                    out_pdf[i] = 0.0
                    continue
                x, y, z = _to_tree(hx, hy, hz, c, s, sx, sy)
                out_pdf[i] = _warp_pdf(HALF_VECTOR, child, corners, cdf, root[t], leaf_base[t], x, y, z) / (
                    4.0 * d
                )
            else:
                x, y, z = _to_tree(ix, iy, iz, c, s, sx, sy)
                out_pdf[i] = _warp_pdf(projection[t], child, corners, cdf, root[t], leaf_base[t], x, y, z)
            continue
        norm = 0.0
        if mode == EXACT and wz >= cos_min:
            norm = normalizer_at(symmetry, norm_table, norm_log, wz, cos_o, sin_o)
        if norm > 0.0:
            out_pdf[i] = max(luminance3(r, g, b), 0.0) * iz / norm if iz > 0.0 else 0.0
        else:
            out_pdf[i] = cosine


@kernel
def normalizer_rows(table, wo, out):
    """The exact mode's ``I(wo)`` per row (0 where it draws the cosine density)."""
    for i in range(wo.shape[0]):
        c, s, _, _ = _fold(table.symmetry, wo[i, 0], wo[i, 1])
        if wo[i, 2] >= table.cos_min:
            out[i] = max(normalizer_at(table.symmetry, table.norm, table.norm_log, wo[i, 2], c, s), 0.0)
        else:
            out[i] = 0.0


@kernel
def acceptance_rows(table, wo, out):
    """The exact mode's acceptance ``I(wo) / (c V)`` per row: ``1 / V`` of the tree serving it (``c = I``)."""
    edge_cos, edge_sin = table.edge_cos, table.edge_sin
    for i in range(wo.shape[0]):
        t, _, _, _, _, _, _ = _tree_frame(
            table.symmetry, table.follow, table.cell_lut, table.cell_mu, table.phis, edge_cos, edge_sin,
            wo[i, 0], wo[i, 1], wo[i, 2],
        )  # fmt: skip
        v = table.total[t]
        out[i] = 1.0 / v if v > 0.0 else 0.0
