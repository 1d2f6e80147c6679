"""Direct light from the sky by resampled importance sampling (Talbot et al. 2005), the path tracer's option
``ris_candidates``: at every surface vertex, ``M`` BRDF samples resampled by ``f cos L`` and one shadow ray."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from core.brdf import LUMINANCE
from renderer.stages.continuation import add_rows, bsdf_step
from renderer.stages.surface import tangent_frames
from renderer.wavefront import Buffers

if TYPE_CHECKING:
    from renderer.world import World


def ris_sky(
    world: World,
    B: Buffers,
    radiance: np.ndarray,
    row_offset: np.int64,
    n_s: int,
    offsets: np.ndarray,
    candidates: int,
    seed_of: Callable[[int], int],
    rng: np.random.Generator,
) -> tuple[int, int]:
    """Direct light from the sky by resampled importance sampling at the ``n_s`` surface vertices:
    ``M`` candidates from the material's sampler, weights ``w_k = p_hat / p`` with ``p_hat = lum(f cos
    L)`` (unoccluded), one kept with probability ``w_k / sum w``; estimate ``f cos L V * mean(w) /
    p_hat(y)`` with one shadow ray. Returns the numbers of non-finite contributions dropped and of shadow
    rays. ``seed_of(m)`` seeds material ``m``'s candidates, ``rng`` picks one."""
    w = world
    m_c = candidates
    n = n_s
    V = B.vertices
    wo_l, origin, ng = V.wo[:n], V.origin[:n], V.ng[:n]
    ns = V.ns[:n]
    tb, bb = tangent_frames(ns)
    wi_l = np.zeros((n * m_c, 3))
    pdf = np.zeros(n * m_c)
    f = np.zeros((n * m_c, 3))
    wo_rep = np.repeat(wo_l, m_c, axis=0)
    for m in range(len(offsets) - 1):
        a, b = int(offsets[m]), int(offsets[m + 1])
        if a == b:
            continue
        rows = slice(a * m_c, b * m_c)
        sampler = w.materials_by_index[m].sampler
        drawn = sampler.sample_each(wo_rep[rows], seed=seed_of(m))
        wi_l[rows], pdf[rows], f[rows] = drawn.wi, drawn.pdf, drawn.f
    rep = (np.repeat(x, m_c, axis=0) for x in (tb, bb, ns, ng))
    wi, ok, fcos_over_p = bsdf_step(wi_l, pdf, f, *rep, np.ones((n * m_c, 3)))
    le = w.env.lookup(wi)[0]
    weight = np.where(ok, (fcos_over_p * le) @ LUMINANCE, 0.0).reshape(n, m_c)  # p_hat / p
    total = weight.sum(axis=1)
    u = rng.random(n)
    pick = np.minimum((np.cumsum(weight, axis=1) <= (u * total)[:, None]).sum(axis=1), m_c - 1)
    chosen = np.arange(n) * m_c + pick
    fcos_le = f[chosen] * wi_l[chosen, 2:3] * le[chosen]
    p_hat = fcos_le @ LUMINANCE
    good = (total > 0) & (p_hat > 0) & ok[chosen]
    i = np.nonzero(good)[0]
    if len(i) == 0:
        return 0, 0
    contrib = V.beta[i] * fcos_le[i] * ((total[i] / m_c) / p_hat[i])[:, None]
    blocked = w.accel.occluded(origin[i], wi[chosen[i]], parallel=False)
    keep = ~blocked
    bad = add_rows(radiance, V.path[i[keep]] - row_offset, np.ascontiguousarray(contrib[keep]))
    return int(bad), len(i)
