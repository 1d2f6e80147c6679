"""Embree queries (``renderer.accel``): the wavefront's closest hits and occlusion, chunked or in one call."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from renderer import embree
from renderer.accel import BACKENDS, MISS, Accel


def _quad(backend: str = "direct") -> Accel:
    """The square ``[-1, 1]^2`` of the plane ``z = 0``."""
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
    return Accel(v, np.array([[0, 1, 2], [0, 2, 3]]), threads=2, chunk=1000, backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_trace_hits_and_misses_in_one_call_or_in_chunks(backend: str) -> None:
    """Rays from ``z = 2`` straight down hit the square at distance 2 where ``|x|, |y| < 1`` (``prim`` 0 or
    1, barycentrics inside the triangle) and miss elsewhere (``prim`` = ``MISS``, ``t`` = inf, not Embree's
    far limit); a batch traced on the calling thread in one call equals the same batch in chunks on two
    threads."""
    accel = _quad(backend)
    assert accel.backend == backend
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


def _scene_mesh() -> tuple[np.ndarray, np.ndarray]:
    """A sphere inside an open box and a torus: closed and open surfaces, many triangles."""
    parts = [
        trimesh.creation.icosphere(subdivisions=3, radius=0.5),
        trimesh.creation.box(extents=(3, 3, 3)),
        trimesh.creation.torus(0.9, 0.2).apply_translation((0, 0, 0.6)),
    ]
    mesh = trimesh.util.concatenate(parts)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_direct_packets_equal_embreex_run() -> None:
    """Embree called from the compiled packet loops finds what embreex's ``run`` finds: the same triangle
    for every ray, distances to float32 rounding, barycentrics to 1e-5 (the packet kernels round differently), the same occlusion, for random rays from
    inside and outside the box, batch sizes that are and are not multiples of the packet width (0, 1, 15, 16,
    17, 4099 rays) and limits ``t_max`` that end before, at about and after the first hit."""
    v, f = _scene_mesh()
    direct, reference = Accel(v, f, backend="direct"), Accel(v, f, backend="embreex")
    rng = np.random.default_rng(11)
    for n in (0, 1, 15, 16, 17, 4099):
        o = rng.uniform(-2.5, 2.5, (n, 3)).astype(np.float32)
        d = rng.normal(size=(n, 3))
        d = (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)
        out = []
        for accel in (direct, reference):
            prim, t = np.empty(n, np.int32), np.empty(n, np.float32)
            u, w = np.empty(n, np.float32), np.empty(n, np.float32)
            accel.trace(o, d, prim, t, u, w)
            out.append((prim, t, u, w))
        (p1, t1, u1, w1), (p2, t2, u2, w2) = out
        assert np.array_equal(p1, p2)
        hit = p1 != MISS
        assert np.all(np.isinf(t1[~hit])) and np.all(np.isfinite(t1[hit]))
        np.testing.assert_allclose(t1[hit], t2[hit], rtol=1e-6)
        np.testing.assert_allclose(u1[hit], u2[hit], atol=1e-5)
        np.testing.assert_allclose(w1[hit], w2[hit], atol=1e-5)
        t_max = np.where(hit, t2 * rng.choice([0.5, 2.0], n), rng.uniform(0.1, 10, n))
        assert np.array_equal(direct.occluded(o, d, t_max), reference.occluded(o, d, t_max))
        assert np.array_equal(direct.occluded(o, d), hit)
        hits = direct.intersect(o, d)
        assert hits.prim.dtype == np.int64 and np.array_equal(hits.prim, p1)
    direct.close()
    reference.close()


def test_unknown_backend_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    """A misspelt ``BRDF_STUDIO_EMBREE`` names the variable and the choices."""
    monkeypatch.setenv("BRDF_STUDIO_EMBREE", "optix")
    with pytest.raises(ValueError, match="BRDF_STUDIO_EMBREE='optix': expected one of direct, embreex"):
        _quad(backend=None)  # type: ignore[arg-type]


def test_missing_library_falls_back_to_embreex(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without a loadable Embree library the accelerator warns once and traces through embreex's ``run``,
    with the same answers."""
    monkeypatch.setattr(embree, "_LIBRARY", None)
    monkeypatch.setattr(embree, "library_path", lambda: None)
    with pytest.warns(RuntimeWarning, match="no Embree 4 library found"):
        accel = _quad()
    assert accel.backend == "embreex"
    o = np.array([[0.2, 0.3, 1.0], [3.0, 0.0, 1.0]], np.float32)
    d = np.array([[0, 0, -1], [0, 0, -1]], np.float32)
    assert accel.intersect(o, d).prim[1] == MISS and accel.intersect(o, d).t[0] == pytest.approx(1.0)


@pytest.mark.parametrize("backend", BACKENDS)
def test_degenerate_rays_miss_without_harm(backend: str) -> None:
    """A NaN origin, a NaN direction and a zero direction are misses (no hit, no occlusion, ``t`` = inf) and
    leave the good rays of the same packet alone."""
    accel = _quad(backend)
    o = np.array([[0, 0, 1], [np.nan, 0, 1], [0, 0, 1], [0, 0, 1], [0.5, 0.5, 2]], np.float32)
    d = np.array([[0, 0, -1], [0, 0, -1], [np.nan, 0, -1], [0, 0, 0], [0, 0, -1]], np.float32)
    hits = accel.intersect(o, d)
    assert np.array_equal(hits.prim == MISS, [False, True, True, True, False])
    assert np.allclose(hits.t[[0, 4]], [1.0, 2.0]) and np.all(np.isinf(hits.t[1:4]))
    assert np.array_equal(accel.occluded(o, d), [True, False, False, False, True])
