"""Embree queries (``renderer.accel``): the wavefront's closest hits and occlusion, chunked or in one call."""

from __future__ import annotations

import numpy as np

from renderer.accel import MISS, Accel


def _quad() -> Accel:
    """The square ``[-1, 1]^2`` of the plane ``z = 0``."""
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
    return Accel(v, np.array([[0, 1, 2], [0, 2, 3]]), threads=2, chunk=1000)


def test_trace_hits_and_misses_in_one_call_or_in_chunks() -> None:
    """Rays from ``z = 2`` straight down hit the square at distance 2 where ``|x|, |y| < 1`` (``prim`` 0 or
    1, barycentrics inside the triangle) and miss elsewhere (``prim`` = ``MISS``, ``t`` = inf, not Embree's
    far limit); a batch traced on the calling thread in one call equals the same batch in chunks on two
    threads."""
    accel = _quad()
    rng = np.random.default_rng(3)
    n = 5000
    o = np.zeros((n, 3), np.float32)
    o[:, :2] = rng.uniform(-2, 2, (n, 2))
    o[:, 2] = 2
    d = np.tile(np.array([0, 0, -1], np.float32), (n, 1))
    out = {}
    for parallel in (True, False):
        prim, t = np.full(n, 7, np.int32), np.zeros(n, np.float32)
        u, v = np.zeros(n, np.float32), np.zeros(n, np.float32)
        accel.trace(o, d, prim, t, u, v, parallel=parallel)
        out[parallel] = prim, t, u, v
    for a, b in zip(out[True], out[False], strict=True):
        assert np.array_equal(a, b)
    prim, t, u, v = out[False]
    inside = (np.abs(o[:, 0]) < 1) & (np.abs(o[:, 1]) < 1)
    assert 0.1 * n < inside.sum() < 0.9 * n
    assert np.all(np.isin(prim[inside], [0, 1])) and np.allclose(t[inside], 2.0)
    assert np.all((u[inside] >= 0) & (v[inside] >= 0) & (u[inside] + v[inside] <= 1))
    assert np.all(prim[~inside] == MISS) and np.all(np.isinf(t[~inside]))
    blocked = accel.occluded(o, d, np.where(np.arange(n) % 2 == 0, 1.5, 3.0), parallel=False)
    assert np.array_equal(blocked, inside & (np.arange(n) % 2 == 1))
    accel.close()
