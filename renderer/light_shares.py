"""NEE's light-type probabilities (area, point, sky), set by a pilot of camera rays.

With one type present, its probability is 1. With several: at the first hits of :data:`SHARE_PILOT` camera
rays through a coarse grid of pixels, one light sample of each type (the render's own,
:func:`renderer.stages.surface.surface_stage` with that type's share set to 1), its shadow ray traced, and the
estimate a white Lambertian surface makes of it, ``X = lum(L) cos / (pi pdf)`` (0 where occluded); a type's
share is proportional to the square root of ``E[X^2]`` (what minimizes the variance of one sample of a type
chosen at random, ``sum E[X_k^2] / p_k``), at least :data:`SHARE_FLOOR` (a type the pilot happened to miss
keeps samples). Equal shares where the pilot finds nothing. Deterministic (the pilot's numbers come from the
seed); unbiased whatever the shares (MIS reads them).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from core.brdf import LUMINANCE
from renderer.qmc import key
from renderer.stages.camera import camera_rays
from renderer.stages.records import Estimator, Lights, PassKeys, PinholeCamera, Triangles
from renderer.stages.surface import surface_stage
from renderer.wavefront import Buffers
from renderer.world import NO_MATERIAL

if TYPE_CHECKING:
    from renderer.world import World

SHARE_PILOT = 4096
"""Camera rays of the pilot."""
SHARE_FLOOR = 0.1
"""The least probability of a light type present (before renormalizing)."""


def light_shares(
    world: World,
    camera: PinholeCamera,
    tris: Triangles,
    lights: Lights,
    present: tuple[bool, bool, bool],
    seed: int,
    seed_key: np.uint64,
) -> tuple[float, float, float]:
    """The probabilities of the light types (area, point, sky) among those ``present`` (see the module)."""
    k = sum(present)
    if k <= 1:
        return tuple(1.0 if on else 0.0 for on in present)  # type: ignore[return-value]
    moments = light_moments(world, camera, tris, lights, present, seed, seed_key)
    if not np.all(np.isfinite(moments)) or moments.sum() <= 0.0:
        return tuple(1.0 / k if on else 0.0 for on in present)  # type: ignore[return-value]
    w = np.where(present, np.sqrt(moments), 0.0)
    p = np.where(present, np.maximum(w / w.sum(), SHARE_FLOOR), 0.0)
    p /= p.sum()
    return float(p[0]), float(p[1]), float(p[2])


def light_moments(
    world: World,
    camera: PinholeCamera,
    tris: Triangles,
    lights: Lights,
    present: tuple[bool, bool, bool],
    seed: int,
    seed_key: np.uint64,
) -> np.ndarray:
    """``E[X^2]`` per light type over the pilot's vertices (see the module), ``(3,)``: each type's light
    samples are the render's own (``surface_stage`` with that type's share set to 1), their shadow rays traced
    by the render's occlusion query."""
    w = world
    n_pix = camera.width * camera.height
    pix = np.unique(np.linspace(0, n_pix - 1, min(SHARE_PILOT, n_pix)).astype(np.int64))
    rng = np.random.default_rng([seed, 0x5A4E])
    o, d = camera_rays(pix, rng.random((len(pix), 2)), camera)
    hits = w.accel.intersect(o, d)
    keep = hits.prim >= 0
    keep[keep] = w.tri_material[hits.prim[keep]] != NO_MATERIAL
    out = np.zeros(3)
    n = int(np.count_nonzero(keep))
    if n == 0:
        return out
    B = Buffers(n)
    R, H, V, L = B.rays, B.hits, B.vertices, B.light
    R.o[:], R.d[:], R.path[:] = o[keep], d[keep], pix[keep]
    H.t[:], H.bu[:], H.bv[:], H.prim[:] = hits.t[keep], hits.u[keep], hits.v[keep], hits.prim[keep]
    H.mat[:] = w.tri_material[H.prim]
    V.order[:] = np.arange(n)
    R.beta.fill(1.0)
    pilot_key = np.uint64(key(np.uint64(int(seed_key)), np.uint64(0x5A4E)))
    keys = PassKeys(n_pix, 0, pilot_key, pilot_key)
    est = Estimator(power=False, nee=True, ris=False)
    for kind in range(3):
        if not present[kind]:
            continue
        # the type's share 1: its pdf is the type's own
        p = np.eye(3)[kind]
        one = lights.with_shares(p[0], p[1], p[2])
        surface_stage(0, n, 0, keys, est, tris, one, B.rays, B.hits, B.vertices, B.light, B.scratch)
        le = L.le @ LUMINANCE
        ok = L.cand & np.isfinite(le) & np.isfinite(L.pdf)
        x = np.zeros(n)
        if np.any(ok):
            seen = ~w.accel.occluded(V.origin[ok], L.wi[ok], L.tmax[ok])
            rows = np.flatnonzero(ok)[seen]
            x[rows] = le[rows] * L.wi_local[rows, 2] / (np.pi * L.pdf[rows])
        out[kind] = float(np.mean(x * x))
    return out
