"""After the BRDF samples: the light samples' contributions and shadow rays, the BRDF samples' throughput,
Russian roulette and the next bounce's rays; after the occlusion query, the unblocked contributions."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.jit import kernel
from renderer.qmc import uniform
from renderer.stages.primitives import add_radiance, mis_weight, tangents


@njit(inline="always", nogil=True, cache=True)
def _throughput(wi_local, t, b, s, g, p, f, beta):
    """A BRDF sample ``wi_local = (x, y, z)`` of the frame ``(t, b, s)`` (three ``(x, y, z)`` tuples) with
    density ``p`` and value ``f = (r, g, b)``: its unit world direction, the throughput ``beta f cos / p``
    and whether the path goes on (the pdf positive and finite, ``f`` finite, the direction above both the
    shading and the geometric surface ``g``: reflection only, and some throughput left)."""
    x, y, z = wi_local
    tx, ty, tz = t
    bx, by, bz = b
    sx, sy, sz = s
    gx, gy, gz = g
    r, gr, bl = f
    beta_r, beta_g, beta_b = beta
    wx = x * tx + y * bx + z * sx
    wy = x * ty + y * by + z * sy
    wz = x * tz + y * bz + z * sz
    length = math.sqrt(wx * wx + wy * wy + wz * wz)
    if length > 0.0:
        wx, wy, wz = wx / length, wy / length, wz / length
    if not (p > 0.0 and math.isfinite(p) and z > 0.0) or wx * gx + wy * gy + wz * gz <= 0.0:
        return wx, wy, wz, 0.0, 0.0, 0.0, False
    if not (math.isfinite(r) and math.isfinite(gr) and math.isfinite(bl)):
        return wx, wy, wz, 0.0, 0.0, 0.0, False
    sc = z / p
    br, bg, bb = beta_r * r * sc, beta_g * gr * sc, beta_b * bl * sc
    return wx, wy, wz, br, bg, bb, br > 0.0 or bg > 0.0 or bb > 0.0


@kernel
def continue_stage(a, b, est, rr, rr_key, vtx, light, bsdf, rays, shadow, counts):
    """Surface vertices ``[a, b)`` after their samplers ran: the light sample's contribution ``beta f L cos
    w / pdf_light`` (MIS weight ``w`` against the sampler's density, by ``est.power``; 1 for delta lights)
    into ``light.contrib`` and, if it carries light, its shadow ray; the BRDF sample's world direction and
    throughput (:func:`_throughput`), then Russian roulette when ``rr`` (survival ``min(0.95, max beta)``, a
    uniform keyed by ``rr_key`` and the path), and the next bounce's ray of a path that goes on. Rays and
    shadow rays are packed in the vertices' order from rows ``counts[0]`` and ``counts[1]`` of ``rays`` and
    ``shadow`` (the rows the vertices before ``a`` took), and ``counts`` is advanced past them. ``rays`` may
    be the rays the vertices were made from: a vertex reads only its own rows (``vtx``, ``light``, ``bsdf``)
    and writes row ``m <= s``. The records are :mod:`renderer.stages.records`'."""
    power = est.power
    s_ng, s_ns, s_beta, s_path, s_origin = vtx.ng, vtx.ns, vtx.beta, vtx.path, vtx.origin
    l_wi, l_wi_local, l_le, l_pdf, l_tmax = light.wi, light.wi_local, light.le, light.pdf, light.tmax
    l_delta, l_cand, l_f = light.delta, light.cand, light.f
    l_pdf_brdf, l_contrib = light.pdf_brdf, light.contrib
    wi_local, pdf, f = bsdf.wi_local, bsdf.pdf, bsdf.f
    o, d, o32, d32 = rays.o, rays.d, rays.o32, rays.d32
    beta, path, prev_pdf = rays.beta, rays.path, rays.prev_pdf
    so32, sd32, st32, shadow_slot = shadow.o32, shadow.d32, shadow.tmax32, shadow.slot
    m = counts[0]
    k = counts[1]
    for s in range(a, b):
        # ---- the light sample, and its shadow ray
        if l_cand[s]:
            pl = l_pdf[s]
            w = 1.0 if l_delta[s] else mis_weight(pl, l_pdf_brdf[s], power)
            sc = l_wi_local[s, 2] * w / pl
            any_light = False
            for c in range(3):
                v = s_beta[s, c] * l_f[s, c] * l_le[s, c] * sc
                l_contrib[s, c] = v
                any_light = any_light or v > 0.0
            if any_light:
                for c in range(3):
                    so32[k, c] = s_origin[s, c]
                    sd32[k, c] = l_wi[s, c]
                st32[k] = l_tmax[s]
                shadow_slot[k] = s
                k += 1
        # ---- the BRDF sample, and the next ray
        sx, sy, sz = s_ns[s, 0], s_ns[s, 1], s_ns[s, 2]
        tx, ty, tz, bx, by, bz = tangents(sx, sy, sz)
        wx, wy, wz, br, bg, bb, ok = _throughput(
            (wi_local[s, 0], wi_local[s, 1], wi_local[s, 2]), (tx, ty, tz), (bx, by, bz), (sx, sy, sz),
            (s_ng[s, 0], s_ng[s, 1], s_ng[s, 2]), pdf[s], (f[s, 0], f[s, 1], f[s, 2]),
            (s_beta[s, 0], s_beta[s, 1], s_beta[s, 2]),
        )  # fmt: skip
        if not ok:
            continue
        if rr:
            q = min(0.95, max(br, max(bg, bb)))
            if not uniform(rr_key, s_path[s]) < q:
                continue
            br, bg, bb = br / q, bg / q, bb / q
        ox, oy, oz = s_origin[s, 0], s_origin[s, 1], s_origin[s, 2]
        o[m, 0], o[m, 1], o[m, 2] = ox, oy, oz
        d[m, 0], d[m, 1], d[m, 2] = wx, wy, wz
        o32[m, 0], o32[m, 1], o32[m, 2] = ox, oy, oz
        d32[m, 0], d32[m, 1], d32[m, 2] = wx, wy, wz
        beta[m, 0], beta[m, 1], beta[m, 2] = br, bg, bb
        path[m] = s_path[s]
        prev_pdf[m] = pdf[s]
        m += 1
    counts[0] = m
    counts[1] = k


@kernel
def shadow_stage(a, b, blocked, shadow, vtx, light, radiance, row_offset):
    """Add the contributions (``light.contrib``) of the shadow rays ``[a, b)`` that nothing blocked to
    ``radiance`` row ``path - row_offset``; returns the number of non-finite ones dropped."""
    shadow_slot, s_path, l_contrib = shadow.slot, vtx.path, light.contrib
    bad = 0
    for j in range(a, b):
        if blocked[j]:
            continue
        s = shadow_slot[j]
        bad += add_radiance(
            radiance, s_path[s] - row_offset, l_contrib[s, 0], l_contrib[s, 1], l_contrib[s, 2]
        )
    return bad


@njit(nogil=True, cache=True)
def add_rows(radiance, path, contrib):
    """``radiance[path[j]] += contrib[j]`` for finite rows; returns the number of non-finite rows dropped."""
    bad = 0
    for j in range(path.shape[0]):
        bad += add_radiance(radiance, path[j], contrib[j, 0], contrib[j, 1], contrib[j, 2])
    return bad


@njit(nogil=True, cache=True)
def bsdf_step(wi_l, pdf, f, tb, bb, ns, ng, beta):
    """After a BRDF sample, per row: world direction, validity, and the updated throughput (zero where the
    path ends; :func:`_throughput`)."""
    n = wi_l.shape[0]
    wi = np.empty((n, 3))
    ok = np.zeros(n, dtype=np.bool_)
    out = np.zeros((n, 3))
    for i in range(n):
        wx, wy, wz, br, bg, b_, good = _throughput(
            (wi_l[i, 0], wi_l[i, 1], wi_l[i, 2]), (tb[i, 0], tb[i, 1], tb[i, 2]), (bb[i, 0], bb[i, 1], bb[i, 2]),
            (ns[i, 0], ns[i, 1], ns[i, 2]), (ng[i, 0], ng[i, 1], ng[i, 2]), pdf[i], (f[i, 0], f[i, 1], f[i, 2]),
            (beta[i, 0], beta[i, 1], beta[i, 2]),
        )  # fmt: skip
        wi[i, 0], wi[i, 1], wi[i, 2] = wx, wy, wz
        if good:
            out[i, 0], out[i, 1], out[i, 2] = br, bg, b_
            ok[i] = True
    return wi, ok, out
