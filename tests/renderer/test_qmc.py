"""The wavefront's random numbers (renderer.qmc): Owen-scrambled Sobol pairs are stratified and uniform,
keyed uniforms are uniform and independent of each other.

Statistical checks are chi-square tests at significance 1e-4 with fixed keys (deterministic: the same
numbers every run)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chisquare

from renderer.qmc import sobol2_points, uniforms

ALPHA = 1e-4


@pytest.mark.parametrize("key", [0, 1, 0xDEADBEEF, 2**63 + 12345])
def test_every_power_of_two_prefix_is_stratified(key: int) -> None:
    """The first 2^k points of a pixel's sequence put exactly one point in each of the 2^k elementary
    intervals of every shape (2^a x 2^(k-a)): the (0, 2)-sequence property, which Owen scrambling keeps."""
    for k in (4, 8, 10):
        p = sobol2_points(np.arange(2**k, dtype=np.int64), np.uint64(key))
        assert np.all((p >= 0.0) & (p < 1.0))
        for a in range(k + 1):
            nx, ny = 2**a, 2 ** (k - a)
            cells = np.floor(p[:, 0] * nx).astype(np.int64) * ny + np.floor(p[:, 1] * ny).astype(np.int64)
            assert len(np.unique(cells)) == 2**k, (key, k, a)


def test_later_blocks_are_stratified_too() -> None:
    """Samples 2^k ... 2^(k+1) - 1 (a later run of passes) form a stratified set of their own."""
    p = sobol2_points(np.arange(256, 512, dtype=np.int64), np.uint64(77))
    cells = np.floor(p[:, 0] * 16).astype(np.int64) * 16 + np.floor(p[:, 1] * 16).astype(np.int64)
    assert len(np.unique(cells)) == 256


def test_a_sample_is_uniform_over_keys() -> None:
    """Sample ``s`` of the sequence, over many keys (pixels), is uniform in the unit square (what makes a
    pixel's estimate unbiased at every sample count): chi-square over a 16 x 16 grid."""
    for s in (0, 1, 5):
        p = np.array([sobol2_points(np.array([s], dtype=np.int64), np.uint64(k))[0] for k in range(20000)])
        counts = np.histogram2d(p[:, 0], p[:, 1], bins=16, range=[[0, 1], [0, 1]])[0].ravel()
        assert chisquare(counts).pvalue > ALPHA, s


def test_different_keys_give_unrelated_sequences() -> None:
    a = sobol2_points(np.arange(64, dtype=np.int64), np.uint64(1))
    b = sobol2_points(np.arange(64, dtype=np.int64), np.uint64(2))
    assert abs(np.corrcoef(a[:, 0], b[:, 0])[0, 1]) < 0.5
    assert not np.allclose(a, b)


def test_keyed_uniforms_are_uniform_and_independent() -> None:
    """Uniforms of consecutive keys and dimensions: uniform (chi-square over 64 bins) and pairwise
    uncorrelated (|r| < 5 / sqrt(n))."""
    u = uniforms(np.arange(100_000, dtype=np.uint64), 4)
    assert np.all((u >= 0.0) & (u < 1.0))
    for d in range(4):
        counts = np.histogram(u[:, d], bins=64, range=(0, 1))[0]
        assert chisquare(counts).pvalue > ALPHA, d
    r = np.corrcoef(u.T)
    assert np.all(np.abs(r[np.triu_indices(4, 1)]) < 5 / np.sqrt(len(u)))
    lag = np.corrcoef(u[:-1, 0], u[1:, 0])[0, 1]
    assert abs(lag) < 5 / np.sqrt(len(u))
