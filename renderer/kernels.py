"""Compiled stages of the wavefront path tracer (:mod:`renderer.integrator`).

A bounce is six loops over the live paths, each one pass over contiguous arrays with no numpy in between:

1. :func:`camera_stage` (first bounce only): rays through Owen-scrambled Sobol points of each pixel.
2. Embree finds the closest hits (:meth:`renderer.accel.Accel.trace`).
3. :func:`hit_stage`: light from the sky on rays that escaped and from emitters that were hit (both
   MIS-weighted against the BRDF sample that made the ray), and the material of every ray that goes on.
4. :func:`sort_by_material`: the rays that go on, grouped by material (a counting sort), so each material's
   sampler runs once on a contiguous slice; :func:`surface_stage` computes their frames and one light sample
   each (area, point or sky), in that order.
5. The samplers (compiled per strategy, outside this module) evaluate ``f`` and their pdf at the light
   samples and draw the BRDF samples, material by material.
6. :func:`continue_stage`: the light sample's MIS-weighted contribution, the BRDF sample's throughput and
   Russian roulette, and the next bounce's rays and the shadow rays, packed; after Embree's occlusion test
   :func:`shadow_stage` adds the unblocked contributions.

Every stage takes a row range ``[a, b)`` and releases the GIL, so the integrator runs wavefronts on several
threads at once (each wavefront's stages on its thread). The stages allocate nothing (their scratch rows are
the wavefront's, :class:`renderer.wavefront.Buffers`) and are compiled without numba's reference counting
(:func:`core.jit.kernel`): the sky's light sample and lookup, inlined into the loops, took and dropped a
count on each of their arrays per vertex, ~20 % of a pass. Contributions are added to a per-path radiance array
(one row per path; a path belongs to one wavefront), so threads never write the same memory. Random numbers
come from :mod:`renderer.qmc` by key, never from arrays. These kernels do not depend on the material models:
they compile once and are cached.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core import fastmath, merl
from core.dispatch import MERL, MERL_NEAREST, eval_model, pdf_model, sample_model
from core.jit import kernel
from core.models.lobes import cosine_hemisphere_pdf
from core.sampling.distributions import upper_bound
from renderer.envmap import env_eval_one, env_sample_one
from renderer.qmc import key, pair, sobol2, uniform

NO_MATERIAL = -1

# how a material's BRDF samples are drawn: by its sampler object, slice by slice (strategies with tables), or
# here, in compiled code, through the model's dispatch id (strategies without tables)
BY_SAMPLER = 0
UNIFORM = 1
COSINE = 2
ANALYTIC = 3
COMPILED_STRATEGIES = {"uniform": UNIFORM, "cosine": COSINE, "analytic": ANALYTIC}
INV_TWO_PI = 0.15915494309189535
TWO_PI = 2.0 * math.pi
BLOCK = 64
"""Vertices whose random numbers a stage hashes ahead of their loop (:func:`bsdf_stage`), and whose frames
:func:`surface_stage` keeps for their light samples: the rows of the wavefront's scratch arrays."""

# roles of a path vertex's random numbers (the key of a vertex is key(path key, bounce))
_U_RR = 4
_U_LOBE = 5
# pairs of low-discrepancy dimensions: the pixel, the light point at bounce k and the BRDF sample at bounce k
# get their own scrambles
_PAIR_PIXEL = 0
_PAIR_LIGHT = 1
_PAIR_BSDF = 1 << 16
SOBOL_DEPTH = 2
"""Vertices below this bounce draw their light points and their BRDF samples' two warp dimensions from Sobol
pairs; deeper ones from independent uniforms (stratification pays where a pixel's variance comes from: the
first bounces). Every strategy gets the same BRDF points, those with tables too (``Sampler.sample_into``'s
``points``): a renderer built to compare BRDF samplers must not place one strategy's samples better than
another's; how much of the stratification a strategy's warp keeps is its own (a rejection trial keeps it
only when accepted at once)."""


@njit(inline="always", nogil=True, cache=True)
def _mis(a, b, power):
    """Weight of a strategy of density ``a`` against one of density ``b`` (power or balance heuristic)."""
    if power:
        s = a * a + b * b
        return a * a / s if s > 0.0 else 0.0
    s = a + b
    return a / s if s > 0.0 else 0.0


@njit(inline="always", nogil=True, cache=True)
def _rescale(u, lo, hi):
    """Where ``u`` lies in ``[lo, hi)``, as a number of ``[0, 1)``: uniform there when ``u`` is uniform and
    fell in that interval, and as stratified as ``u`` was (one number makes a discrete choice, then a
    continuous one)."""
    if not hi > lo:
        return 0.5
    return min(max((u - lo) / (hi - lo), 0.0), 0.9999999999999999)


@njit(inline="always", nogil=True, cache=True)
def _add(radiance, p, r, g, b):
    """``radiance[p] += (r, g, b)`` for a finite value; returns 1 for a value that was not finite."""
    if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
        return 1
    radiance[p, 0] += r
    radiance[p, 1] += g
    radiance[p, 2] += b
    return 0


@njit(inline="always", nogil=True, cache=True)
def camera_ray(col, row, width, height, origin, forward, right, up, tan_half, aspect):
    """Unit direction of the pinhole ray through image point ``(col, row)`` (pixels, row 0 at the top)."""
    x = (2.0 * col / width - 1.0) * tan_half * aspect
    y = (1.0 - 2.0 * row / height) * tan_half
    dx = forward[0] + x * right[0] + y * up[0]
    dy = forward[1] + x * right[1] + y * up[1]
    dz = forward[2] + x * right[2] + y * up[2]
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / length, dy / length, dz / length


@njit(nogil=True, cache=True)
def camera_rays(pixels, jitter, width, height, origin, forward, right, up, tan_half, aspect):
    """Pinhole rays through jittered points of ``pixels`` (row-major, row 0 at the top)."""
    n = pixels.shape[0]
    o = np.empty((n, 3))
    d = np.empty((n, 3))
    for i in range(n):
        row = pixels[i] // width
        col = pixels[i] - row * width
        d[i, 0], d[i, 1], d[i, 2] = camera_ray(
            col + jitter[i, 0],
            row + jitter[i, 1],
            width,
            height,
            origin,
            forward,
            right,
            up,
            tan_half,
            aspect,
        )
        o[i, 0], o[i, 1], o[i, 2] = origin[0], origin[1], origin[2]
    return o, d


@kernel
def camera_stage(
    a, b, j0, block, step, n_pix, first_sample, seed_key, width, height, origin, forward, right, up, tan_half,
    aspect, o, d, o32, d32, beta, path, prev_pdf,
):  # fmt: skip
    """Camera rays of rows ``[a, b)``: row ``r`` is path ``j = j0 + (r // block) * step + r % block`` (runs of
    ``block`` paths, ``step`` apart: a wavefront interleaved with others; ``block = step`` for consecutive
    paths), sample ``first_sample + j // n_pix`` of pixel ``j % n_pix``, through the pixel's Owen-scrambled
    Sobol point of that sample number. Within a run the pixel, its row and column and the sample number are
    advanced by one path at a time (the integer divisions once a run instead of four a ray)."""
    q = a // block
    off = a - q * block - 1
    pixel = sample = row = col = 0
    for r in range(a, b):
        off += 1
        if off == block:
            q += 1
            off = 0
        j = j0 + q * step + off
        if r == a or off == 0:
            pixel = j % n_pix
            sample = first_sample + j // n_pix
            row = pixel // width
            col = pixel - row * width
        else:
            pixel += 1
            col += 1
            if pixel == n_pix:
                pixel = row = col = 0
                sample += 1
            elif col == width:
                col = 0
                row += 1
        jx, jy = sobol2(sample, key(key(seed_key, pixel), _PAIR_PIXEL))
        dx, dy, dz = camera_ray(
            col + jx, row + jy, width, height, origin, forward, right, up, tan_half, aspect
        )
        o[r, 0], o[r, 1], o[r, 2] = origin[0], origin[1], origin[2]
        d[r, 0], d[r, 1], d[r, 2] = dx, dy, dz
        for c in range(3):
            o32[r, c] = o[r, c]
            d32[r, c] = d[r, c]
            beta[r, c] = 1.0
        path[r] = j
        prev_pdf[r] = 0.0


@kernel
def hit_stage(
    a, b, d, prim, t, beta, path, prev_pdf, radiance, row_offset, mat_out, at_last_bounce, power, p_env, p_area,
    ris, tri_normal, tri_material, tri_emission, tri_emissive, tri_two_sided, emit_pmf_per_area,
    env_kind, env_radiance, env_pmf, env_image, env_rotation, env_edges,
):  # fmt: skip
    """Rays ``[a, b)`` after the closest-hit query: sky and emitted light (MIS-weighted against the BRDF
    sample that made the ray, whose density is ``prev_pdf``; 0 for camera rays), added to ``radiance`` row
    ``path - row_offset``, then ``mat_out`` = the material index of each ray that goes on (``NO_MATERIAL``
    for rays that end). Returns the number of non-finite contributions dropped."""
    bad = 0
    for i in range(a, b):
        mat_out[i] = NO_MATERIAL
        k = prim[i]
        row = path[i] - row_offset
        if k < 0:
            if env_kind == 0:
                continue
            r, g, bl, pdf_env = env_eval_one(env_kind, d[i, 0], d[i, 1], d[i, 2], env_radiance, env_pmf,
                                             env_image, env_rotation, env_edges)  # fmt: skip
            w = 1.0
            if prev_pdf[i] > 0.0:
                w = 0.0 if ris else _mis(prev_pdf[i], p_env * pdf_env, power)
            if w > 0.0:
                bad += _add(radiance, row, beta[i, 0] * r * w, beta[i, 1] * g * w, beta[i, 2] * bl * w)
            continue
        if tri_emissive[k]:
            cos_l = -(d[i, 0] * tri_normal[k, 0] + d[i, 1] * tri_normal[k, 1] + d[i, 2] * tri_normal[k, 2])
            if cos_l > 0.0 or tri_two_sided[k]:
                w = 1.0
                if prev_pdf[i] > 0.0:
                    p_light = p_area * emit_pmf_per_area[k] * t[i] * t[i] / max(abs(cos_l), 1e-12)
                    w = _mis(prev_pdf[i], p_light, power)
                bad += _add(radiance, row, beta[i, 0] * tri_emission[k, 0] * w,
                            beta[i, 1] * tri_emission[k, 1] * w, beta[i, 2] * tri_emission[k, 2] * w)  # fmt: skip
        if not at_last_bounce:
            mat_out[i] = tri_material[k]
    return bad


@njit(nogil=True, cache=True)
def sort_by_material(mat, n_materials, order, offsets):
    """Counting sort of the rays with ``mat >= 0`` by material: ``order[:n]`` their indices grouped by
    material (in ray order within a group), ``offsets (n_materials + 1,)`` each group's start. Returns ``n``."""
    counts = np.zeros(n_materials + 1, dtype=np.int64)
    for i in range(mat.shape[0]):
        if mat[i] >= 0:
            counts[mat[i] + 1] += 1
    for m in range(n_materials):
        counts[m + 1] += counts[m]
    offsets[:] = counts
    fill = counts[:-1].copy()
    for i in range(mat.shape[0]):
        m = mat[i]
        if m >= 0:
            order[fill[m]] = i
            fill[m] += 1
    return counts[n_materials]


@njit(inline="always", nogil=True, cache=True)
def _tangents(sx, sy, sz):
    """Tangent and bitangent of the unit normal ``s`` (Duff et al. 2017): a function of ``s`` alone, so a
    stage that needs the frame recomputes it from the stored normal (the same values bit for bit) instead of
    reading six more numbers a vertex."""
    sign = 1.0 if sz >= 0.0 else -1.0
    q = -1.0 / (sign + sz)
    c = sx * sy * q
    return 1.0 + sign * sx * sx * q, sign * c, -sign * sx, c, sign + sy * sy * q, -sy


@njit(nogil=True, cache=True)
def tangent_frames(ns):
    """Tangents and bitangents ``(n, 3)`` of the unit normals ``ns (n, 3)`` (:func:`_tangents`)."""
    n = ns.shape[0]
    tb = np.empty((n, 3))
    bb = np.empty((n, 3))
    for i in range(n):
        tb[i, 0], tb[i, 1], tb[i, 2], bb[i, 0], bb[i, 1], bb[i, 2] = _tangents(ns[i, 0], ns[i, 1], ns[i, 2])
    return tb, bb


@njit(inline="always", nogil=True, cache=True)
def _shading_frame(k, dx, dy, dz, bu, bv, tri_normal, tri_vnormals, tri_smooth):
    """Geometric and shading normals at a hit of triangle ``k`` (barycentrics ``bu, bv``) turned towards the
    viewer (two-sided surfaces), and a tangent frame of the shading normal (Duff et al. 2017)."""
    gx, gy, gz = tri_normal[k, 0], tri_normal[k, 1], tri_normal[k, 2]
    flip = -(dx * gx + dy * gy + dz * gz) < 0.0
    if flip:
        gx, gy, gz = -gx, -gy, -gz
    sx, sy, sz = gx, gy, gz
    if tri_smooth[k]:
        b0 = 1.0 - bu - bv
        vx = b0 * tri_vnormals[k, 0, 0] + bu * tri_vnormals[k, 1, 0] + bv * tri_vnormals[k, 2, 0]
        vy = b0 * tri_vnormals[k, 0, 1] + bu * tri_vnormals[k, 1, 1] + bv * tri_vnormals[k, 2, 1]
        vz = b0 * tri_vnormals[k, 0, 2] + bu * tri_vnormals[k, 1, 2] + bv * tri_vnormals[k, 2, 2]
        length = math.sqrt(vx * vx + vy * vy + vz * vz)
        if length > 0.5:  # interpolated normals of a sane mesh are near unit length
            sx, sy, sz = vx / length, vy / length, vz / length
            if flip:
                sx, sy, sz = -sx, -sy, -sz
    tx, ty, tz, bx, by, bz = _tangents(sx, sy, sz)
    return gx, gy, gz, sx, sy, sz, tx, ty, tz, bx, by, bz


@njit(nogil=True, cache=True)
def surface_frames(o, d, t, prim, bu, bv, tri_normal, tri_vnormals, tri_smooth, eps):
    """Hit geometry for rays ``o, d (n, 3)`` hitting triangles ``prim`` at distance ``t``: ``ng, ns, tb, bb,
    wo_local, origin`` (normals towards the viewer, tangent frame, ``-d`` in it, the hit point pushed off the
    surface along ``ng`` by ``eps``: Embree's tnear is 0)."""
    n = o.shape[0]
    ng = np.empty((n, 3))
    ns = np.empty((n, 3))
    tb = np.empty((n, 3))
    bb = np.empty((n, 3))
    wo_l = np.empty((n, 3))
    origin = np.empty((n, 3))
    for i in range(n):
        gx, gy, gz, sx, sy, sz, tx, ty, tz, bx, by, bz = _shading_frame(
            prim[i], d[i, 0], d[i, 1], d[i, 2], bu[i], bv[i], tri_normal, tri_vnormals, tri_smooth
        )
        ng[i, 0], ng[i, 1], ng[i, 2] = gx, gy, gz
        ns[i, 0], ns[i, 1], ns[i, 2] = sx, sy, sz
        tb[i, 0], tb[i, 1], tb[i, 2] = tx, ty, tz
        bb[i, 0], bb[i, 1], bb[i, 2] = bx, by, bz
        wo_l[i, 0] = -(d[i, 0] * tx + d[i, 1] * ty + d[i, 2] * tz)
        wo_l[i, 1] = -(d[i, 0] * bx + d[i, 1] * by + d[i, 2] * bz)
        wo_l[i, 2] = -(d[i, 0] * sx + d[i, 1] * sy + d[i, 2] * sz)
        for c in range(3):
            origin[i, c] = o[i, c] + t[i] * d[i, c] + eps * ng[i, c]
    return ng, ns, tb, bb, wo_l, origin


@kernel
def surface_stage(
    a, b, order, mat, o, d, t, prim, bu, bv, beta, path, eps, tri_normal, tri_vnormals, tri_smooth,
    # light sampling
    nee, n_pix, first_sample, seed_key, depth, c_area, c_point, p_area, p_point, p_env,
    emit_ids, emit_cdf, v0, e1, e2, tri_two_sided, tri_emission, emit_pmf_per_area,
    point_pos, point_intensity, point_cdf, point_pmf,
    env_kind, env_radiance, env_row_cdf, env_col_cdf_flat, env_guide, env_edges, env_pmf, env_image, env_rotation,
    # outputs, one row per surface vertex (sorted order)
    s_mat, s_ng, s_ns, s_wo, s_origin, s_beta, s_path, l_wi, l_wi_local, l_le, l_pdf, l_tmax, l_delta,
    l_cand,
    # scratch: (BLOCK, 11), the block's frames and its light samples' Sobol points
    frames,
):  # fmt: skip
    """Surface vertices ``[a, b)`` of the material-sorted ``order``: the shading frame, ``wo`` in it, the
    offset origin, and one light sample (light type by ``c_area``/``c_point``, then a light, then a point
    on it, all from one Owen-scrambled Sobol pair: the choices from its first coordinate, rescaled after
    each, :func:`_rescale`). ``s_ns`` holds the shading normal (the frame's tangents are a
    function of it, :func:`_tangents`); ``l_wi`` the light sample's direction (float32: it only makes the
    shadow ray) and ``l_tmax`` its distance limit (float32, at most 1e30, as Embree takes it). ``l_cand``
    marks light samples worth a BRDF evaluation (positive pdf and radiance, above both surfaces)."""
    n_emit = emit_ids.shape[0]
    n_point = point_pos.shape[0]
    # blocks of BLOCK vertices, each in two short loops (the frames and the light samples' Sobol points, then
    # the light samples from the frames' rows, still in L1): the light sample's long chain of dependent steps
    # overlaps across vertices there, and the points' hashes do in the first loop (a tenth less CPU in a
    # cosine pass's surface stage than one loop over the vertices)
    for s0 in range(a, b, BLOCK):
        s1 = min(b, s0 + BLOCK)
        for s in range(s0, s1):
            i = order[s]
            gx, gy, gz, sx, sy, sz, tx, ty, tz, bx, by, bz = _shading_frame(
                prim[i], d[i, 0], d[i, 1], d[i, 2], bu[i], bv[i], tri_normal, tri_vnormals, tri_smooth
            )
            s_ng[s, 0], s_ng[s, 1], s_ng[s, 2] = gx, gy, gz
            s_ns[s, 0], s_ns[s, 1], s_ns[s, 2] = sx, sy, sz
            fb = frames[s - s0]
            fb[0], fb[1], fb[2], fb[3], fb[4], fb[5], fb[6], fb[7], fb[8] = tx, ty, tz, bx, by, bz, sx, sy, sz
            p = path[i]
            if nee:
                fb[9], fb[10] = pair(
                    first_sample + p // n_pix,
                    key(key(seed_key, p % n_pix), _PAIR_LIGHT + depth),
                    depth < SOBOL_DEPTH,
                )
            s_wo[s, 0] = -(d[i, 0] * tx + d[i, 1] * ty + d[i, 2] * tz)
            s_wo[s, 1] = -(d[i, 0] * bx + d[i, 1] * by + d[i, 2] * bz)
            s_wo[s, 2] = -(d[i, 0] * sx + d[i, 1] * sy + d[i, 2] * sz)
            px = o[i, 0] + t[i] * d[i, 0] + eps * gx
            py = o[i, 1] + t[i] * d[i, 1] + eps * gy
            pz = o[i, 2] + t[i] * d[i, 2] + eps * gz
            s_origin[s, 0], s_origin[s, 1], s_origin[s, 2] = px, py, pz
            s_path[s] = p
            s_mat[s] = mat[i]
            for c in range(3):
                s_beta[s, c] = beta[i, c]
            l_cand[s] = False
            l_delta[s] = False
            l_pdf[s] = 0.0
        if not nee:
            continue
        for s in range(s0, s1):
            # ---- one light sample
            p = s_path[s]
            px, py, pz = s_origin[s, 0], s_origin[s, 1], s_origin[s, 2]
            gx, gy, gz = s_ng[s, 0], s_ng[s, 1], s_ng[s, 2]
            fb = frames[s - s0]
            tx, ty, tz, bx, by, bz, sx, sy, sz = fb[0], fb[1], fb[2], fb[3], fb[4], fb[5], fb[6], fb[7], fb[8]
            ux, uy = fb[9], fb[10]
            wx, wy, wz = 0.0, 0.0, 1.0
            lr, lg, lb = 0.0, 0.0, 0.0
            pdf = 0.0
            t_max = np.inf
            # the light type, then the light, from the point's first coordinate, each choice rescaling it to
            # what is left inside the chosen interval: a pixel's samples split between the types (and the
            # lights) in proportion, and each type's share is still spread over its lights' surfaces
            u_type = ux
            if u_type < c_area and n_emit > 0:
                ux = _rescale(u_type, 0.0, c_area)
                k = min(upper_bound(emit_cdf, 0, emit_cdf.shape[0], ux), n_emit - 1)
                ux = _rescale(ux, emit_cdf[k - 1] if k > 0 else 0.0, emit_cdf[k] if k < n_emit - 1 else 1.0)
                tri = emit_ids[k]
                su = math.sqrt(ux)
                b1 = su * (1.0 - uy)
                b2 = su * uy
                qx = v0[tri, 0] + b1 * e1[tri, 0] + b2 * e2[tri, 0] - px
                qy = v0[tri, 1] + b1 * e1[tri, 1] + b2 * e2[tri, 1] - py
                qz = v0[tri, 2] + b1 * e1[tri, 2] + b2 * e2[tri, 2] - pz
                dist = math.sqrt(qx * qx + qy * qy + qz * qz)
                if dist > 0.0:
                    wx, wy, wz = qx / dist, qy / dist, qz / dist
                    cos_l = -(wx * tri_normal[tri, 0] + wy * tri_normal[tri, 1] + wz * tri_normal[tri, 2])
                    if (cos_l > 0.0 or tri_two_sided[tri]) and abs(cos_l) > 1e-9:
                        lr, lg, lb = tri_emission[tri, 0], tri_emission[tri, 1], tri_emission[tri, 2]
                        pdf = p_area * emit_pmf_per_area[tri] * dist * dist / abs(cos_l)
                        t_max = dist * (1.0 - 1e-4)
            elif u_type < c_point and n_point > 0:
                k = min(
                    upper_bound(point_cdf, 0, point_cdf.shape[0], _rescale(u_type, c_area, c_point)),
                    n_point - 1,
                )
                qx, qy, qz = point_pos[k, 0] - px, point_pos[k, 1] - py, point_pos[k, 2] - pz
                dist = max(math.sqrt(qx * qx + qy * qy + qz * qz), 1e-12)
                wx, wy, wz = qx / dist, qy / dist, qz / dist
                inv = 1.0 / (dist * dist)
                lr, lg, lb = (
                    point_intensity[k, 0] * inv,
                    point_intensity[k, 1] * inv,
                    point_intensity[k, 2] * inv,
                )
                pdf = p_point * point_pmf[k]
                t_max = dist * (1.0 - 1e-4)
                l_delta[s] = True
            elif env_kind != 0 and p_env > 0.0:
                ux = _rescale(u_type, c_point, 1.0)
                wx, wy, wz, lr, lg, lb, pdf_e = env_sample_one(
                    env_kind, ux, uy, env_radiance, env_row_cdf, env_col_cdf_flat, env_guide, env_pmf, env_image,
                    env_rotation, env_edges,
                )  # fmt: skip
                pdf = p_env * pdf_e
            l_wi[s, 0], l_wi[s, 1], l_wi[s, 2] = wx, wy, wz
            lz = wx * sx + wy * sy + wz * sz
            l_wi_local[s, 0] = wx * tx + wy * ty + wz * tz
            l_wi_local[s, 1] = wx * bx + wy * by + wz * bz
            l_wi_local[s, 2] = lz
            l_le[s, 0], l_le[s, 1], l_le[s, 2] = lr, lg, lb
            l_pdf[s] = pdf
            l_tmax[s] = min(t_max, 1e30)
            if pdf > 0.0 and lz > 0.0 and (lr > 0.0 or lg > 0.0 or lb > 0.0):
                l_cand[s] = wx * gx + wy * gy + wz * gz > 0.0


@njit(inline="always", nogil=True, cache=True)
def _cosine_hemisphere(u1, u2):
    """:func:`core.models.lobes.cosine_hemisphere` (Malley's method) with the azimuth's sine and cosine from
    :func:`core.fastmath.sin_cos`."""
    r = math.sqrt(u1)
    sn, cs = fastmath.sin_cos(TWO_PI * u2)
    return r * cs, r * sn, math.sqrt(max(0.0, 1.0 - u1))


@njit(inline="always", nogil=True, cache=True)
def _uniform_hemisphere(u1, u2):
    """:func:`core.models.lobes.uniform_hemisphere` with the azimuth's sine and cosine from
    :func:`core.fastmath.sin_cos`."""
    r = math.sqrt(max(0.0, 1.0 - u1 * u1))
    sn, cs = fastmath.sin_cos(TWO_PI * u2)
    return r * cs, r * sn, u1


@njit(inline="always", nogil=True, cache=True)
def _eval(mid, wi, wo, prm, table):
    """``eval_model(mid, wi, wo, prm)``, except that a MERL material's table is read from ``table``, its
    float32 copy: a 35 MB float64 table read at random points misses the cache far more often than the
    17.5 MB copy (490 against 350 ns an evaluation; the values differ by float32 rounding,
    ~6e-8 relative)."""
    if mid == MERL:
        r, g, b = merl.eval_merl(wi, wo, table)
    elif mid == MERL_NEAREST:
        r, g, b = merl.eval_merl_nearest(wi, wo, table)
    else:
        r, g, b = eval_model(mid, wi, wo, prm)
    return r, g, b


@njit(inline="always", nogil=True, cache=True)
def _bsdf_pair(p, n_pix, first_sample, seed_key, depth):
    """The two uniforms of path ``p``'s BRDF sample at bounce ``depth``: an Owen-scrambled Sobol point of
    the pixel's sample number below ``SOBOL_DEPTH``, deeper two independent hashes. Every strategy gets the
    same ones (:func:`bsdf_stage`; :func:`bsdf_points` for the strategies with tables)."""
    return pair(
        first_sample + p // n_pix, key(key(seed_key, p % n_pix), _PAIR_BSDF + depth), depth < SOBOL_DEPTH
    )


@njit(nogil=True, cache=True)
def bsdf_points(a, b, n_pix, first_sample, seed_key, depth, s_path, out):
    """``out[s]`` = the BRDF sample's two uniforms (:func:`_bsdf_pair`) of surface vertices ``[a, b)``: what
    a strategy with tables reads for its warp (``Sampler.sample_into``'s ``points``)."""
    for s in range(a, b):
        out[s, 0], out[s, 1] = _bsdf_pair(s_path[s], n_pix, first_sample, seed_key, depth)


@kernel
def bsdf_stage(
    a, b, n_pix, first_sample, seed_key, pass_key, depth, nee, mat_strategy, mat_model, mat_params, mat_tables,
    s_mat, s_path, s_wo, l_wi_local, l_cand, l_f, l_pdf_brdf, wi_local, pdf, f, blk, mcell, mfrac,
):  # fmt: skip
    """For the surface vertices ``[a, b)`` whose material's strategy has no tables (``mat_strategy[m]`` is
    ``UNIFORM``, ``COSINE`` or ``ANALYTIC``; ``BY_SAMPLER`` rows are left to their sampler objects): ``f``
    and the strategy's pdf at the light sample (if a candidate), and one BRDF sample with ``f`` there, the
    model reached by its dispatch id ``mat_model[m]`` with parameters ``mat_params[m]`` (MERL tables:
    ``mat_tables[m]``, float32; see :func:`_eval`), from :func:`_bsdf_pair`'s uniforms (as every strategy's).

    The uniforms of a block of ``BLOCK`` vertices are hashed first, in a loop of their own: there the hashes
    of independent paths overlap, where inside the long loop each vertex's chain of hashes would wait for the
    previous vertex's evaluations (68 ns a Lambert vertex in isolation instead of 81; the same numbers).

    A measured (MERL) material's lookups are deferred to the block's end (:func:`core.merl.find_cell`): the cells of
    its light and BRDF samples are found in the long loop, their corners read in a short loop of their own,
    then summed (:func:`core.merl.eval_merl_rows` explains why; the same values). ``mcell (BLOCK, 2, 3)`` int64
    and ``mfrac (BLOCK, 2, 3)`` are the cells' scratch (slot 0 the light sample's, 1 the BRDF sample's)."""
    touched = 0.0
    for s0 in range(a, b, BLOCK):
        s1 = min(b, s0 + BLOCK)
        deferred = 0
        for s in range(s0, s1):
            mcell[s - s0, 0, 0] = -1
            mcell[s - s0, 1, 0] = -1
            kind = mat_strategy[s_mat[s]]
            if kind == BY_SAMPLER:
                continue
            p = s_path[s]
            blk[s - s0, 0], blk[s - s0, 1] = _bsdf_pair(p, n_pix, first_sample, seed_key, depth)
            if kind == ANALYTIC:
                blk[s - s0, 2] = uniform(key(key(pass_key, p), depth), _U_LOBE)
        for s in range(s0, s1):
            m = s_mat[s]
            kind = mat_strategy[m]
            if kind == BY_SAMPLER:
                continue
            mid = mat_model[m]
            prm = mat_params[m]
            table = mat_tables[m]
            wo = (s_wo[s, 0], s_wo[s, 1], s_wo[s, 2])
            if nee and l_cand[s]:
                wi = (l_wi_local[s, 0], l_wi_local[s, 1], l_wi_local[s, 2])
                if mid == MERL:
                    merl.find_cell(wi, wo, table, mcell[s - s0, 0], mfrac[s - s0, 0])
                    deferred += 1
                else:
                    l_f[s, 0], l_f[s, 1], l_f[s, 2] = _eval(mid, wi, wo, prm, table)
                if kind == UNIFORM:
                    l_pdf_brdf[s] = INV_TWO_PI if wi[2] >= 0.0 else 0.0
                elif kind == COSINE:
                    l_pdf_brdf[s] = cosine_hemisphere_pdf(wi[2])
                else:
                    l_pdf_brdf[s] = pdf_model(mid, wo, wi, prm)
            u1, u2 = blk[s - s0, 0], blk[s - s0, 1]
            if kind == UNIFORM:
                x, y, z = _uniform_hemisphere(u1, u2)
                q = INV_TWO_PI
            elif kind == COSINE:
                x, y, z = _cosine_hemisphere(u1, u2)
                q = cosine_hemisphere_pdf(z)
            else:
                x, y, z, q = sample_model(mid, wo, prm, u1, u2, blk[s - s0, 2])
            wi_local[s, 0], wi_local[s, 1], wi_local[s, 2] = x, y, z
            pdf[s] = q
            if q > 0.0 and mid == MERL:
                merl.find_cell((x, y, z), wo, table, mcell[s - s0, 1], mfrac[s - s0, 1])
                deferred += 1
            elif q > 0.0:
                f[s, 0], f[s, 1], f[s, 2] = _eval(mid, (x, y, z), wo, prm, table)
            else:
                f[s, 0], f[s, 1], f[s, 2] = 0.0, 0.0, 0.0
        if deferred == 0:
            continue
        for r in range(s1 - s0):  # the deferred lookups' corners, read with the whole block's in flight
            for slot in range(2):
                touched += merl.read_ahead(mat_tables[s_mat[s0 + r]], mcell[r, slot])
        for r in range(s1 - s0):
            for slot in range(2):
                if mcell[r, slot, 0] == -1:
                    continue
                out = l_f if slot == 0 else f
                out[s0 + r, 0], out[s0 + r, 1], out[s0 + r, 2] = merl.cell_value(
                    mat_tables[s_mat[s0 + r]], mcell[r, slot], mfrac[r, slot]
                )
    mfrac[0, 0, 0] = touched  # (the reads' sum, stored: not a dead computation to the compiler)


@njit(inline="always", nogil=True, cache=True)
def _throughput(x, y, z, tx, ty, tz, bx, by, bz, sx, sy, sz, gx, gy, gz, p, r, g, b, beta_r, beta_g, beta_b):
    """A BRDF sample ``(x, y, z)`` of the frame ``(t, b, s)`` with density ``p`` and value ``(r, g, b)``: its
    unit world direction, the throughput ``beta f cos / p`` and whether the path goes on (the pdf positive and
    finite, ``f`` finite, the direction above both the shading and the geometric surface ``g``: reflection
    only, and some throughput left)."""
    wx = x * tx + y * bx + z * sx
    wy = x * ty + y * by + z * sy
    wz = x * tz + y * bz + z * sz
    length = math.sqrt(wx * wx + wy * wy + wz * wz)
    if length > 0.0:
        wx, wy, wz = wx / length, wy / length, wz / length
    if not (p > 0.0 and math.isfinite(p) and z > 0.0) or wx * gx + wy * gy + wz * gz <= 0.0:
        return wx, wy, wz, 0.0, 0.0, 0.0, False
    if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
        return wx, wy, wz, 0.0, 0.0, 0.0, False
    sc = z / p
    br, bg, bb = beta_r * r * sc, beta_g * g * sc, beta_b * b * sc
    return wx, wy, wz, br, bg, bb, br > 0.0 or bg > 0.0 or bb > 0.0


@kernel
def continue_stage(
    a, b, power, rr, rr_key, s_ng, s_ns, s_beta, s_path, s_origin, l_wi, l_wi_local, l_le, l_pdf, l_tmax, l_delta,
    l_cand, l_f, l_pdf_brdf, wi_local, pdf, f, l_contrib, o, d, o32, d32, beta, path, prev_pdf, so32, sd32, st32,
    shadow_slot, counts,
):  # fmt: skip
    """Surface vertices ``[a, b)`` after their samplers ran: the light sample's contribution ``beta f L cos
    w / pdf_light`` (MIS weight ``w`` against the sampler's density; 1 for delta lights) and, if it carries
    light, its shadow ray; the BRDF sample's world direction and throughput (:func:`_throughput`), then Russian
    roulette when ``rr`` (survival ``min(0.95, max beta)``, a uniform keyed by ``rr_key`` and the path), and
    the next bounce's ray of a path that goes on. Rays and shadow rays are packed in the vertices' order from
    rows ``counts[0]`` and ``counts[1]`` of their arrays (the rows the vertices before ``a`` took), and
    ``counts`` is advanced past them. The rays' arrays may be the ones the vertices were made from: a vertex
    reads only its own rows (``s_*``, ``l_*``) and writes row ``m <= s``."""
    m = counts[0]
    k = counts[1]
    for s in range(a, b):
        # ---- the light sample, and its shadow ray
        if l_cand[s]:
            pl = l_pdf[s]
            w = 1.0 if l_delta[s] else _mis(pl, l_pdf_brdf[s], power)
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
        tx, ty, tz, bx, by, bz = _tangents(sx, sy, sz)
        wx, wy, wz, br, bg, bb, ok = _throughput(
            wi_local[s, 0], wi_local[s, 1], wi_local[s, 2], tx, ty, tz, bx, by, bz, sx, sy, sz,
            s_ng[s, 0], s_ng[s, 1], s_ng[s, 2], pdf[s], f[s, 0], f[s, 1], f[s, 2], s_beta[s, 0], s_beta[s, 1],
            s_beta[s, 2],
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
def shadow_stage(a, b, blocked, shadow_slot, s_path, l_contrib, radiance, row_offset):
    """Add the contributions of the shadow rays ``[a, b)`` that nothing blocked to ``radiance`` row ``path -
    row_offset``; returns the number of non-finite ones dropped."""
    bad = 0
    for j in range(a, b):
        if blocked[j]:
            continue
        s = shadow_slot[j]
        bad += _add(radiance, s_path[s] - row_offset, l_contrib[s, 0], l_contrib[s, 1], l_contrib[s, 2])
    return bad


@njit(nogil=True, cache=True)
def add_rows(radiance, path, contrib):
    """``radiance[path[j]] += contrib[j]`` for finite rows; returns the number of non-finite rows dropped."""
    bad = 0
    for j in range(path.shape[0]):
        bad += _add(radiance, path[j], contrib[j, 0], contrib[j, 1], contrib[j, 2])
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
            wi_l[i, 0], wi_l[i, 1], wi_l[i, 2], tb[i, 0], tb[i, 1], tb[i, 2], bb[i, 0], bb[i, 1], bb[i, 2],
            ns[i, 0], ns[i, 1], ns[i, 2], ng[i, 0], ng[i, 1], ng[i, 2], pdf[i], f[i, 0], f[i, 1], f[i, 2],
            beta[i, 0], beta[i, 1], beta[i, 2],
        )  # fmt: skip
        wi[i, 0], wi[i, 1], wi[i, 2] = wx, wy, wz
        if good:
            out[i, 0], out[i, 1], out[i, 2] = br, bg, b_
            ok[i] = True
    return wi, ok, out
