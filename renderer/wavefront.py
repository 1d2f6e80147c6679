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

from renderer.stages.primitives import BLOCK
from renderer.stages.records import BsdfSamples, Hits, LightSamples, Rays, Scratch, ShadowRays, Vertices

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
    """The records of one wavefront (:mod:`renderer.stages.records`), allocated once per size and reused by
    every wavefront its thread traces."""

    def __init__(self, n: int):
        self.rays = Rays.empty(n)
        """the current bounce's rays"""
        self.hits = Hits.empty(n)
        """their closest hits"""
        self.vertices = Vertices.empty(n)
        """the surface vertices, sorted by material"""
        self.light = LightSamples.empty(n)
        """their light samples"""
        self.bsdf = BsdfSamples.empty(n)
        """their BRDF samples"""
        self.shadow = ShadowRays.empty(n)
        """the light samples' shadow rays"""
        self.counts = np.zeros(2, np.int64)
        """the numbers of next rays and of shadow rays (:func:`renderer.stages.continuation.continue_stage`)"""
        self.scratch = Scratch.empty(BLOCK)
        """the stages' scratch rows"""

    def __len__(self) -> int:
        return len(self.rays.path)

    def arrays(self) -> list[np.ndarray]:
        """Every array of the records."""
        out = [self.counts]
        for record in (self.rays, self.hits, self.vertices, self.light, self.bsdf, self.shadow, self.scratch):
            out.extend(record)
        return out

    def touch(self) -> None:
        """Write every array once (zeros): their pages are mapped now rather than in a pass's stages."""
        for a in self.arrays():
            a.fill(0)
