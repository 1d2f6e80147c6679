"""numba kernels for the per-ray geometry of a bounce (one loop instead of dozens of numpy passes).

These do not depend on the material models, so they compile once and are cached on disk (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(nogil=True, cache=True)
def surface_frames(o, d, t, prim, bu, bv, tri_normal, tri_vnormals, tri_smooth, eps):
    """Hit geometry for rays ``o, d (n, 3)`` hitting triangles ``prim`` at distance ``t`` (barycentrics bu, bv).

    Returns ``ng, ns, tb, bb, wo_local, origin``: the geometric and shading normals turned towards the viewer
    (two-sided surfaces), a tangent frame of ``ns`` (Duff et al. 2017), the outgoing direction ``-d`` in that
    frame, and the hit point pushed off the surface along ``ng`` by ``eps`` (Embree's tnear is 0).
    """
    n = o.shape[0]
    ng = np.empty((n, 3))
    ns = np.empty((n, 3))
    tb = np.empty((n, 3))
    bb = np.empty((n, 3))
    wo_l = np.empty((n, 3))
    origin = np.empty((n, 3))
    for i in range(n):
        k = prim[i]
        gx, gy, gz = tri_normal[k, 0], tri_normal[k, 1], tri_normal[k, 2]
        wx, wy, wz = -d[i, 0], -d[i, 1], -d[i, 2]
        flip = wx * gx + wy * gy + wz * gz < 0.0
        if flip:
            gx, gy, gz = -gx, -gy, -gz
        sx, sy, sz = gx, gy, gz
        if tri_smooth[k]:
            b0 = 1.0 - bu[i] - bv[i]
            vx = b0 * tri_vnormals[k, 0, 0] + bu[i] * tri_vnormals[k, 1, 0] + bv[i] * tri_vnormals[k, 2, 0]
            vy = b0 * tri_vnormals[k, 0, 1] + bu[i] * tri_vnormals[k, 1, 1] + bv[i] * tri_vnormals[k, 2, 1]
            vz = b0 * tri_vnormals[k, 0, 2] + bu[i] * tri_vnormals[k, 1, 2] + bv[i] * tri_vnormals[k, 2, 2]
            length = math.sqrt(vx * vx + vy * vy + vz * vz)
            if length > 0.5:  # interpolated normals of a sane mesh are near unit length
                sx, sy, sz = vx / length, vy / length, vz / length
                if flip:
                    sx, sy, sz = -sx, -sy, -sz
        ng[i, 0], ng[i, 1], ng[i, 2] = gx, gy, gz
        ns[i, 0], ns[i, 1], ns[i, 2] = sx, sy, sz
        sign = 1.0 if sz >= 0.0 else -1.0
        a = -1.0 / (sign + sz)
        c = sx * sy * a
        tb[i, 0], tb[i, 1], tb[i, 2] = 1.0 + sign * sx * sx * a, sign * c, -sign * sx
        bb[i, 0], bb[i, 1], bb[i, 2] = c, sign + sy * sy * a, -sy
        wo_l[i, 0] = wx * tb[i, 0] + wy * tb[i, 1] + wz * tb[i, 2]
        wo_l[i, 1] = wx * bb[i, 0] + wy * bb[i, 1] + wz * bb[i, 2]
        wo_l[i, 2] = wx * sx + wy * sy + wz * sz
        px = o[i, 0] + t[i] * d[i, 0]
        py = o[i, 1] + t[i] * d[i, 1]
        pz = o[i, 2] + t[i] * d[i, 2]
        origin[i, 0], origin[i, 1], origin[i, 2] = px + eps * gx, py + eps * gy, pz + eps * gz
    return ng, ns, tb, bb, wo_l, origin


@njit(nogil=True, cache=True)
def to_local(v, tb, bb, ns):
    """World vectors ``v (n, 3)`` in the per-row frames ``(tb, bb, ns)``."""
    n = v.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        out[i, 0] = v[i, 0] * tb[i, 0] + v[i, 1] * tb[i, 1] + v[i, 2] * tb[i, 2]
        out[i, 1] = v[i, 0] * bb[i, 0] + v[i, 1] * bb[i, 1] + v[i, 2] * bb[i, 2]
        out[i, 2] = v[i, 0] * ns[i, 0] + v[i, 1] * ns[i, 1] + v[i, 2] * ns[i, 2]
    return out


@njit(nogil=True, cache=True)
def bsdf_step(wi_l, pdf, f, tb, bb, ns, ng, beta):
    """After a BRDF sample: world direction, validity, and the updated throughput ``beta * f cos / pdf``.

    A sample is valid when its pdf is positive and finite, ``f`` is finite, and it leaves above both the
    shading and the geometric surface (reflection only). Invalid samples get zero throughput.
    """
    n = wi_l.shape[0]
    wi = np.empty((n, 3))
    ok = np.zeros(n, dtype=np.bool_)
    out = np.zeros((n, 3))
    for i in range(n):
        x, y, z = wi_l[i, 0], wi_l[i, 1], wi_l[i, 2]
        wx = x * tb[i, 0] + y * bb[i, 0] + z * ns[i, 0]
        wy = x * tb[i, 1] + y * bb[i, 1] + z * ns[i, 1]
        wz = x * tb[i, 2] + y * bb[i, 2] + z * ns[i, 2]
        length = math.sqrt(wx * wx + wy * wy + wz * wz)
        if length > 0.0:
            wx, wy, wz = wx / length, wy / length, wz / length
        wi[i, 0], wi[i, 1], wi[i, 2] = wx, wy, wz
        p = pdf[i]
        if not (p > 0.0 and math.isfinite(p) and z > 0.0):
            continue
        if wx * ng[i, 0] + wy * ng[i, 1] + wz * ng[i, 2] <= 0.0:
            continue
        r, g, b = f[i, 0], f[i, 1], f[i, 2]
        if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
            continue
        s = z / p
        out[i, 0] = beta[i, 0] * r * s
        out[i, 1] = beta[i, 1] * g * s
        out[i, 2] = beta[i, 2] * b * s
        ok[i] = out[i, 0] > 0.0 or out[i, 1] > 0.0 or out[i, 2] > 0.0
    return wi, ok, out


@njit(nogil=True, cache=True)
def accumulate(img, pix, contrib):
    """``img[pix[i]] += contrib[i]`` for finite rows; returns the number of non-finite rows skipped."""
    bad = 0
    for i in range(pix.shape[0]):
        r, g, b = contrib[i, 0], contrib[i, 1], contrib[i, 2]
        if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
            bad += 1
            continue
        k = pix[i]
        img[k, 0] += r
        img[k, 1] += g
        img[k, 2] += b
    return bad


@njit(nogil=True, cache=True)
def camera_rays(pixels, jitter, width, height, origin, forward, right, up, tan_half, aspect):
    """Pinhole rays through jittered points of ``pixels`` (row-major, row 0 at the top)."""
    n = pixels.shape[0]
    o = np.empty((n, 3))
    d = np.empty((n, 3))
    for i in range(n):
        row = pixels[i] // width
        col = pixels[i] - row * width
        x = (2.0 * (col + jitter[i, 0]) / width - 1.0) * tan_half * aspect
        y = (1.0 - 2.0 * (row + jitter[i, 1]) / height) * tan_half
        dx = forward[0] + x * right[0] + y * up[0]
        dy = forward[1] + x * right[1] + y * up[1]
        dz = forward[2] + x * right[2] + y * up[2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        o[i, 0], o[i, 1], o[i, 2] = origin[0], origin[1], origin[2]
        d[i, 0], d[i, 1], d[i, 2] = dx / length, dy / length, dz / length
    return o, d


@njit(nogil=True, cache=True)
def sample_lights(
    origin, u, c_area, c_point, emit_ids, emit_cdf, v0, e1, e2, tri_normal, tri_two_sided, tri_emission,
    emit_pmf_per_area, p_area, point_pos, point_intensity, point_cdf, point_pmf, p_point,
):  # fmt: skip
    """One light sample per row for area and point lights (rows that chose the environment are flagged).

    ``u (n, 5)``: ``u[:, 0]`` picks the light type (area below ``c_area``, point below ``c_point``, else the
    environment), ``u[:, 1]`` the light, ``u[:, 2:4]`` the point on a triangle (uniform, by the square-root
    parametrization). Returns directions ``wi``, radiance ``le``, light pdf per solid angle (area pdf times
    ``dist^2 / |cos|``; for point lights the selection probability of a delta light), shadow-ray ``t_max``,
    ``delta`` and ``is_env`` flags.
    """
    n = origin.shape[0]
    wi = np.zeros((n, 3))
    le = np.zeros((n, 3))
    pdf = np.zeros(n)
    t_max = np.full(n, np.inf)
    delta = np.zeros(n, dtype=np.bool_)
    is_env = np.zeros(n, dtype=np.bool_)
    n_emit = emit_ids.shape[0]
    n_point = point_pos.shape[0]
    for i in range(n):
        if u[i, 0] < c_area and n_emit > 0:
            k = min(np.searchsorted(emit_cdf, u[i, 1], side="right"), n_emit - 1)
            tri = emit_ids[k]
            su = math.sqrt(u[i, 2])
            b1 = su * (1.0 - u[i, 3])
            b2 = su * u[i, 3]
            qx = v0[tri, 0] + b1 * e1[tri, 0] + b2 * e2[tri, 0] - origin[i, 0]
            qy = v0[tri, 1] + b1 * e1[tri, 1] + b2 * e2[tri, 1] - origin[i, 1]
            qz = v0[tri, 2] + b1 * e1[tri, 2] + b2 * e2[tri, 2] - origin[i, 2]
            dist = math.sqrt(qx * qx + qy * qy + qz * qz)
            if dist <= 0.0:
                continue
            dx, dy, dz = qx / dist, qy / dist, qz / dist
            cos_l = -(dx * tri_normal[tri, 0] + dy * tri_normal[tri, 1] + dz * tri_normal[tri, 2])
            if not (cos_l > 0.0 or tri_two_sided[tri]) or abs(cos_l) <= 1e-9:
                continue
            wi[i, 0], wi[i, 1], wi[i, 2] = dx, dy, dz
            le[i, 0], le[i, 1], le[i, 2] = tri_emission[tri, 0], tri_emission[tri, 1], tri_emission[tri, 2]
            pdf[i] = p_area * emit_pmf_per_area[tri] * dist * dist / abs(cos_l)
            t_max[i] = dist * (1.0 - 1e-4)
        elif u[i, 0] < c_point and n_point > 0:
            k = min(np.searchsorted(point_cdf, u[i, 1], side="right"), n_point - 1)
            qx = point_pos[k, 0] - origin[i, 0]
            qy = point_pos[k, 1] - origin[i, 1]
            qz = point_pos[k, 2] - origin[i, 2]
            dist = max(math.sqrt(qx * qx + qy * qy + qz * qz), 1e-12)
            wi[i, 0], wi[i, 1], wi[i, 2] = qx / dist, qy / dist, qz / dist
            inv = 1.0 / (dist * dist)
            le[i, 0] = point_intensity[k, 0] * inv
            le[i, 1] = point_intensity[k, 1] * inv
            le[i, 2] = point_intensity[k, 2] * inv
            pdf[i] = p_point * point_pmf[k]
            t_max[i] = dist * (1.0 - 1e-4)
            delta[i] = True
        else:
            is_env[i] = True
    return wi, le, pdf, t_max, delta, is_env


@njit(nogil=True, cache=True)
def light_candidates(pdf_light, wi_l, wi, ng, le):
    """Light samples worth a BRDF evaluation: positive pdf and radiance, above both surfaces."""
    n = pdf_light.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        if pdf_light[i] > 0.0 and wi_l[i, 2] > 0.0 and (le[i, 0] > 0.0 or le[i, 1] > 0.0 or le[i, 2] > 0.0):
            out[i] = wi[i, 0] * ng[i, 0] + wi[i, 1] * ng[i, 1] + wi[i, 2] * ng[i, 2] > 0.0
    return out


@njit(nogil=True, cache=True)
def light_contributions(beta, f, le, pdf_light, pdf_brdf, wi_l, delta, cand, power):
    """``beta f le cos w / pdf_light`` with the MIS weight ``w`` (power or balance heuristic; 1 for delta
    lights); returns the contributions and the rows that still need a shadow ray."""
    n = beta.shape[0]
    out = np.zeros((n, 3))
    need = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        if not cand[i]:
            continue
        pl = pdf_light[i]
        w = 1.0
        if not delta[i]:
            pb = pdf_brdf[i]
            if power:
                s = pl * pl + pb * pb
                w = pl * pl / s if s > 0.0 else 0.0
            else:
                s = pl + pb
                w = pl / s if s > 0.0 else 0.0
        s = wi_l[i, 2] * w / pl
        for c in range(3):
            out[i, c] = beta[i, c] * f[i, c] * le[i, c] * s
        need[i] = out[i, 0] > 0.0 or out[i, 1] > 0.0 or out[i, 2] > 0.0
    return out, need
