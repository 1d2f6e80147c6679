"""A pass's paths in wavefronts: which paths each wavefront traces, and the arrays one wavefront needs.

A pass's paths ``[j0, j1)`` (or a band's, sample by sample) go in groups of at most ``WAVEFRONT`` paths, one
after the other, and every group is traced as ``WAVES`` wavefronts **interleaved** in runs of ``RUN`` paths
(run ``q`` of the group goes to wavefront ``q % WAVES``). The wavefronts of a group trace on separate threads,
each with its own buffers and every stage of a bounce on its thread, so one wavefront's serial parts (Python,
the material sort, the samplers' calls) overlap the other's compiled stages and Embree, and nothing waits for
the slower half of a stage. Interleaving gives both wavefronts the same mix of the image (two halves of the
image's rows may cost very differently: sky against floor), in runs long enough that their camera rays stay
coherent and that the threads' radiance rows share a cache line at most at a run's ends.

The split depends on the pass alone, never on the number of threads: the image is the same bit for bit with
one thread or two.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from renderer.kernels import BLOCK

WAVEFRONT = 1 << 18
"""Paths traced together at most (a group of ``WAVES`` wavefronts): a pass of a large image runs several groups
one after the other, so the per-path buffers (~500 bytes a path) stay within ~130 MB whatever the image size."""

WAVES = 2
"""Wavefronts a group of paths is split into (each traced on its own thread when the tracer has several)."""

RUN = 64
"""Consecutive paths a wavefront takes before the next wavefront of its group takes as many."""


@dataclass(frozen=True)
class Wave:
    """One wavefront: its ``n`` paths are ``j0 + (r // block) * step + r % block`` for ``r < n``; path ``j``
    adds its light to radiance row ``j - row_offset``; ``key`` (its first path) seeds the draws of the
    samplers with tables."""

    j0: int
    n: int
    block: int
    step: int
    row_offset: int

    @property
    def key(self) -> int:
        return self.j0

    def paths(self) -> np.ndarray:
        """The paths, in row order (for tests and checks)."""
        r = np.arange(self.n, dtype=np.int64)
        return self.j0 + (r // self.block) * self.step + r % self.block


def waves(j0: int, j1: int, row_offset: int = 0) -> list[Wave]:
    """The wavefronts of paths ``[j0, j1)``: groups of at most :data:`WAVEFRONT` paths, each as :data:`WAVES`
    wavefronts interleaved in runs of :data:`RUN` (empty ones left out), in order."""
    out: list[Wave] = []
    step = RUN * WAVES
    for g0 in range(j0, j1, WAVEFRONT):
        length = min(j1, g0 + WAVEFRONT) - g0
        full, rest = divmod(length, RUN)
        for k in range(WAVES):
            n = max(0, (full - k + WAVES - 1) // WAVES) * RUN + (rest if full % WAVES == k else 0)
            if n:
                out.append(Wave(g0 + k * RUN, n, RUN, step, row_offset))
    return out


class Buffers:
    """The arrays of one wavefront, allocated once per size and reused by every wavefront its thread traces."""

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
        self.ng, self.ns, self.wo, self.origin, self.s_beta = (np.empty((n, 3), f64) for _ in range(5))
        self.s_path = np.empty(n, i64)
        # their light samples and BRDF samples
        self.l_wi_local, self.l_le, self.l_f, self.l_contrib = (np.empty((n, 3), f64) for _ in range(4))
        self.l_pdf, self.l_pdf_brdf = np.empty(n, f64), np.empty(n, f64)
        # what only makes shadow rays is kept in Embree's float32
        self.l_wi, self.l_tmax = np.empty((n, 3), f32), np.empty(n, f32)
        self.l_delta, self.l_cand = np.empty(n, np.bool_), np.empty(n, np.bool_)
        self.wi_local, self.f = np.empty((n, 3), f64), np.empty((n, 3), f64)
        self.pdf = np.empty(n, f64)
        self.points = np.empty((n, 2), f64)  # the BRDF samples' Sobol points, for the strategies with tables
        # shadow rays, and the numbers of next rays and shadow rays
        self.so32, self.sd32 = np.empty((n, 3), f32), np.empty((n, 3), f32)
        self.st32 = np.empty(n, f32)
        self.shadow_slot = np.empty(n, i64)
        self.counts = np.zeros(2, i64)
        # the stages' scratch rows: a block's frames and light points (surface stage) and uniforms (BRDF stage)
        self.frames, self.blk = np.empty((BLOCK, 11), f64), np.empty((BLOCK, 3), f64)
        # and the cells of a block's deferred MERL lookups (BRDF stage)
        self.mcell, self.mfrac = np.empty((BLOCK, 2, 3), i64), np.empty((BLOCK, 2, 3), f64)

    def __len__(self) -> int:
        return len(self.path)

    def touch(self) -> None:
        """Write every array once (zeros): their pages are mapped now rather than in a pass's stages."""
        for a in vars(self).values():
            a.fill(0)
