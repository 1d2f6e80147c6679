"""The surface stage: the shading frames of a bounce's surface vertices and one light sample each (next-event
estimation: a light type by its share, a light, a point on it)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.jit import kernel
from core.sampling.distributions import upper_bound
from renderer.envmap import env_sample_one
from renderer.qmc import key, pair
from renderer.stages.primitives import BLOCK, PAIR_LIGHT, SOBOL_DEPTH, rescale, tangents


@njit(nogil=True, cache=True)
def tangent_frames(ns):
    """Tangents and bitangents ``(n, 3)`` of the unit normals ``ns (n, 3)`` (:func:`~renderer.stages.primitives.tangents`)."""
    n = ns.shape[0]
    tb = np.empty((n, 3))
    bb = np.empty((n, 3))
    for i in range(n):
        tb[i, 0], tb[i, 1], tb[i, 2], bb[i, 0], bb[i, 1], bb[i, 2] = tangents(ns[i, 0], ns[i, 1], ns[i, 2])
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
    tx, ty, tz, bx, by, bz = tangents(sx, sy, sz)
    return gx, gy, gz, sx, sy, sz, tx, ty, tz, bx, by, bz


@njit(nogil=True, cache=True)
def surface_frames(o, d, t, prim, bu, bv, tris):
    """Hit geometry for rays ``o, d (n, 3)`` hitting triangles ``prim`` of ``tris``
    (:class:`~renderer.stages.records.Triangles`) at distance ``t``: ``ng, ns, tb, bb, wo_local, origin``
    (normals towards the viewer, tangent frame, ``-d`` in it, the hit point pushed off the surface along
    ``ng`` by ``tris.eps``: Embree's tnear is 0)."""
    tri_normal, tri_vnormals, tri_smooth, eps = tris.normal, tris.vnormals, tris.smooth, tris.eps
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
def surface_stage(a, b, depth, keys, est, tris, lights, rays, hits, vtx, light, scratch):
    """Surface vertices ``[a, b)`` of the material-sorted ``vtx.order`` (the rays' ``rays``, their hits
    ``hits``): into ``vtx`` the shading frame's normals, ``wo`` in it, the offset origin (``tris.eps``); into
    ``light`` one light sample when ``est.nee`` (light type by ``lights.c_area``/``lights.c_point``, then a
    light, then a point on it, all from one Owen-scrambled Sobol pair of bounce ``depth``: the choices from
    its first coordinate, rescaled after each, :func:`~renderer.stages.primitives.rescale`). ``vtx.ns``
    holds the shading normal (the frame's tangents are a function of it,
    :func:`~renderer.stages.primitives.tangents`). ``scratch.frames`` holds a block's frames and light
    points. The records are :mod:`renderer.stages.records`'."""
    order, o, d, beta, path = vtx.order, rays.o, rays.d, rays.beta, rays.path
    mat, t, prim, bu, bv = hits.mat, hits.t, hits.prim, hits.bu, hits.bv
    tri_normal, tri_vnormals, tri_smooth, eps = tris.normal, tris.vnormals, tris.smooth, tris.eps
    tri_two_sided, tri_emission = tris.two_sided, tris.emission
    nee, n_pix, first_sample, seed_key = est.nee, keys.n_pix, keys.first_sample, keys.seed_key
    c_area, c_point = lights.c_area, lights.c_point
    p_area, p_point, p_env = lights.p_area, lights.p_point, lights.p_env
    area, point, sky = lights.area, lights.point, lights.sky
    emit_ids, emit_cdf, emit_pmf_per_area = area.ids, area.cdf, area.pmf_per_area
    v0, e1, e2 = area.v0, area.e1, area.e2
    point_pos, point_intensity, point_cdf, point_pmf = point.position, point.intensity, point.cdf, point.pmf
    env_kind, env_radiance, env_row_cdf, env_col_cdf_flat = (
        sky.kind,
        sky.radiance,
        sky.row_cdf,
        sky.col_cdf_flat,
    )
    env_guide, env_edges, env_pmf, env_image, env_rotation = (
        sky.guide,
        sky.edges,
        sky.pmf,
        sky.image,
        sky.rotation,
    )
    s_mat, s_ng, s_ns, s_wo = vtx.mat, vtx.ng, vtx.ns, vtx.wo
    s_origin, s_beta, s_path = vtx.origin, vtx.beta, vtx.path
    l_wi, l_wi_local, l_le, l_pdf = light.wi, light.wi_local, light.le, light.pdf
    l_tmax, l_delta, l_cand = light.tmax, light.delta, light.cand
    frames = scratch.frames
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
                    key(key(seed_key, p % n_pix), PAIR_LIGHT + depth),
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
                ux = rescale(u_type, 0.0, c_area)
                k = min(upper_bound(emit_cdf, 0, emit_cdf.shape[0], ux), n_emit - 1)
                ux = rescale(ux, emit_cdf[k - 1] if k > 0 else 0.0, emit_cdf[k] if k < n_emit - 1 else 1.0)
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
                    upper_bound(point_cdf, 0, point_cdf.shape[0], rescale(u_type, c_area, c_point)),
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
                ux = rescale(u_type, c_point, 1.0)
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
