"""core.fastmath against the library's functions, over their whole ranges and at the edges."""

from __future__ import annotations

import math

import numpy as np
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
