"""Wavefront path tracing: a pass traces a batch of paths per pixel, all advancing bounce by bounce.

Per bounce: Embree finds the closest hits of every live ray in one batched query; compiled stages
(:mod:`renderer.stages`) add sky or emitted light (MIS-weighted against light sampling), group the surviving
vertices by material, and take one light sample each (next-event estimation, MIS-weighted against BRDF
sampling); each material's sampler then evaluates its BRDF and pdf at the light samples and draws its BRDF
samples on one contiguous slice (the sampler's draws carry ``f`` with them); a last stage adds the light
samples' contributions, applies the BRDF samples' throughput and Russian roulette after ``rr_depth`` bounces,
and packs the next rays and the shadow rays; Embree's occlusion query then decides which light samples count.
Python runs a fixed number of calls per bounce and per material, whatever the number of rays. A pass's paths
go in interleaved wavefronts (:mod:`renderer.wavefront`) traced on the tracer's threads at once, each
wavefront's stages and Embree queries on its own thread (the kernels release the GIL).

NEE picks a light type (area, point, sky) by shares a pilot of camera rays sets (:mod:`renderer.light_shares`),
then a light (emissive triangles by area x luminance, point lights by luminance). MIS uses the exact densities: the light density
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

import queue
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from core.dispatch import MERL, MERL_NEAREST
from core.scene import Scene
from renderer.light_shares import light_shares
from renderer.qmc import key
from renderer.ris import ris_sky
from renderer.stages.bsdf import BY_SAMPLER, COMPILED_STRATEGIES, bsdf_points, bsdf_stage
from renderer.stages.camera import camera_rays, camera_stage
from renderer.stages.continuation import bsdf_step, continue_stage, shadow_stage
from renderer.stages.hits import hit_stage, sort_by_material
from renderer.stages.primitives import SOBOL_DEPTH
from renderer.stages.records import (
    Estimator,
    Lights,
    Materials,
    PassKeys,
    PinholeCamera,
    lights,
    sky_record,
    triangles,
)
from renderer.stages.surface import surface_frames, surface_stage
from renderer.wavefront import WAVEFRONT, Buffers, Wave, waves
from renderer.world import NO_MATERIAL, World

PARALLEL_MIN = 16384
"""Images of more pixels than this compile their models' kernels on all threads (``World.compile``)."""
LOAD_PASS = (1 << 62) + 0x10AD
"""The pass index of :meth:`PathTracer.load_kernels`' paths (no render numbers its passes this high)."""

KEEP_RADIANCE_ROWS = 1 << 21
"""Passes of at most this many paths (48 MB of radiance rows) keep their radiance rows from pass to pass
(:meth:`PathTracer.reserve`); larger ones, whose page faults are a small part of a long pass, allocate
their own."""


def _key(a: int, b: int) -> np.uint64:
    """:func:`renderer.qmc.key` from Python (keys are 64-bit unsigned: numba would read a Python int as
    signed)."""
    return np.uint64(key(np.uint64(a), np.uint64(b)))


SAMPLER_SLICE = 1 << 15
"""Rows of one material a sampler object is given at a time (each slice seeded on its own)."""


@dataclass
class PassStats:
    paths: int = 0
    rays: int = 0
    nonfinite: int = 0
    """Path contributions that were NaN or infinite (dropped; 0 in a correct renderer)."""


class Camera:
    """Pinhole camera rays for pixel indices (row-major, row 0 at the top)."""

    def __init__(self, scene: Scene, width: int, height: int):
        cam = scene.camera
        origin = np.asarray(cam.position, dtype=np.float64)
        fwd = np.asarray(cam.target, dtype=np.float64) - origin
        forward = fwd / np.linalg.norm(fwd)
        right = np.cross(forward, np.asarray(cam.up, dtype=np.float64))
        right = right / np.linalg.norm(right)
        up = np.cross(right, forward)
        tan_half = float(np.tan(np.radians(cam.fov_deg) / 2.0))
        self.record = PinholeCamera(
            width, height, origin, forward, right, up, tan_half, float(width / height)
        )
        """what the compiled stages read"""

    def rays(self, pixels: np.ndarray, jitter: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return camera_rays(pixels, jitter, self.record)  # type: ignore[no-any-return]


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
        self.camera = Camera(world.scene, width, height)
        self.width, self.height = width, height
        self.seed = seed
        present = (len(world.emit_ids) > 0, len(world.point_pos) > 0, world.env is not None and not self.ris)
        self.has_nee_lights = any(present)
        self.max_depth = max_depth
        self.rr_depth = rr_depth
        self.mis = mis
        self.stats = PassStats()
        self._seed_key = _key(seed % (1 << 64), 0x5EED)
        # the records the compiled stages read (renderer.stages.records), built once
        self.estimator = Estimator(power=mis == "power", nee=self.has_nee_lights, ris=self.ris > 0)
        self.triangles = triangles(world)
        self.lights: Lights = lights(world, sky_record(world.env), 0.0, 0.0, 0.0)
        shares = light_shares(
            world, self.camera.record, self.triangles, self.lights, present, seed, self._seed_key
        )
        self.lights = self.lights.with_shares(*shares)
        self.materials = self._materials()
        self.threads = max(1, int(getattr(world, "threads", 1)))
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        # one set of wavefront buffers per thread at work: a wavefront takes a free set and gives it back
        self._free: queue.SimpleQueue[Buffers] = queue.SimpleQueue()
        self.buffers: list[Buffers] = []
        # a whole-image pass's radiance rows, kept from pass to pass (see reserve and render_pass)
        self._radiance: np.ndarray | None = None
        self._mean: np.ndarray | None = None  # and their mean per pixel, when a pass has several samples

    @property
    def p_area(self) -> float:
        """NEE's probability of an area light (:mod:`renderer.light_shares`)."""
        return self.lights.p_area

    @p_area.setter
    def p_area(self, p: float) -> None:
        self.lights = self.lights.with_shares(p, self.lights.p_point, self.lights.p_env)

    @property
    def p_point(self) -> float:
        """NEE's probability of a point light."""
        return self.lights.p_point

    @p_point.setter
    def p_point(self, p: float) -> None:
        self.lights = self.lights.with_shares(self.lights.p_area, p, self.lights.p_env)

    @property
    def p_env(self) -> float:
        """NEE's probability of the sky."""
        return self.lights.p_env

    @p_env.setter
    def p_env(self, p: float) -> None:
        self.lights = self.lights.with_shares(self.lights.p_area, self.lights.p_point, p)

    def _materials(self) -> Materials:
        """Per material index: whether its BRDF samples are drawn in compiled code (a strategy without
        tables: ``uniform``, ``cosine``, ``analytic``) or by its sampler object, the model's dispatch id and
        its parameters (rows padded to one length)."""
        from core.sampling.basic import AnalyticSampler, CosineSampler, UniformSampler

        compiled = (UniformSampler, CosineSampler, AnalyticSampler)
        rts = self.world.materials_by_index
        n = len(rts)
        strategy = np.full(n, BY_SAMPLER, dtype=np.int64)
        model = np.zeros(n, dtype=np.int64)
        # MERL tables (4.4 M values) go to tables as float32 (renderer.stages.bsdf._eval), every other model's
        # parameters to params: neither matrix pads a small row to a table's width
        table = [rt is not None and rt.brdf.model.id in (MERL, MERL_NEAREST) for rt in rts]
        width = max(
            [len(rt.brdf.params) for rt, t in zip(rts, table, strict=True) if rt is not None and not t] + [1]
        )
        t_width = max([len(rt.brdf.params) for rt, t in zip(rts, table, strict=True) if t] + [1])
        params = np.zeros((n, width))
        tables = np.zeros((n, t_width), dtype=np.float32)
        for m, rt in enumerate(rts):
            if rt is None:
                continue
            model[m] = rt.brdf.model.id
            if table[m]:
                tables[m, : len(rt.brdf.params)] = rt.brdf.params
            else:
                params[m, : len(rt.brdf.params)] = rt.brdf.params
            # a sampler with tables whose density is a compiled strategy's (the adaptive sampler's flat table
            # of a Lambertian material: the cosine density) is drawn as that strategy
            name = rt.sampler.name if type(rt.sampler) in compiled else rt.sampler.compiled_equivalent()
            if name is not None:
                strategy[m] = COMPILED_STRATEGIES[name]
        return Materials(strategy, model, params, tables)

    def _rng(self, pass_index: int, depth: int, role: int, wave: int = 0) -> np.random.Generator:
        return np.random.default_rng([self.seed, pass_index, depth + 1, role, wave])

    def _seed(self, pass_index: int, depth: int, material: int, part: int = 0, wave: int = 0) -> int:
        ss = np.random.SeedSequence([self.seed, pass_index, depth + 1, material, 0x5A, part, wave])
        return int(ss.generate_state(1, dtype=np.uint32)[0])

    def _run(self, stage, n: int, *args) -> int:  # type: ignore[no-untyped-def]
        """``stage(0, n, *args)`` on the calling thread (a wavefront's thread); what it returns (a count of
        dropped contributions), or 0. Every compiled stage of a wavefront goes through here."""
        return int(stage(0, n, *args) or 0)

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
            ng, ns, tb, bb, wo_l, origin = surface_frames(o, d, t, prim, bu, bv, self.triangles)
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
        borrow: bool = False,
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

        ``borrow``: a whole-image pass may return the tracer's own rows (those :meth:`reserve` mapped: the
        radiance of a pass of one sample per pixel, or the mean of several), valid until the next pass: for a
        caller that adds them to a film at once (:meth:`renderer.render.RenderJob.passes`). Otherwise the
        array returned is the caller's. One pass at a time per tracer: a whole-image pass traces into those
        rows whether it borrows them or not.
        """
        first = pass_index * int(spp) if first_sample is None else int(first_sample)
        n_pix = self.width * self.height
        p0, p1 = (0, n_pix) if pixels is None else (int(pixels[0]), int(pixels[1]))
        if not 0 <= p0 < p1 <= n_pix:
            raise ValueError(f"pixels {p0}..{p1} outside the image's 0..{n_pix}")
        band = p1 - p0
        rows = band * int(spp)
        kept = self._radiance
        if pixels is None and kept is not None and len(kept) == rows and (borrow or spp > 1):
            # the rows reserve() mapped: a new array's pages are faulted in by the paths' first writes, in the
            # first passes until the allocator reuses them (~15-25 ms of a first pass at 256² and 4 spp)
            radiance = kept
            radiance.fill(0.0)
        else:
            radiance = np.zeros((rows, 3))
        keys = PassKeys(n_pix, first, self._seed_key, _key(self._seed_key, pass_index))
        if pixels is None:
            plan = waves(0, n_pix * int(spp))
        else:
            # path j = s * n_pix + p (pixel p) keeps its radiance in row s * band + p - p0 = j - offset; the
            # samplers' draws are keyed by each wavefront's first path: unique within the pass
            plan = [w for s in range(int(spp))
                    for w in waves(s * n_pix + p0, s * n_pix + p1, s * (n_pix - band) + p0)]  # fmt: skip

        def trace(wave: Wave) -> tuple[int, int]:
            try:
                B = self._free.get_nowait()
            except queue.Empty:
                B = None
            if B is None or len(B) < wave.n:
                if B is not None:
                    self.buffers.remove(B)
                B = Buffers(wave.n)
                self.buffers.append(B)
            try:
                return self._wavefront(B, wave, radiance, pass_index, keys)
            finally:
                self._free.put(B)

        if self._pool is None or len(plan) < 2:
            done = [trace(w) for w in plan]
        else:
            jobs = [self._pool.submit(trace, w) for w in plan]
            done = [j.result() for j in jobs]
        self.stats.paths += sum(w.n for w in plan)
        self.stats.rays += sum(rays for rays, _ in done)
        self.stats.nonfinite += sum(bad for _, bad in done)
        if spp == 1:  # one path a pixel: its rows are the mean (no sum, no division)
            return radiance
        if borrow and radiance is kept and self._mean is not None and len(self._mean) == band:
            np.sum(radiance.reshape(int(spp), band, 3), axis=0, out=self._mean)
            return np.divide(self._mean, spp, out=self._mean)
        return radiance.reshape(int(spp), band, 3).sum(axis=0) / spp

    def load_kernels(self, paths: int = 256) -> None:
        """Trace ``paths`` paths through the middle of the image and forget them (image, statistics): each
        compiled stage's first call in a process loads it from numba's cache, ~0.1 s in all (most of it the
        BRDF stage's model switch), which belongs with the preparation rather than in a render's first pass.
        Passes are keyed by their index, so later passes draw what they would have drawn without it."""
        n_pix = self.width * self.height
        k = min(n_pix, int(paths))
        p0 = max(0, min(n_pix - k, (n_pix - k) // 2 + self.width // 2))
        stats, self.stats = self.stats, PassStats()
        self.render_pass(LOAD_PASS, 1, pixels=(p0, p0 + k))
        self.stats = stats

    def reserve(self, paths: int) -> None:
        """Allocate and touch the wavefront buffers a pass of ``paths`` paths uses (one set per thread, each
        the size of the pass's largest wavefront), replacing smaller ones: the first pass then runs on mapped
        memory like every later one (at 256² and 4 spp a pass, ~60 ms of page faults and first writes)."""
        n = max((w.n for w in waves(0, max(1, min(int(paths), WAVEFRONT)))), default=1)  # the first group's
        while True:
            try:
                self._free.get_nowait()
            except queue.Empty:
                break
        self.buffers = []
        for _ in range(self.threads):
            B = Buffers(n)
            B.touch()
            self.buffers.append(B)
            self._free.put(B)
        self._radiance = self._mean = None
        if int(paths) <= KEEP_RADIANCE_ROWS:
            self._radiance = np.empty((max(1, int(paths)), 3))
            self._radiance.fill(0.0)
            self._mean = np.empty((self.width * self.height, 3))
            self._mean.fill(0.0)

    def _wavefront(
        self, B: Buffers, wave: Wave, radiance: np.ndarray, pass_index: int, keys: PassKeys
    ) -> tuple[int, int]:
        """The paths of ``wave``, bounce by bounce on the calling thread with the buffers ``B``, the light of
        path ``j`` added to ``radiance`` row ``j - wave.row_offset``. Returns the number of rays traced and of
        non-finite contributions dropped."""
        w = self.world
        n = wave.n
        rows = np.int64(wave.row_offset)
        est, tris, lights = self.estimator, self.triangles, self.lights
        R, H, V, L, S = B.rays, B.hits, B.vertices, B.light, B.bsdf
        self._run(camera_stage, n, wave.j0, wave.block, wave.step, keys, self.camera.record, R)
        n_mat = len(w.materials_by_index)
        offsets = np.zeros(n_mat + 1, dtype=np.int64)
        bad = 0
        rays = 0
        for depth in range(self.max_depth + 1):
            if n == 0:
                break
            w.accel.trace(R.o32[:n], R.d32[:n], H.prim, H.t, H.bu, H.bv, parallel=False)
            rays += n
            bad += self._run(hit_stage, n, R, H, radiance, rows, depth == self.max_depth, est, tris, lights)
            n_s = int(sort_by_material(H.mat[:n], n_mat, V.order, offsets))
            if n_s == 0:
                break
            self._run(surface_stage, n_s, depth, keys, est, tris, lights, R, H, V, L, B.scratch)
            # ---- BRDF samples, and f and pdf at the light samples: strategies without tables in compiled code,
            # the others by their sampler objects, material by material, on contiguous slices
            self._run(bsdf_stage, n_s, depth, keys, est, self.materials, V, L, S, B.scratch)
            self._draw_by_samplers(B, offsets, pass_index, depth, wave.key, keys)
            if self.ris:
                r_bad, r_rays = ris_sky(
                    w, B, radiance, rows, n_s, offsets, self.ris,
                    lambda m, d=depth: self._seed(pass_index, d, m + 0x10000, 0, wave.key),
                    self._rng(pass_index, depth, 7, wave.key),
                )  # fmt: skip
                bad += r_bad
                rays += r_rays
            rr_key = _key(_key(keys.pass_key, depth), 0x7272)
            counts = B.counts
            counts[:] = 0
            self._run(
                continue_stage, n_s, est, depth + 1 >= self.rr_depth, rr_key, V, L, S, R, B.shadow, counts
            )
            n, k = int(counts[0]), int(counts[1])
            if k:
                sh = B.shadow
                blocked = w.accel.occluded(sh.o32[:k], sh.d32[:k], sh.tmax32[:k], parallel=False)
                rays += k
                bad += self._run(shadow_stage, k, blocked, sh, V, L, radiance, rows)
        return rays, bad

    def _draw_by_samplers(
        self, B: Buffers, offsets: np.ndarray, pass_index: int, depth: int, wave: int, keys: PassKeys
    ) -> None:
        """The vertices of materials whose strategy has tables: their sampler objects evaluate ``f`` and the
        pdf at the light samples and draw the BRDF samples (with ``f``), in slices of at most
        ``SAMPLER_SLICE`` rows of one material, on the wavefront's thread. Each slice's draws are seeded by
        ``(seed, pass, wavefront, bounce, material, slice)``: the image does not depend on the threads. Below
        ``SOBOL_DEPTH`` their warps read the Sobol points the compiled strategies draw from
        (:func:`~renderer.stages.bsdf.bsdf_points`), so every strategy's samples are placed alike."""
        strategy = self.materials.strategy
        jobs = []
        for m in range(len(offsets) - 1):
            a, b = int(offsets[m]), int(offsets[m + 1])
            if a == b or strategy[m] != BY_SAMPLER:
                continue
            sampler = self.world.materials_by_index[m].sampler
            for k, lo in enumerate(range(a, b, SAMPLER_SLICE)):
                jobs.append(
                    (sampler, lo, min(b, lo + SAMPLER_SLICE), self._seed(pass_index, depth, m, k, wave))
                )

        placed = depth < SOBOL_DEPTH
        V, L, S = B.vertices, B.light, B.bsdf
        for sampler, lo, hi, seed in jobs:
            if placed:
                bsdf_points(lo, hi, keys, depth, V.path, S.points)
            if self.has_nee_lights:
                sampler.eval_pdf_where(V.wo[lo:hi], L.wi_local[lo:hi], L.cand[lo:hi], L.f[lo:hi],
                                       L.pdf_brdf[lo:hi])  # fmt: skip
            sampler.sample_into(V.wo[lo:hi], seed, S.wi_local[lo:hi], S.pdf[lo:hi], S.f[lo:hi],
                                points=S.points[lo:hi] if placed else None)  # fmt: skip
