"""Wavefront path tracing: a pass traces a batch of paths per pixel, all advancing bounce by bounce.

Per bounce: Embree finds the closest hits of every live ray in one batched query; compiled stages
(:mod:`renderer.kernels`) add sky or emitted light (MIS-weighted against light sampling), group the surviving
vertices by material, and take one light sample each (next-event estimation, MIS-weighted against BRDF
sampling); each material's sampler then evaluates its BRDF and pdf at the light samples and draws its BRDF
samples on one contiguous slice (the sampler's draws carry ``f`` with them); a last stage adds the light
samples' contributions, applies the BRDF samples' throughput and Russian roulette after ``rr_depth`` bounces,
and packs the next rays and the shadow rays; Embree's occlusion query then decides which light samples count.
Python runs a fixed number of calls per bounce and per material, whatever the number of rays; each stage runs
on two threads over halves of the batch (the kernels release the GIL).

NEE picks a light type with equal shares among those present (area, point, sky), then a light (emissive
triangles by area x luminance, point lights by luminance). MIS uses the exact densities: the light density
(area pdf converted to solid angle, environment-map pdf, uniform sphere for a constant sky) and the sampler's
``pdf(wo, wi)``; point lights are delta lights (no MIS). Optionally (``ris_candidates``) the sky's direct light
comes from resampled importance sampling instead. Reflection only: a direction below the geometric surface
carries nothing (no transmission).

Sample placement: pixel positions and the point on a light are Owen-scrambled Sobol points of the pixel's
sample number (:mod:`renderer.qmc`): stratified at every power of two, unbiased at every sample. Every other
random number is a hash of ``(seed, pass, path, bounce, role)``, and the samplers' draws are seeded by
``(seed, pass, bounce, material)``, so the same seed gives the same image, whatever the thread timing.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from core.dispatch import MERL, MERL_NEAREST
from core.model import LUMINANCE
from core.scene import Scene
from renderer.envmap import env_args
from renderer.kernels import (
    BY_SAMPLER,
    COMPILED_STRATEGIES,
    add_rows,
    bsdf_stage,
    bsdf_step,
    camera_rays,
    camera_stage,
    compact_counts,
    compact_stage,
    continue_stage,
    hit_stage,
    shadow_stage,
    sort_by_material,
    surface_frames,
    surface_stage,
)
from renderer.qmc import key
from renderer.world import NO_MATERIAL, World

PARALLEL_MIN = 16384
"""Stages over more rows than this run on two threads (two halves of the batch); smaller ones stay on one,
where the thread hand-off would cost more than it saves."""


def _key(a: int, b: int) -> np.uint64:
    """:func:`renderer.qmc.key` from Python (keys are 64-bit unsigned: numba would read a Python int as
    signed)."""
    return np.uint64(key(np.uint64(a), np.uint64(b)))


SAMPLER_SLICE = 1 << 15
"""Rows of one material a sampler object is given at a time (slices run on the integrator's threads)."""


WAVEFRONT = 1 << 18
"""Paths traced together at most: a pass of a large image runs several wavefronts one after the other, so the
per-path buffers (~600 bytes a path) stay within ~160 MB whatever the image size."""


@dataclass
class PassStats:
    paths: int = 0
    rays: int = 0
    nonfinite: int = 0
    """Path contributions that were NaN or infinite (dropped; 0 in a correct renderer)."""


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


class _Buffers:
    """The arrays of one pass's wavefront, allocated once per batch size and reused by every pass."""

    def __init__(self, n: int):
        f64, f32, i64 = np.float64, np.float32, np.int64
        # rays of the current bounce
        self.o, self.d, self.beta = (np.empty((n, 3), f64) for _ in range(3))
        self.o32, self.d32 = np.empty((n, 3), f32), np.empty((n, 3), f32)
        self.path, self.prev_pdf = np.empty(n, i64), np.empty(n, f64)
        self.prim, self.t = np.empty(n, np.int32), np.empty(n, f32)
        self.bu, self.bv = np.empty(n, f32), np.empty(n, f32)
        self.mat, self.order, self.s_mat = np.empty(n, i64), np.empty(n, i64), np.empty(n, i64)
        # surface vertices, sorted by material
        self.ng, self.wo, self.origin, self.s_beta = (np.empty((n, 3), f64) for _ in range(4))
        self.frame = np.empty((n, 3, 3), f64)
        self.s_path = np.empty(n, i64)
        # their light samples and BRDF samples
        self.l_wi, self.l_wi_local, self.l_le, self.l_f, self.l_contrib = (
            np.empty((n, 3), f64) for _ in range(5)
        )
        self.l_pdf, self.l_tmax, self.l_pdf_brdf = (np.empty(n, f64) for _ in range(3))
        self.l_delta, self.l_cand, self.l_need = (np.empty(n, np.bool_) for _ in range(3))
        self.wi_local, self.f, self.next_d = (np.empty((n, 3), f64) for _ in range(3))
        self.pdf = np.empty(n, f64)
        self.alive = np.empty(n, np.bool_)
        # shadow rays
        self.so32, self.sd32 = np.empty((n, 3), f32), np.empty((n, 3), f32)
        self.st32 = np.empty(n, f32)
        self.shadow_slot = np.empty(n, i64)


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
        self._seed_key = _key(seed % (1 << 64), 0x5EED)
        self._env = tuple(
            np.ascontiguousarray(x) if isinstance(x, np.ndarray) else x for x in env_args(world.env)
        )
        self._buffers: _Buffers | None = None
        self._strategies()
        self.threads = max(1, int(getattr(world, "threads", 1)))
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None

    def _strategies(self) -> None:
        """Per material index: whether its BRDF samples are drawn in compiled code (a strategy without
        tables: ``uniform``, ``cosine``, ``analytic``) or by its sampler object, the model's dispatch id and
        its parameters (rows padded to one length)."""
        from core.sampling.basic import AnalyticSampler, CosineSampler, UniformSampler

        compiled = (UniformSampler, CosineSampler, AnalyticSampler)
        rts = self.world.materials_by_index
        n = len(rts)
        self.mat_strategy = np.full(n, BY_SAMPLER, dtype=np.int64)
        self.mat_model = np.zeros(n, dtype=np.int64)
        # MERL tables (4.4 M values) go to mat_tables as float32 (renderer.kernels._eval), every other model's
        # parameters to mat_params: neither matrix pads a small row to a table's width
        table = [rt is not None and rt.brdf.model.id in (MERL, MERL_NEAREST) for rt in rts]
        width = max(
            [len(rt.brdf.params) for rt, t in zip(rts, table, strict=True) if rt is not None and not t] + [1]
        )
        t_width = max([len(rt.brdf.params) for rt, t in zip(rts, table, strict=True) if t] + [1])
        self.mat_params = np.zeros((n, width))
        self.mat_tables = np.zeros((n, t_width), dtype=np.float32)
        for m, rt in enumerate(rts):
            if rt is None:
                continue
            self.mat_model[m] = rt.brdf.model.id
            if table[m]:
                self.mat_tables[m, : len(rt.brdf.params)] = rt.brdf.params
            else:
                self.mat_params[m, : len(rt.brdf.params)] = rt.brdf.params
            if type(rt.sampler) in compiled:
                self.mat_strategy[m] = COMPILED_STRATEGIES[rt.sampler.name]

    def _rng(self, pass_index: int, depth: int, role: int, wave: int = 0) -> np.random.Generator:
        return np.random.default_rng([self.seed, pass_index, depth + 1, role, wave])

    def _seed(self, pass_index: int, depth: int, material: int, part: int = 0, wave: int = 0) -> int:
        ss = np.random.SeedSequence([self.seed, pass_index, depth + 1, material, 0x5A, part, wave])
        return int(ss.generate_state(1, dtype=np.uint32)[0])

    def _cuts(self, n: int) -> np.ndarray:
        """Row ranges a stage over ``[0, n)`` is split into: one, or one per thread for large ``n``."""
        parts = 1 if self._pool is None or n < PARALLEL_MIN else self.threads
        return np.linspace(0, n, parts + 1).astype(np.int64)

    def _compact(self, n_s: int) -> tuple[int, int]:
        """Pack the next rays and the shadow rays of ``n_s`` vertices (count per range, then write each range
        from its offset); returns their numbers."""
        B = self._buffers
        assert B is not None
        cuts = self._cuts(n_s)
        ranges = list(zip(cuts[:-1].tolist(), cuts[1:].tolist(), strict=True))
        counts = np.zeros((len(ranges), 2), dtype=np.int64)
        self._each(ranges, lambda a, b, c: compact_counts(a, b, B.alive, B.l_need, counts, c))
        starts = np.vstack([np.zeros((1, 2), np.int64), np.cumsum(counts, axis=0)])
        self._each(ranges, lambda a, b, c: compact_stage(
            a, b, starts[c, 0], starts[c, 1], B.alive, B.l_need, B.origin, B.next_d, B.s_beta, B.s_path, B.pdf,
            B.l_wi, B.l_tmax, B.o, B.d, B.o32, B.d32, B.beta, B.path, B.prev_pdf, B.so32, B.sd32, B.st32,
            B.shadow_slot,
        ))  # fmt: skip
        return int(starts[-1, 0]), int(starts[-1, 1])

    def _each(self, ranges: list[tuple[int, int]], fn) -> None:  # type: ignore[no-untyped-def]
        """``fn(a, b, index)`` for each range, on the threads when there are several."""
        if self._pool is None or len(ranges) == 1:
            for c, (a, b) in enumerate(ranges):
                fn(a, b, c)
        else:
            for job in [self._pool.submit(fn, a, b, c) for c, (a, b) in enumerate(ranges)]:
                job.result()

    def _run(self, stage, n: int, *args) -> int:  # type: ignore[no-untyped-def]
        """``stage(a, b, *args)`` over ``[0, n)``, in halves on two threads for large ``n``; the sum of what
        the calls return (counts of dropped contributions, or 0)."""
        cuts = self._cuts(n)
        if len(cuts) == 2:
            return int(stage(0, n, *args) or 0)
        jobs = [
            self._pool.submit(stage, int(a), int(b), *args) for a, b in zip(cuts[:-1], cuts[1:], strict=True)
        ]
        return sum(int(j.result() or 0) for j in jobs)

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
    def render_pass(
        self,
        pass_index: int,
        spp: int = 1,
        first_sample: int | None = None,
        pixels: tuple[int, int] | None = None,
    ) -> np.ndarray:
        """``spp`` samples per pixel traced together; returns their mean per pixel, ``(height * width, 3)``,
        or for ``pixels = (p0, p1)`` the pixels ``p0 .. p1 - 1`` only (row-major: a band of whole rows is
        one range), ``(p1 - p0, 3)``.

        Passes with different ``pass_index`` are independent (their random numbers are keyed by it); path
        ``j`` of a pass is sample ``first_sample + j // pixels`` of pixel ``j % pixels`` in the pixel's
        low-discrepancy sequence (default ``pass_index * spp``: passes of equal size; a progressive render
        passes the number of samples it already has, so that no sample number is used twice). A range of
        pixels traces the very paths ``j`` the whole pass traces for them (only their radiance rows are kept):
        for strategies drawn in compiled code its pixels equal the whole pass's bit for bit.
        """
        first = pass_index * int(spp) if first_sample is None else int(first_sample)
        n_pix = self.width * self.height
        p0, p1 = (0, n_pix) if pixels is None else (int(pixels[0]), int(pixels[1]))
        if not 0 <= p0 < p1 <= n_pix:
            raise ValueError(f"pixels {p0}..{p1} outside the image's 0..{n_pix}")
        band = p1 - p0
        radiance = np.zeros((band * int(spp), 3))
        pass_key = _key(self._seed_key, pass_index)
        bad = 0
        if pixels is None:
            n_all = n_pix * int(spp)
            for j0 in range(0, n_all, WAVEFRONT):
                n = min(n_all, j0 + WAVEFRONT) - j0
                bad += self._wavefront(j0, n, radiance, pass_index, pass_key, first, 0, j0 // WAVEFRONT)
        else:
            for s in range(int(spp)):
                # path j = s * n_pix + p (pixel p) keeps its radiance in row s * band + p - p0 = j - offset
                offset = s * (n_pix - band) + p0
                end = s * n_pix + p1
                for j0 in range(s * n_pix + p0, end, WAVEFRONT):
                    # the samplers' draws are keyed by the wavefront's first path: unique within the pass
                    bad += self._wavefront(j0, min(end, j0 + WAVEFRONT) - j0, radiance, pass_index, pass_key,
                                           first, offset, j0)  # fmt: skip
        self.stats.nonfinite += bad
        if (
            spp == 1
        ):  # one path a pixel: its rows are the mean (no sum, no division: 2 passes over 6 MB at 512²)
            return radiance
        return radiance.reshape(int(spp), band, 3).sum(axis=0) / spp

    def _wavefront(
        self,
        j0: int,
        n: int,
        radiance: np.ndarray,
        pass_index: int,
        pass_key: np.uint64,
        first: int,
        row_offset: int,
        wave: int,
    ) -> int:
        """Paths ``j0 .. j0 + n - 1`` of a pass, bounce by bounce, the light of path ``j`` added to
        ``radiance`` row ``j - row_offset``; ``wave`` keys the draws of the samplers with tables. Returns the
        number of non-finite contributions dropped."""
        w = self.world
        n_pix = self.width * self.height
        if self._buffers is None or len(self._buffers.path) < n:
            self._buffers = _Buffers(n)
        B = self._buffers
        cam = self.camera
        rows = np.int64(row_offset)
        self._run(camera_stage, n, j0, n_pix, first, self._seed_key, self.width, self.height,
                  cam.origin, cam.forward, cam.right, cam.up, float(cam.tan_half), float(cam.aspect),
                  B.o, B.d, B.o32, B.d32, B.beta, B.path, B.prev_pdf)  # fmt: skip
        self.stats.paths += n
        env_kind, env_rad, env_row, env_col, env_guide, env_edges, env_pmf, env_img, env_rot = self._env
        power = self.mis == "power"
        n_mat = len(w.materials_by_index)
        offsets = np.zeros(n_mat + 1, dtype=np.int64)
        bad = 0
        for depth in range(self.max_depth + 1):
            if n == 0:
                break
            w.accel.trace(B.o32[:n], B.d32[:n], B.prim, B.t, B.bu, B.bv)
            self.stats.rays += n
            bad += self._run(
                hit_stage, n, B.d, B.prim, B.t, B.beta, B.path, B.prev_pdf, radiance, rows, B.mat,
                depth == self.max_depth, power, self.p_env, self.p_area, self.ris > 0,
                w.tri_normal, w.tri_material, w.tri_emission, w.tri_emissive, w.tri_two_sided,
                w.emit_pmf_per_area, env_kind, env_rad, env_pmf, env_img, env_rot, env_edges,
            )  # fmt: skip
            n_s = int(sort_by_material(B.mat[:n], n_mat, B.order, offsets))
            if n_s == 0:
                break
            self._run(
                surface_stage, n_s, B.order, B.mat, B.o, B.d, B.t, B.prim, B.bu, B.bv, B.beta, B.path, w.eps,
                w.tri_normal, w.tri_vnormals, w.tri_smooth,
                self.has_nee_lights, n_pix, first, self._seed_key, pass_key, depth,
                self.p_area, self.p_area + self.p_point, self.p_area, self.p_point, self.p_env,
                w.emit_ids, w.emit_cdf, w.v0, w.e1, w.e2, w.tri_two_sided, w.tri_emission, w.emit_pmf_per_area,
                w.point_pos, w.point_intensity, w.point_cdf, w.point_pmf,
                env_kind, env_rad, env_row, env_col, env_guide, env_edges, env_pmf, env_img, env_rot,
                B.s_mat, B.ng, B.frame, B.wo, B.origin, B.s_beta, B.s_path,
                B.l_wi, B.l_wi_local, B.l_le, B.l_pdf, B.l_tmax, B.l_delta, B.l_cand,
            )  # fmt: skip
            # ---- BRDF samples, and f and pdf at the light samples: strategies without tables in compiled code,
            # the others by their sampler objects, material by material, on contiguous slices
            self._run(
                bsdf_stage, n_s, n_pix, first, self._seed_key, pass_key, depth, self.has_nee_lights,
                self.mat_strategy, self.mat_model, self.mat_params, self.mat_tables, B.s_mat, B.s_path, B.wo,
                B.l_wi_local, B.l_cand, B.l_f, B.l_pdf_brdf, B.wi_local, B.pdf, B.f,
            )  # fmt: skip
            self._draw_by_samplers(offsets, pass_index, depth, wave)
            if self.ris:
                bad += self._ris_environment(radiance, rows, pass_index, depth, n_s, offsets, wave)
            rr_key = _key(_key(pass_key, depth), 0x7272)
            self._run(
                continue_stage, n_s, power, depth + 1 >= self.rr_depth, rr_key, B.ng, B.frame, B.s_beta,
                B.s_path, B.l_wi_local, B.l_le, B.l_pdf, B.l_delta, B.l_cand, B.l_f, B.l_pdf_brdf,
                B.wi_local, B.pdf, B.f, B.l_contrib, B.l_need, B.next_d, B.alive,
            )  # fmt: skip
            n, k = self._compact(n_s)
            if k:
                blocked = w.accel.occluded(B.so32[:k], B.sd32[:k], B.st32[:k])
                self.stats.rays += k
                bad += self._run(
                    shadow_stage, k, blocked, B.shadow_slot, B.s_path, B.l_contrib, radiance, rows
                )
        return bad

    def _draw_by_samplers(self, offsets: np.ndarray, pass_index: int, depth: int, wave: int) -> None:
        """The vertices of materials whose strategy has tables: their sampler objects evaluate ``f`` and the
        pdf at the light samples and draw the BRDF samples (with ``f``), in slices of at most
        ``SAMPLER_SLICE`` rows of one material, run on the integrator's threads. Each slice's draws are seeded
        by ``(seed, pass, wavefront, bounce, material, slice)``: the image does not depend on the threads."""
        B = self._buffers
        assert B is not None
        jobs = []
        for m in range(len(offsets) - 1):
            a, b = int(offsets[m]), int(offsets[m + 1])
            if a == b or self.mat_strategy[m] != BY_SAMPLER:
                continue
            sampler = self.world.materials_by_index[m].sampler
            for k, lo in enumerate(range(a, b, SAMPLER_SLICE)):
                jobs.append(
                    (sampler, lo, min(b, lo + SAMPLER_SLICE), self._seed(pass_index, depth, m, k, wave))
                )

        def run(job) -> None:  # type: ignore[no-untyped-def]
            sampler, lo, hi, seed = job
            if self.has_nee_lights:
                c = lo + np.flatnonzero(B.l_cand[lo:hi])
                if len(c):
                    B.l_f[c], B.l_pdf_brdf[c] = sampler.eval_pdf(B.wo[c], B.l_wi_local[c])
            drawn = sampler.sample_each(B.wo[lo:hi], seed=seed)
            B.wi_local[lo:hi], B.pdf[lo:hi], B.f[lo:hi] = drawn.wi, drawn.pdf, drawn.f

        if self._pool is None or len(jobs) < 2:
            for job in jobs:
                run(job)
        else:
            list(self._pool.map(run, jobs))

    def _ris_environment(
        self,
        radiance: np.ndarray,
        row_offset: np.int64,
        pass_index: int,
        depth: int,
        n_s: int,
        offsets: np.ndarray,
        wave: int,
    ) -> int:
        """Direct light from the sky by resampled importance sampling at the ``n_s`` surface vertices:
        ``M`` candidates from the material's sampler, weights ``w_k = p_hat / p`` with ``p_hat = lum(f cos
        L)`` (unoccluded), one kept with probability ``w_k / sum w``; estimate ``f cos L V * mean(w) /
        p_hat(y)`` with one shadow ray. Returns the number of non-finite contributions dropped."""
        w = self.world
        B = self._buffers
        assert B is not None
        m_c = self.ris
        n = n_s
        wo_l, origin, ng = B.wo[:n], B.origin[:n], B.ng[:n]
        tb, bb, ns = (np.ascontiguousarray(B.frame[:n, r]) for r in range(3))
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
            drawn = sampler.sample_each(
                wo_rep[rows], seed=self._seed(pass_index, depth, m + 0x10000, 0, wave)
            )
            wi_l[rows], pdf[rows], f[rows] = drawn.wi, drawn.pdf, drawn.f
        rep = (np.repeat(x, m_c, axis=0) for x in (tb, bb, ns, ng))
        wi, ok, fcos_over_p = bsdf_step(wi_l, pdf, f, *rep, np.ones((n * m_c, 3)))
        le = w.env.lookup(wi)[0]
        weight = np.where(ok, (fcos_over_p * le) @ LUMINANCE, 0.0).reshape(n, m_c)  # p_hat / p
        total = weight.sum(axis=1)
        u = self._rng(pass_index, depth, 7, wave).random(n)
        pick = np.minimum((np.cumsum(weight, axis=1) <= (u * total)[:, None]).sum(axis=1), m_c - 1)
        chosen = np.arange(n) * m_c + pick
        fcos_le = f[chosen] * wi_l[chosen, 2:3] * le[chosen]
        p_hat = fcos_le @ LUMINANCE
        good = (total > 0) & (p_hat > 0) & ok[chosen]
        i = np.nonzero(good)[0]
        if len(i) == 0:
            return 0
        contrib = B.s_beta[i] * fcos_le[i] * ((total[i] / m_c) / p_hat[i])[:, None]
        blocked = w.accel.occluded(origin[i], wi[chosen[i]])
        self.stats.rays += len(i)
        keep = ~blocked
        return int(add_rows(radiance, B.s_path[i[keep]] - row_offset, np.ascontiguousarray(contrib[keep])))
