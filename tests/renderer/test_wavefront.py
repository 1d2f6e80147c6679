"""A pass's split into interleaved wavefronts (``renderer.wavefront``) and the camera stage's paths."""

from __future__ import annotations

import numpy as np
import pytest

from renderer.stages.records import PassKeys, PinholeCamera, Rays
from renderer.wavefront import RUN, WAVEFRONT, WAVES, waves


def _camera() -> PinholeCamera:
    """A 16 x 8 pixel camera at the origin looking down -z."""
    return PinholeCamera(16, 8, np.zeros(3), np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0]),
                         np.array([0.0, 1.0, 0.0]), 0.5, 2.0)  # fmt: skip


@pytest.mark.parametrize(
    ("j0", "j1"),
    [(0, 1), (5, 68), (0, RUN), (3, 3 + RUN + 1), (0, 2 * RUN), (100, 1100), (7, 7 + WAVEFRONT + 130),
     (0, 3 * WAVEFRONT)],
)  # fmt: skip
def test_waves_partition_the_paths(j0: int, j1: int) -> None:
    """Every path of ``[j0, j1)`` is in exactly one wavefront; a wavefront holds at most half a group (runs of
    ``RUN`` alternating between the two of its group) and its key (first path) is unique in the pass."""
    ws = waves(j0, j1, row_offset=j0)
    paths = np.concatenate([w.paths() for w in ws])
    assert np.array_equal(np.sort(paths), np.arange(j0, j1))
    assert all(0 < w.n <= WAVEFRONT // WAVES for w in ws)
    assert len({w.key for w in ws}) == len(ws)
    assert all(w.row_offset == j0 for w in ws)
    if j1 - j0 >= WAVES * RUN:  # both wavefronts of the first group take runs of RUN paths in turn
        first = [w.paths()[:RUN] for w in ws[:WAVES]]
        assert np.array_equal(np.concatenate(first), np.arange(j0, j0 + WAVES * RUN))


def test_camera_stage_traces_the_paths_of_its_wavefront() -> None:
    """The camera stage's path of row ``r`` is the wavefront's ``r``-th path, and its pixel and sample number
    follow from that path (the same ray as a wavefront of consecutive paths gives it)."""
    from renderer.stages.camera import camera_stage

    n_pix = 128
    cam, keys = _camera(), PassKeys(n_pix, 3, np.uint64(77), np.uint64(0))

    def run(j0: int, n: int, block: int, step: int) -> tuple[np.ndarray, np.ndarray]:
        rays = Rays.empty(n)
        camera_stage(0, n, j0, block, step, keys, cam, rays)
        return rays.path, rays.d

    whole_path, whole_d = run(0, 3 * n_pix, 3 * n_pix, 3 * n_pix)
    for w in waves(0, 3 * n_pix):
        path, d = run(w.j0, w.n, w.block, w.step)
        assert np.array_equal(path, w.paths())
        assert np.array_equal(d, whole_d[path])
    assert np.array_equal(whole_path, np.arange(3 * n_pix))


@pytest.mark.parametrize(
    ("a", "block", "step"), [(5, 384, 384), (70, 64, 128), (127, 64, 128), (128, 64, 128)]
)
def test_camera_stage_rows_from_any_start(a: int, block: int, step: int) -> None:
    """Rows ``[a, b)`` of the camera stage, started anywhere in a run (it advances pixel, row, column and sample
    number path by path), are the rows a call over ``[0, b)`` gives: the same paths and rays, across the
    image's row ends and the pixels' wrap to the next sample."""
    from renderer.qmc import key, sobol2
    from renderer.stages.camera import camera_rays, camera_stage

    n_pix, n = 128, 384
    cam, keys = _camera(), PassKeys(n_pix, 3, np.uint64(77), np.uint64(0))

    def run(lo: int) -> tuple[np.ndarray, np.ndarray]:
        rays = Rays.empty(n)
        rays.d.fill(0.0)
        rays.path.fill(-1)
        camera_stage(lo, n, 9, block, step, keys, cam, rays)
        return rays.path, rays.d

    whole_path, whole_d = run(0)
    path, d = run(a)
    assert np.array_equal(path[a:], whole_path[a:])
    assert np.array_equal(d[a:], whole_d[a:])
    assert np.all(path[:a] == -1)
    # the paths are the wavefront's, and their rays those of their pixel and sample number
    q = np.arange(n) // block
    assert np.array_equal(whole_path, 9 + q * step + np.arange(n) % block)
    pixel, sample = whole_path % n_pix, 3 + whole_path // n_pix
    jitter = np.array(
        [
            sobol2(int(s), np.uint64(key(np.uint64(key(np.uint64(77), int(p))), 0)))
            for p, s in zip(pixel, sample, strict=True)
        ]
    )
    _, expect = camera_rays(pixel, jitter, cam)
    assert np.array_equal(whole_d, expect)
