"""core.fastmath against the library's functions, over their whole ranges and at the edges."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from core import fastmath


@njit(cache=False)
def _apply(kind, x, y):
    out = np.empty((x.shape[0], 2))
    for i in range(x.shape[0]):
        if kind == 0:
            out[i, 0] = fastmath.atan2(y[i], x[i])
        elif kind == 1:
            out[i, 0] = fastmath.acos(x[i])
        else:
            out[i, 0], out[i, 1] = fastmath.sin_cos(x[i])
    return out


def test_atan2_every_quadrant_and_the_axes() -> None:
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.normal(size=100_000), [0.0, 0.0, 1.0, -1.0, 0.0, 1e-300, -1e-300, 5.0]])
    y = np.concatenate([rng.normal(size=100_000), [1.0, -1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 5.0]])
    got = _apply(0, x, y)[:, 0]
    want = np.arctan2(y, x)
    assert np.max(np.abs(got - want)) <= 1e-15
    assert np.all(np.abs(got) <= math.pi)


def test_acos_including_the_ends_and_beyond() -> None:
    x = np.concatenate(
        [np.linspace(-1.0, 1.0, 200_001), [1.0 - 1e-16, -1.0 + 1e-16, 1.0 + 1e-12, -1.0 - 1e-12]]
    )
    got = _apply(1, x, x)[:, 0]
    want = np.arccos(np.clip(x, -1.0, 1.0))
    assert np.max(np.abs(got - want)) <= 2e-15
    assert got[np.argmax(x)] == 0.0 and np.isfinite(got).all()


def test_sin_cos_over_two_turns_either_way() -> None:
    phi = np.concatenate([np.linspace(-4 * math.pi, 4 * math.pi, 400_001), [0.0, math.pi / 4, -math.pi / 4]])
    got = _apply(2, phi, phi)
    assert np.max(np.abs(got[:, 0] - np.sin(phi))) <= 1e-15
    assert np.max(np.abs(got[:, 1] - np.cos(phi))) <= 1e-15


def test_atan2_nan_and_infinite_arguments() -> None:
    """A NaN argument gives NaN (never a division by zero: ``(0, NaN)`` raised before the octant selects),
    and the infinite ones the library's angles where it has a finite answer."""
    nan, inf = math.nan, math.inf
    y = np.array([0.0, nan, nan, 1.0, -1.0, inf, 1.0, -inf])
    x = np.array([nan, 0.0, nan, nan, nan, 1.0, inf, 1.0])
    got = _apply(0, x, y)[:, 0]
    assert np.isnan(got[:5]).all()
    np.testing.assert_allclose(got[5:], np.arctan2(y[5:], x[5:]), atol=1e-15)


@njit(cache=False)
def _cells(c, n, out):
    for i in range(c.shape[0]):
        out[i, 0] = fastmath.polar_cell(c[i], n)
        out[i, 1] = min(int(fastmath.acos(c[i]) / fastmath.HALF_PI * n), n - 1)


def test_acos_estimate_within_its_stated_error() -> None:
    x = np.concatenate([np.linspace(-1.0, 1.0, 400_001), [-1.0, 1.0, 0.0, 1.0 + 1e-12]])
    got = np.array([fastmath.acos_estimate(v) for v in x[::97]] + [fastmath.acos_estimate(v) for v in x[-4:]])
    want = np.arccos(np.clip(np.concatenate([x[::97], x[-4:]]), -1.0, 1.0))
    assert np.max(np.abs(got - want)) <= 2.2e-8


@pytest.mark.parametrize("n", [1, 2, 16, 32, 64, 100, 128, 256])
def test_polar_cell_is_the_arc_cosines_cell(n: int) -> None:
    """The estimate's cell is taken only where it cannot differ from the exact arc cosine's: the same integer
    for random cosines and on, next to and 1e-13 away from every cell edge, at the horizon and at the pole."""
    edges = np.cos(np.arange(n + 1) * (math.pi / 2) / n)
    c = np.concatenate(
        [
            np.random.default_rng(n).random(200_000),
            edges,
            np.nextafter(edges, 0.0),
            np.nextafter(edges, 1.0),
            edges + 1e-13,
            edges - 1e-13,
            [0.0, 1.0, 5e-324],
        ]
    )
    c = c[(c >= 0.0) & (c <= 1.0)]
    out = np.empty((len(c), 2), dtype=np.int64)
    _cells(c, n, out)
    np.testing.assert_array_equal(out[:, 0], out[:, 1])
    assert out[:, 0].min() >= 0 and out[:, 0].max() <= n - 1


def test_atan2_estimate_within_its_stated_error() -> None:
    t = np.linspace(-math.pi, math.pi, 100_001)
    r = np.random.default_rng(3).uniform(1e-300, 10.0, t.shape)
    got = np.array([fastmath.atan2_estimate(y, x) for y, x in zip(r * np.sin(t), r * np.cos(t), strict=True)])
    err = np.abs(got - np.arctan2(r * np.sin(t), r * np.cos(t)))
    assert np.max(np.minimum(err, 2 * math.pi - err)) <= 1.7e-6 < fastmath.AZIMUTH_MARGIN / 5
    assert fastmath.atan2_estimate(0.0, 0.0) == 0.0
