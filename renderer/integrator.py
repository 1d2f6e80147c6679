"""Wavefront path tracing: a pass traces a batch of paths per pixel, all advancing bounce by bounce.

Per bounce: intersect every live ray (Embree, batched over threads); add environment or emitted radiance
(MIS-weighted against light sampling); at each hit, next-event estimation (one light sample, shadow ray,
MIS-weighted against BRDF sampling), then a BRDF sample from the material's chosen strategy; Russian
roulette after ``rr_depth`` bounces. Rays are grouped by material so each group's sampler (whose draws carry
``f`` with them) and BRDF run on contiguous arrays, one compiled loop per group with the model's id fixed
(:mod:`core.dispatch`).

NEE picks a light type with equal shares among those present (area, point, sky), then a light (emissive
triangles by area x luminance, point lights by luminance). MIS uses the exact densities: the light density
(area pdf converted to solid angle, environment-map pdf, uniform sphere for a constant sky) and the sampler's
``pdf(wo, wi)``; point lights are delta lights (no MIS). Optionally (``ris_candidates``) the sky's direct light
comes from resampled importance sampling instead. Reflection only: a direction below the geometric surface
carries nothing (no transmission).

Randomness: every draw comes from generators keyed by ``(seed, pass, bounce, role)``, so the same seed gives
the same image, whatever the thread timing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.model import LUMINANCE
from core.scene import Scene
from renderer.kernels import (
    accumulate,
    bsdf_step,
    camera_rays,
    light_candidates,
    light_contributions,
    sample_lights,
    surface_frames,
    to_local,
)
from renderer.world import NO_MATERIAL, World

PARALLEL_MIN = 65536
"""Batches larger than this evaluate BRDFs on all cores (numba prange); smaller ones stay serial, where the
thread start-up would cost more than it saves."""


@dataclass
class PassStats:
    paths: int = 0
    rays: int = 0
    nonfinite: int = 0
    """Path contributions that were NaN or infinite (dropped; 0 in a correct renderer)."""


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def mis_weight(pdf_a: np.ndarray, pdf_b: np.ndarray, heuristic: str) -> np.ndarray:
    """Weight of strategy a against b: balance ``a / (a + b)`` or power ``a^2 / (a^2 + b^2)``."""
    if heuristic == "power":
        a2, b2 = pdf_a * pdf_a, pdf_b * pdf_b
        s = a2 + b2
        return np.where(s > 0, a2 / np.where(s > 0, s, 1.0), 0.0)
    s = pdf_a + pdf_b
    return np.where(s > 0, pdf_a / np.where(s > 0, s, 1.0), 0.0)


class Camera:
    """Pinhole camera rays for pixel indices (row-major, row 0 at the top)."""

    def __init__(self, scene: Scene, width: int, height: int):
        cam = scene.camera
        self.width, self.height = width, height
        self.origin = np.asarray(cam.position, dtype=np.float64)
        fwd = np.asarray(cam.target, dtype=np.float64) - self.origin
        self.forward = fwd / np.linalg.norm(fwd)
        right = np.cross(self.forward, np.asarray(cam.up, dtype=np.float64))
        self.right = right / np.linalg.norm(right)
        self.up = np.cross(self.right, self.forward)
        self.tan_half = np.tan(np.radians(cam.fov_deg) / 2.0)
        self.aspect = width / height

    def rays(self, pixels: np.ndarray, jitter: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return camera_rays(
            pixels, jitter, self.width, self.height, self.origin, self.forward, self.right, self.up,
            float(self.tan_half), float(self.aspect),
        )  # fmt: skip


class PathTracer:
    """Renders passes of one sample per pixel for a compiled :class:`World`."""

    def __init__(
        self,
        world: World,
        width: int,
        height: int,
        max_depth: int,
        rr_depth: int,
        mis: str,
        seed: int,
        ris_candidates: int = 0,
    ):
        self.world = world
        # RIS (Talbot et al. 2005) for the environment: with M > 0 candidates, direct light from the sky comes
        # from resampling M BRDF samples by f cos L (one shadow ray); the sky then leaves the light-type choice
        # of NEE, and BRDF-sampled rays that escape after a bounce add no sky radiance (no double counting).
        self.ris = int(ris_candidates) if world.env is not None else 0
        shares = [len(world.emit_ids) > 0, len(world.point_pos) > 0, world.env is not None and not self.ris]
        k = sum(shares)
        self.p_area, self.p_point, self.p_env = (
            ((1.0 / k if on else 0.0) for on in shares) if k else (0.0,) * 3
        )
        self.has_nee_lights = k > 0
        self.camera = Camera(world.scene, width, height)
        self.width, self.height = width, height
        self.max_depth = max_depth
        self.rr_depth = rr_depth
        self.mis = mis
        self.seed = seed
        self.stats = PassStats()

    def _rng(self, pass_index: int, depth: int, role: int) -> np.random.Generator:
        return np.random.default_rng([self.seed, pass_index, depth + 1, role])

    def _seed(self, pass_index: int, depth: int, material: int) -> int:
        ss = np.random.SeedSequence([self.seed, pass_index, depth + 1, material, 0x5A])
        return int(ss.generate_state(1, dtype=np.uint32)[0])

    def _add(self, img: np.ndarray, pix: np.ndarray, contrib: np.ndarray) -> None:
        """Add ``contrib (k, 3)`` to pixels ``pix (k,)`` (several paths may share a pixel)."""
        self.stats.nonfinite += accumulate(img, pix, np.ascontiguousarray(contrib))

    # ------------------------------------------------------------------------------------------ warm-up
    def incident_directions(self, max_paths: int = 8192, bounces: int = 2) -> dict[int, np.ndarray]:
        """Outgoing directions (local frame) the scene presents to each material, from a small pre-pass:
        camera rays through a coarse pixel grid, then cosine-sampled bounces. A sampler that builds tables
        lazily (per incident-angle bin) gets them built for these directions before the first pass."""
        w = self.world
        n_pix = self.width * self.height
        pix = np.unique(np.linspace(0, n_pix - 1, min(max_paths, n_pix)).astype(np.int64))
        rng = np.random.default_rng([self.seed, 0x3A3A])
        o, d = self.camera.rays(pix, rng.random((len(pix), 2)))
        found: dict[int, list[np.ndarray]] = {}
        for _ in range(bounces):
            if len(o) == 0:
                break
            hits = w.accel.intersect(o, d)
            keep = hits.prim >= 0
            prim = hits.prim[keep]
            mat = w.tri_material[prim]
            live = mat != NO_MATERIAL
            o, d, t, bu, bv = (x[keep][live] for x in (o, d, hits.t, hits.u, hits.v))
            prim, mat = prim[live], mat[live]
            if len(o) == 0:
                break
            ng, ns, tb, bb, wo_l, origin = surface_frames(
                o, d, t, prim, bu, bv, w.tri_normal, w.tri_vnormals, w.tri_smooth, w.eps
            )
            for m in np.unique(mat):
                found.setdefault(int(m), []).append(wo_l[mat == m])
            u = rng.random((len(o), 2))
            r = np.sqrt(u[:, 0])
            wi_l = np.stack([r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1]),
                             np.sqrt(np.maximum(0.0, 1.0 - u[:, 0]))], axis=1)  # fmt: skip
            pdf = np.full(len(o), 1.0)
            wi, ok, _ = bsdf_step(wi_l, pdf, np.ones((len(o), 3)), tb, bb, ns, ng, np.ones((len(o), 3)))
            o, d = origin[ok], wi[ok]
        return {m: np.concatenate(v) for m, v in found.items()}

    # ------------------------------------------------------------------------------------------ a pass
    def render_pass(self, pass_index: int, spp: int = 1) -> np.ndarray:
        """``spp`` samples per pixel traced together; returns their mean per pixel, ``(height * width, 3)``.

        Passes with different ``pass_index`` are independent (their random numbers are keyed by it).
        """
        w = self.world
        n_pix = self.width * self.height
        img = np.zeros((n_pix, 3))
        pix = np.tile(np.arange(n_pix), int(spp))
        n_paths = len(pix)
        rng = self._rng(pass_index, -1, 0)
        o, d = self.camera.rays(pix, rng.random((n_paths, 2)))
        beta = np.ones((n_paths, 3))
        prev_pdf = np.zeros(n_paths)  # density of the BRDF sample that made the ray; 0 for camera rays
        self.stats.paths += n_paths

        for depth in range(self.max_depth + 1):
            if len(o) == 0:
                break
            hits = w.accel.intersect(o, d)
            self.stats.rays += len(o)
            miss = hits.prim < 0

            # ---- light from infinity on rays that escape
            if w.env is not None and np.any(miss):
                i = np.nonzero(miss)[0]
                le, p_env = w.env.lookup(d[i])
                wgt = np.ones(len(i))
                bs = prev_pdf[i] > 0
                if np.any(bs):
                    if self.ris:
                        wgt[bs] = 0.0  # the sky's direct light was resampled at the previous vertex
                    else:
                        wgt[bs] = mis_weight(prev_pdf[i[bs]], self.p_env * p_env[bs], self.mis)
                self._add(img, pix[i], beta[i] * le * wgt[:, None])

            keep = ~miss
            o, d, beta, pix, prev_pdf = o[keep], d[keep], beta[keep], pix[keep], prev_pdf[keep]
            t, prim, bu, bv = hits.t[keep], hits.prim[keep], hits.u[keep], hits.v[keep]
            if len(o) == 0:
                break
            ng = w.tri_normal[prim]

            # ---- emitted light on rays that hit an emitter
            em = w.tri_emissive[prim]
            if np.any(em):
                i = np.nonzero(em)[0]
                cos_l = -_dot(d[i], ng[i])
                front = (cos_l > 0) | w.tri_two_sided[prim[i]]
                le = w.tri_emission[prim[i]] * front[:, None]
                wgt = np.ones(len(i))
                bs = prev_pdf[i] > 0
                if np.any(bs):
                    j = i[bs]
                    p_light = (
                        self.p_area
                        * w.emit_pmf_per_area[prim[j]]
                        * t[j] ** 2
                        / np.maximum(np.abs(cos_l[bs]), 1e-12)
                    )
                    wgt[bs] = mis_weight(prev_pdf[j], p_light, self.mis)
                self._add(img, pix[i], beta[i] * le * wgt[:, None])

            if depth == self.max_depth:
                break

            # ---- surfaces that reflect: frames with both normals facing the viewer (two-sided surfaces)
            mat = w.tri_material[prim]
            live = mat != NO_MATERIAL
            if not np.all(live):
                o, d, t, beta, pix, prim, mat, bu, bv = (
                    x[live] for x in (o, d, t, beta, pix, prim, mat, bu, bv)
                )
            n = len(o)
            if n == 0:
                break
            ng, ns, tb, bb, wo_l, origin = surface_frames(
                o, d, t, prim, bu, bv, w.tri_normal, w.tri_vnormals, w.tri_smooth, w.eps
            )
            groups = [(m, np.nonzero(mat == m)[0]) for m in np.unique(mat)]

            # ---- next-event estimation
            if self.has_nee_lights:
                self._next_event(img, pass_index, depth, origin, ng, wo_l, (tb, bb, ns), beta, pix, groups)
            if self.ris:
                self._ris_environment(
                    img, pass_index, depth, origin, ng, wo_l, (tb, bb, ns), beta, pix, groups
                )

            # ---- BRDF sampling with the chosen strategy, material by material
            wi_l = np.zeros((n, 3))
            pdf = np.zeros(n)
            f = np.zeros((n, 3))
            for m, idx in groups:
                rt = w.materials_by_index[m]
                drawn = rt.sampler.sample_each(wo_l[idx], seed=self._seed(pass_index, depth, int(m)))
                wi_l[idx] = drawn.wi
                pdf[idx] = drawn.pdf
                f[idx] = drawn.f
            wi, ok, beta = bsdf_step(wi_l, pdf, f, tb, bb, ns, ng, beta)

            # ---- Russian roulette
            if depth + 1 >= self.rr_depth:
                q = np.minimum(0.95, beta.max(axis=1))
                u = self._rng(pass_index, depth, 3).random(n)
                survive = u < q
                beta = beta / np.where(q > 0, q, 1.0)[:, None]
                ok &= survive
            o, d, beta, pix, prev_pdf = origin[ok], wi[ok], beta[ok], pix[ok], pdf[ok]

        return img / spp

    def _next_event(self, img, pass_index, depth, origin, ng, wo_l, frame, beta, pix, groups) -> None:  # type: ignore[no-untyped-def]
        """One light sample per path vertex, MIS-weighted against the BRDF sampler (exact pdfs)."""
        w = self.world
        n = len(origin)
        u = self._rng(pass_index, depth, 1).random((n, 5))
        wi, le, pdf_light, t_max, delta, is_env = sample_lights(
            origin, u, self.p_area, self.p_area + self.p_point, w.emit_ids, w.emit_cdf, w.v0, w.e1, w.e2,
            w.tri_normal, w.tri_two_sided, w.tri_emission, w.emit_pmf_per_area, self.p_area,
            w.point_pos, w.point_intensity, w.point_cdf, w.point_pmf, self.p_point,
        )  # fmt: skip
        if w.env is not None and np.any(is_env):
            i = np.nonzero(is_env)[0]
            dirs, rad, pdf_e = w.env.sample(u[i, 1:5])
            wi[i] = dirs
            le[i] = rad
            pdf_light[i] = self.p_env * pdf_e
        wi_l = to_local(wi, *frame)
        cand = light_candidates(pdf_light, wi_l, wi, ng, le)
        f = np.zeros((n, 3))
        pdf_brdf = np.zeros(n)
        for m, idx in groups:
            j = idx[cand[idx]]
            if len(j) == 0:
                continue
            rt = w.materials_by_index[m]
            f[j], pdf_brdf[j] = rt.sampler.eval_pdf(wo_l[j], wi_l[j])
        contrib, need = light_contributions(
            beta, f, le, pdf_light, pdf_brdf, wi_l, delta, cand, self.mis == "power"
        )
        i = np.nonzero(need)[0]
        if len(i) == 0:
            return
        blocked = w.accel.occluded(origin[i], wi[i], t_max[i])
        self.stats.rays += len(i)
        i = i[~blocked]
        self._add(img, pix[i], contrib[i])

    def _ris_environment(self, img, pass_index, depth, origin, ng, wo_l, frame, beta, pix, groups) -> None:  # type: ignore[no-untyped-def]
        """Direct light from the sky by resampled importance sampling: ``M`` candidates from the material's
        sampler, weights ``w_k = p_hat / p`` with ``p_hat = lum(f cos L)`` (unoccluded), one kept with
        probability ``w_k / sum w``; estimate ``f cos L V * mean(w) / p_hat(y)`` with one shadow ray."""
        w = self.world
        m_c = self.ris
        n = len(origin)
        tb, bb, ns = frame
        wi_l = np.zeros((n * m_c, 3))
        pdf = np.zeros(n * m_c)
        f = np.zeros((n * m_c, 3))
        wo_rep = np.repeat(wo_l, m_c, axis=0)
        for m, idx in groups:
            rows = (idx[:, None] * m_c + np.arange(m_c)).ravel()
            rt = w.materials_by_index[m]
            seed = self._seed(pass_index, depth, int(m) + 0x10000)
            drawn = rt.sampler.sample_each(wo_rep[rows], seed=seed)
            wi_l[rows] = drawn.wi
            pdf[rows] = drawn.pdf
            f[rows] = drawn.f
        rep = (np.repeat(x, m_c, axis=0) for x in (tb, bb, ns, ng))
        wi, ok, fcos_over_p = bsdf_step(wi_l, pdf, f, *rep, np.ones((n * m_c, 3)))
        le = w.env.lookup(wi)[0]
        weight = np.where(ok, (fcos_over_p * le) @ LUMINANCE, 0.0).reshape(n, m_c)  # p_hat / p
        total = weight.sum(axis=1)
        u = self._rng(pass_index, depth, 7).random(n)
        pick = np.minimum((np.cumsum(weight, axis=1) <= (u * total)[:, None]).sum(axis=1), m_c - 1)
        chosen = np.arange(n) * m_c + pick
        fcos_le = f[chosen] * wi_l[chosen, 2:3] * le[chosen]
        p_hat = fcos_le @ LUMINANCE
        good = (total > 0) & (p_hat > 0) & ok[chosen]
        i = np.nonzero(good)[0]
        if len(i) == 0:
            return
        contrib = beta[i] * fcos_le[i] * ((total[i] / m_c) / p_hat[i])[:, None]
        blocked = w.accel.occluded(origin[i], wi[chosen[i]])
        self.stats.rays += len(i)
        keep = ~blocked
        self._add(img, pix[i[keep]], contrib[keep])
