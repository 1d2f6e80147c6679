"""After the closest-hit query: the light of rays that escaped or hit an emitter, and the vertices that go on,
sorted by material."""

from __future__ import annotations

import numpy as np
from numba import njit

from core.jit import kernel
from renderer.envmap import env_eval_one
from renderer.stages.primitives import NO_MATERIAL, add_radiance, mis_weight


@kernel
def hit_stage(a, b, rays, hits, radiance, row_offset, at_last_bounce, est, tris, lights):
    """Rays ``[a, b)`` after the closest-hit query: sky and emitted light (MIS-weighted against the BRDF
    sample that made the ray, whose density is ``rays.prev_pdf``; 0 for camera rays), added to ``radiance``
    row ``path - row_offset``, then ``hits.mat`` = the material index of each ray that goes on
    (``NO_MATERIAL`` for rays that end). Returns the number of non-finite contributions dropped."""
    d, beta, path, prev_pdf = rays.d, rays.beta, rays.path, rays.prev_pdf
    prim, t, mat_out = hits.prim, hits.t, hits.mat
    power, ris, p_env, p_area = est.power, est.ris, lights.p_env, lights.p_area
    tri_normal, tri_material, tri_emission = tris.normal, tris.material, tris.emission
    tri_emissive, tri_two_sided, emit_pmf_per_area = tris.emissive, tris.two_sided, lights.area.pmf_per_area
    sky = lights.sky
    env_kind, env_radiance, env_pmf, env_image, env_rotation, env_edges = (
        sky.kind, sky.radiance, sky.pmf, sky.image, sky.rotation, sky.edges
    )  # fmt: skip
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
                w = 0.0 if ris else mis_weight(prev_pdf[i], p_env * pdf_env, power)
            if w > 0.0:
                bad += add_radiance(
                    radiance, row, beta[i, 0] * r * w, beta[i, 1] * g * w, beta[i, 2] * bl * w
                )
            continue
        if tri_emissive[k]:
            cos_l = -(d[i, 0] * tri_normal[k, 0] + d[i, 1] * tri_normal[k, 1] + d[i, 2] * tri_normal[k, 2])
            if cos_l > 0.0 or tri_two_sided[k]:
                w = 1.0
                if prev_pdf[i] > 0.0:
                    p_light = p_area * emit_pmf_per_area[k] * t[i] * t[i] / max(abs(cos_l), 1e-12)
                    w = mis_weight(prev_pdf[i], p_light, power)
                bad += add_radiance(radiance, row, beta[i, 0] * tri_emission[k, 0] * w,
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
