"""Environment-map importance sampling: the pdf is normalized, matches the samples, and equals pdf(d)."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from core.sampling.distributions import upper_bound, walk_upper_bound
from renderer.envmap import SMALL_ANGLE_COLUMNS, SMALL_ANGLE_ROWS, EnvironmentMap, guide_table


@njit(cache=False)
def _upper_bounds(a, lo, n, v):  # type: ignore[no-untyped-def]
    out = np.empty(v.shape[0], np.int64)
    for i in range(v.shape[0]):
        out[i] = upper_bound(a, lo, n, v[i])
    return out


@njit(cache=False)
def _guided(a, lo, n, v, start):  # type: ignore[no-untyped-def]
    out = np.empty(v.shape[0], np.int64)
    for i in range(v.shape[0]):
        out[i] = walk_upper_bound(a, lo, n, v[i], start[i])
    return out


def _map(rng: np.random.Generator) -> EnvironmentMap:
    img = rng.random((16, 32, 3)) ** 4 * 5.0
    img[3, 7] = 200.0  # a sun
    img[10:, :5] = 0.0  # a black region: zero density there
    return EnvironmentMap(img, scale=1.5, rotate_deg=30.0)


def test_pdf_integrates_to_one(rng: np.random.Generator) -> None:
    env = _map(rng)
    # midpoint rule on a fine (theta, phi) grid, 16x finer than the map's pixels
    nt, npb = 256, 512
    t = (np.arange(nt) + 0.5) / nt * np.pi
    p = (np.arange(npb) + 0.5) / npb * 2 * np.pi
    T, P = np.meshgrid(t, p, indexing="ij")
    d = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3)
    integral = (env.pdf(d) * np.sin(T).ravel()).sum() * (np.pi / nt) * (2 * np.pi / npb)
    assert abs(integral - 1.0) < 1e-3


def test_sample_pdf_equals_pdf_and_radiance_lookup(rng: np.random.Generator) -> None:
    env = _map(rng)
    d, le, pdf = env.sample(rng.random((20000, 4)))
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.allclose(pdf, env.pdf(d), rtol=1e-9)
    assert np.allclose(le, env.eval(d))
    assert np.all(pdf > 0)  # never samples the black region


@pytest.mark.parametrize("n", [0, 1, 2, 3, 7, 64, 1000])
def test_upper_bound_is_searchsorted_right(rng: np.random.Generator, n: int) -> None:
    """The branchless search of a CDF segment returns what np.searchsorted(side="right") does: ties (a value
    equal to an element, repeated elements) and values below or above every element included."""
    a = np.sort(np.round(rng.random(n + 10), 2))  # rounded: repeated values
    lo = 4
    v = np.concatenate([rng.random(500) * 1.2 - 0.1, a, [-1.0, 2.0]])
    expected = lo + np.searchsorted(a[lo : lo + n], v, side="right")
    assert np.array_equal(_upper_bounds(a, lo, n, v), expected)


@pytest.mark.parametrize("n", [0, 1, 2, 3, 7, 64, 1000])
def test_guided_search_is_searchsorted_right_from_any_start(rng: np.random.Generator, n: int) -> None:
    """The walk from a guess returns np.searchsorted(side="right") of the segment whatever the guess (inside,
    at either end or outside the segment), with ties and repeated elements."""
    a = np.sort(np.round(rng.random(n + 10), 2))
    lo = 4
    v = np.concatenate([rng.random(500) * 1.2 - 0.1, a, [-1.0, 2.0]])
    start = rng.integers(-3, n + 15, len(v))
    expected = lo + np.searchsorted(a[lo : lo + n], v, side="right")
    assert np.array_equal(_guided(a, lo, n, v, start), expected)


def test_sky_samples_pick_the_pixels_of_a_binary_search(rng: np.random.Generator) -> None:
    """With the guide table the sky's samples pick the pixel the inverse CDFs give (a row by the row CDF,
    then a column by that row's CDF): the guide only changes where the searches start."""
    env = _map(rng)
    u = np.concatenate([rng.random((20000, 2)), [[0.0, 0.0], [1 - 2**-53, 1 - 2**-53]]])
    d, _, _ = env.sample(u)
    row = np.minimum(np.searchsorted(env._row_cdf, u[:, 0], side="right"), env.h - 1)
    col = np.array(
        [np.searchsorted(env._col_cdf[r], x, side="right") for r, x in zip(row, u[:, 1], strict=True)]
    )
    col = np.minimum(col, env.w - 1)
    theta = np.arccos(np.clip(d[:, 1], -1, 1))
    phi = (np.arctan2(d[:, 2], d[:, 0]) - env.rotation) % (2 * np.pi)
    # the sample lies in its pixel (where it is not within rounding of the pixel's edge: the two fixed rows
    # fall on the map's first and last edges)
    u2, u3 = _in_pixel(env, u, row, col)
    inside = (u2 > 1e-9) & (u2 < 1 - 1e-9) & (u3 > 1e-9) & (u3 < 1 - 1e-9)
    assert inside.sum() > 19900
    r = np.minimum((theta / np.pi * env.h).astype(int), env.h - 1)
    c = np.minimum((phi / (2 * np.pi) * env.w).astype(int), env.w - 1)
    assert np.array_equal(r[inside], row[inside]) and np.array_equal(c[inside], col[inside])
    assert (row[-2], row[-1]) == (0, env.h - 1)
    guide = guide_table(env._row_cdf, env._col_cdf_flat, env.h, env.w)
    assert np.array_equal(guide, env._guide) and guide.dtype == np.int32
    # each entry is numpy's searchsorted at its abscissa (the rows' CDFs stored shifted by the row index)
    h, w = env.h, env.w
    assert np.array_equal(guide[:h], np.searchsorted(env._row_cdf, np.arange(h) / h, side="right"))
    for r in (0, h // 2, h - 1):
        segment = env._col_cdf_flat[r * w : (r + 1) * w]
        expected = r * w + np.searchsorted(segment, r + np.arange(w) / w, side="right")
        assert np.array_equal(guide[h + r * w : h + (r + 1) * w], expected)


def _in_pixel(env: EnvironmentMap, u: np.ndarray, row: np.ndarray, col: np.ndarray) -> tuple[np.ndarray, ...]:
    """Where ``u[:, 0]`` and ``u[:, 1]`` fell inside the chosen row's and column's CDF intervals, in [0, 1]
    (the column's in the shifted CDF the sampler searches, to round as it does)."""
    flat = env._col_cdf_flat
    lo = np.where(row > 0, env._row_cdf[np.maximum(row - 1, 0)], 0.0)
    u2 = np.clip((u[:, 0] - lo) / (env._row_cdf[row] - lo), 0.0, 1.0)
    k = row * env.w + col
    lo = np.where(col > 0, flat[np.maximum(k - 1, 0)], row.astype(float))
    u3 = np.clip((row + u[:, 1] - lo) / (flat[k] - lo), 0.0, 1.0)
    return u2, u3


def test_the_point_in_a_pixel_comes_from_the_pixel_choice(rng: np.random.Generator) -> None:
    """No further uniforms: the point inside the pixel is where the two uniforms fell inside its CDF intervals,
    so the in-pixel offsets are uniform (a Kolmogorov-Smirnov test at 1e-3 each) and a stratified pair (a
    grid of 64 x 64 points) puts points in a pixel's sub-cells evenly: the brightest pixel, chosen ~1 % of
    the time, has its offsets spread over the whole square."""
    from scipy import stats

    env = _map(rng)
    u = rng.random((100000, 2))
    row = np.minimum(np.searchsorted(env._row_cdf, u[:, 0], side="right"), env.h - 1)
    col = np.minimum(
        [np.searchsorted(env._col_cdf[r], x, side="right") for r, x in zip(row, u[:, 1], strict=True)],
        env.w - 1,
    )
    u2, u3 = _in_pixel(env, u, row, col)
    assert stats.kstest(u2, "uniform").pvalue > 1e-3 and stats.kstest(u3, "uniform").pvalue > 1e-3
    d, _, _ = env.sample(u)
    theta = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi * env.h - row
    assert np.all((theta > -1e-9) & (theta < 1 + 1e-9)) and np.abs(theta - u2).max() < 1e-9
    g = (np.arange(64) + 0.5) / 64
    grid = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    r = np.minimum(np.searchsorted(env._row_cdf, grid[:, 0], side="right"), env.h - 1)
    c = np.minimum(
        [np.searchsorted(env._col_cdf[i], x, side="right") for i, x in zip(r, grid[:, 1], strict=True)],
        env.w - 1,
    )
    top = np.bincount(r * env.w + c).argmax()
    a, b = _in_pixel(env, grid, r, c)
    mine = r * env.w + c == top
    assert mine.sum() >= 8 and np.ptp(a[mine]) > 0.5 and np.ptp(b[mine]) > 0.5


def _pixel_by_angles(env: EnvironmentMap, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pixel of each direction by its angles (acos and atan2, as the lookup was first written)."""
    theta = np.arccos(np.clip(d[:, 1], -1.0, 1.0))
    phi = np.arctan2(d[:, 2], d[:, 0]) - env.rotation
    phi = np.where(phi < 0, phi + 2 * np.pi, phi)
    phi = np.where(phi < 0, phi + 2 * np.pi, phi)
    row = np.minimum((theta / np.pi * env.h).astype(int), env.h - 1)
    col = np.minimum((phi / (2 * np.pi) * env.w).astype(int), env.w - 1)
    return row, col


@pytest.mark.parametrize(("h", "w"), [(1, 1), (1, 2), (3, 5), (16, 32), (64, 128), (7, 1000)])
@pytest.mark.parametrize("rotate_deg", [0.0, 33.0, 359.9])
def test_lookup_finds_the_pixel_of_the_angles(
    rng: np.random.Generator, h: int, w: int, rotate_deg: float
) -> None:
    """The lookup's pixel (found by guesses and a walk over the pixel edges, no acos or atan2) is the pixel of
    the direction's angles, for random directions, the poles, directions along the axes and directions just
    past every row and column edge (where the guesses are off); the radiance and the pdf are that pixel's."""
    img = rng.random((h, w, 3)) + 0.05
    env = EnvironmentMap(img, rotate_deg=rotate_deg)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    edge = env.rotation + 2 * np.pi * (np.arange(w) + 1e-6) / w  # just past each column's first edge
    near = np.stack([np.cos(edge) * 0.6, np.full(w, 0.8), np.sin(edge) * 0.6], axis=1)
    theta = np.pi * (np.arange(h) + 1e-7) / h  # just below each row's first edge
    near_row = np.stack([np.sin(theta) * np.cos(0.3), np.cos(theta), np.sin(theta) * np.sin(0.3)], axis=1)
    axes = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1], [0.6, 0.8, 0]])
    d = np.concatenate([d, near, near_row, axes.astype(float)])
    row, col = _pixel_by_angles(env, d)
    le, pdf = env.lookup(d)
    assert np.array_equal(le, env.image[row, col])
    sin_t = np.hypot(d[:, 0], d[:, 2])  # sin(theta) of a unit vector, accurate at the poles too
    expected = np.where(
        sin_t > 1e-12, env._pixel_pmf[row, col] * (w * h) / (2 * np.pi**2) / np.maximum(sin_t, 1e-300), 0.0
    )
    assert np.allclose(pdf, expected, rtol=1e-12, atol=0.0)


@pytest.mark.parametrize("rotate_deg", [0.0, 33.0, 359.9])
def test_samples_of_a_large_map_by_angle_addition(rng: np.random.Generator, rotate_deg: float) -> None:
    """A map of at least SMALL_ANGLE_ROWS x SMALL_ANGLE_COLUMNS pixels places its samples by angle addition from
    the pixel edges: the directions are those of theta = (row + u2) pi / h and phi = rotation + (col + u3)
    2 pi / w to 4e-15, unit length, in the pixel the inverse CDFs chose, with the pdf and radiance of that
    pixel's lookup."""
    h, w = SMALL_ANGLE_ROWS * 2, SMALL_ANGLE_COLUMNS * 2
    img = rng.random((h, w, 3)) ** 3 + 0.01
    env = EnvironmentMap(img, rotate_deg=rotate_deg)
    u = rng.random((20000, 2))
    d, le, pdf = env.sample(u)
    row = np.minimum(np.searchsorted(env._row_cdf, u[:, 0], side="right"), h - 1)
    col = np.minimum(
        [np.searchsorted(env._col_cdf[r], x, side="right") for r, x in zip(row, u[:, 1], strict=True)], w - 1
    )
    u2, u3 = _in_pixel(env, u, row, col)
    theta = (row + u2) / h * np.pi
    phi = (col + u3) / w * 2 * np.pi + env.rotation
    expected = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], axis=1)
    assert np.abs(d - expected).max() < 4e-15  # both sides round theta, phi and the edges: a few ulps
    assert np.abs(np.linalg.norm(d, axis=1) - 1.0).max() < 1e-15
    inside = (u2 > 1e-9) & (u2 < 1 - 1e-9) & (u3 > 1e-9) & (u3 < 1 - 1e-9)
    assert np.array_equal(env.image[row, col][inside], le[inside])
    # (at u2 or u3 within rounding of 1 the point rounds onto the next pixel's edge, as theta and phi did)
    assert np.allclose(pdf[inside], env.pdf(d)[inside], rtol=1e-9)
    assert np.allclose(le[inside], env.eval(d)[inside])


@pytest.mark.parametrize("rotate_deg", [-400.0, -90.0, 0.0, 179.0, 725.0])
def test_any_rotation_samples_its_own_pdf(rng: np.random.Generator, rotate_deg: float) -> None:
    """Rotations outside [0, 360) are reduced once; samples still carry pdf(d) and the radiance lookup, and
    the lookup is the unrotated map's at the rotated direction."""
    img = rng.random((16, 32, 3)) + 0.1
    env = EnvironmentMap(img, rotate_deg=rotate_deg)
    d, le, pdf = env.sample(rng.random((5000, 4)))
    assert np.allclose(pdf, env.pdf(d), rtol=1e-9)
    assert np.allclose(le, env.eval(d))
    a = np.radians(rotate_deg)  # phi = atan2(z, x) - rotation: undo the rotation about +y
    c, s_ = np.cos(a), np.sin(a)
    back = np.stack([d[:, 0] * c + d[:, 2] * s_, d[:, 1], d[:, 2] * c - d[:, 0] * s_], axis=1)
    plain = EnvironmentMap(img)
    inside = (
        np.abs(((np.arctan2(back[:, 2], back[:, 0]) % (2 * np.pi)) * 32 / (2 * np.pi)) % 1.0 - 0.5) < 0.45
    )
    assert inside.sum() > 4000  # away from column edges, where rounding may pick the neighbour
    assert np.allclose(plain.eval(back)[inside], le[inside])


def test_estimator_is_unbiased(rng: np.random.Generator) -> None:
    """E[L(d) cos+(d.y) / pdf(d)] equals the irradiance integral computed on a fine grid (5 standard errors)."""
    env = _map(rng)
    d, le, pdf = env.sample(rng.random((400000, 4)))
    g = le[:, 1] * np.maximum(d[:, 1], 0.0) / pdf
    est, se = g.mean(), g.std() / np.sqrt(len(g))
    nt, npb = 512, 1024
    t = (np.arange(nt) + 0.5) / nt * np.pi
    p = (np.arange(npb) + 0.5) / npb * 2 * np.pi
    T, P = np.meshgrid(t, p, indexing="ij")
    dd = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3)
    truth = (
        (env.eval(dd)[:, 1] * np.maximum(dd[:, 1], 0) * np.sin(T).ravel()).sum()
        * (np.pi / nt)
        * (2 * np.pi / npb)
    )
    assert abs(est - truth) < 5 * se + 1e-3 * truth, (est, truth, se)
