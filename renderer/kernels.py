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
