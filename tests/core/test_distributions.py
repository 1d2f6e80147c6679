"""The sampling toolkit (core.sampling.distributions): the interval search at edges, zero-mass bins and ties,
the guide tables, exact counts and chi-square tests of the 1-D and 2-D distributions against their densities,
the warps' densities and inverses, and the refused inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from scipy import stats

from core.sampling.distributions import (
    build_cdf,
    build_cdf_2d,
    cosine_hemisphere,
    cosine_hemisphere_inverse,
    cosine_hemisphere_pdf,
    find_interval,
    find_intervals,
    guided_interval,
    interval_guides,
    pdf_2d,
    pdf_continuous,
    sample_2d,
    sample_continuous,
    sample_discrete,
    uniform_sphere,
    uniform_sphere_inverse,
    uniform_sphere_pdf,
    upper_bound,
    walk_interval,
    walk_upper_bound,
)


@njit(cache=True)
def _intervals(cdf, lo, hi, u):  # type: ignore[no-untyped-def]
    out = np.empty((u.shape[0], 3), dtype=np.int64)
    guides = interval_guides(cdf, np.array([lo, hi]), 8)
    for i in range(u.shape[0]):
        out[i, 0] = find_interval(cdf, lo, hi, u[i])
        out[i, 1] = walk_interval(cdf, lo, hi, u[i], (lo + hi) // 2)
        out[i, 2] = guided_interval(cdf, lo, hi, guides[0], u[i])
    return out


def _reference(cdf: np.ndarray, lo: int, hi: int, u: np.ndarray) -> np.ndarray:
    """The largest k in [lo, hi - 2] with cdf[k] <= u, lo when none: by numpy."""
    k = lo + np.searchsorted(cdf[lo:hi], u, side="right") - 1
    return np.clip(k, lo, hi - 2)


CDFS = [
    build_cdf([1.0]),  # a single bin
    build_cdf([1.0, 0.0, 0.0, 2.0, 1.0]),  # zero-mass bins in the middle: ties
    build_cdf([0.0, 0.0, 3.0, 1.0, 0.0]),  # zero-mass bins at both ends
    build_cdf(np.random.default_rng(1).random(37) ** 4),
]


@pytest.mark.parametrize("cdf", CDFS)
def test_find_interval_at_edges_ties_and_zero_mass_bins(cdf: np.ndarray) -> None:
    # every CDF value (the ties), its neighbours, the ends and outside them; inside a larger flat array
    u = np.concatenate([cdf, np.nextafter(cdf, -1.0), np.nextafter(cdf, 2.0), [-0.5, 0.0, 1.0, 1.5]])
    u = np.concatenate([u, np.random.default_rng(2).random(1000)])
    flat = np.concatenate([[7.0, 8.0], cdf, [-3.0]])
    lo, hi = 2, 2 + len(cdf)
    got = _intervals(flat, lo, hi, u)
    expected = _reference(flat, lo, hi, u)
    assert np.array_equal(got[:, 0], expected) and np.array_equal(got[:, 1], expected)
    unit = u >= 0.0  # a guide table reads u in [0, 1] (above 1: its last entries)
    assert np.array_equal(got[unit, 2], expected[unit])
    inside = (u >= 0.0) & (u < 1.0)
    k = got[inside, 0] - lo
    assert np.all(np.diff(cdf)[k] > 0.0)  # a zero-mass bin is never chosen


@njit(cache=True)
def _bounds(a, lo, n, v, start):  # type: ignore[no-untyped-def]
    out = np.empty((v.shape[0], 2), dtype=np.int64)
    for i in range(v.shape[0]):
        out[i, 0] = upper_bound(a, lo, n, v[i])
        out[i, 1] = walk_upper_bound(a, lo, n, v[i], start[i])
    return out


def test_upper_bound_is_searchsorted_right() -> None:
    rng = np.random.default_rng(3)
    for n in (0, 1, 2, 5, 64, 100):
        a = np.concatenate([[5.0], np.sort(rng.integers(0, 10, n).astype(float)), [-5.0]])
        v = rng.integers(-1, 12, 300).astype(float)
        start = rng.integers(-3, n + 5, 300)
        got = _bounds(a, 1, n, v, start)
        expected = 1 + np.searchsorted(a[1 : 1 + n], v, side="right")
        assert np.array_equal(got[:, 0], expected) and np.array_equal(got[:, 1], expected)


def test_interval_guides_are_the_answers_at_their_abscissae() -> None:
    cdf = np.concatenate([CDFS[1], CDFS[3]])
    offsets = np.array([0, len(CDFS[1]), len(cdf)])
    guides = interval_guides(cdf, offsets, 16)
    assert guides.dtype == np.int32 and guides.shape == (2, 17)
    for c in range(2):
        lo, hi = offsets[c], offsets[c + 1]
        assert np.array_equal(guides[c], _reference(cdf, lo, hi, np.arange(17) / 16))


@njit(cache=True)
def _draw_1d(cdf, u):  # type: ignore[no-untyped-def]
    out = np.empty((u.shape[0], 7))
    for i in range(u.shape[0]):
        k, p, rest = sample_discrete(cdf, 0, cdf.shape[0], u[i])
        x, pdf, kc = sample_continuous(cdf, 0, cdf.shape[0], u[i])
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = k, p, rest, x, pdf
        out[i, 5], out[i, 6] = kc, pdf_continuous(cdf, 0, cdf.shape[0], x)
    return out


def test_1d_sampling_matches_its_probabilities() -> None:
    weights = np.array([0.5, 0.0, 3.0, 1.0, 0.0, 0.25, 2.0])
    cdf = build_cdf(weights)
    p = weights / weights.sum()
    # exact counts: equally spaced u (stratified) give each bin its share to within one sample
    n = 70_000
    out = _draw_1d(cdf, (np.arange(n) + 0.5) / n)
    counts = np.bincount(out[:, 0].astype(int), minlength=len(weights))
    assert np.all(np.abs(counts - n * p) <= 1.0)
    assert np.allclose(out[:, 1], p[out[:, 0].astype(int)]) and np.allclose(
        out[:, 4], p[out[:, 0].astype(int)] * 7
    )
    assert np.array_equal(out[:, 5], out[:, 0]) and np.array_equal(out[:, 6], out[:, 4])
    # chi-square with a fixed seed, over sub-bins of the continuous variant (uniform inside each bin)
    out = _draw_1d(cdf, np.random.default_rng(4).random(200_000))
    sub = np.minimum((out[:, 3] * 28).astype(int), 27)
    expected = np.repeat(p, 4) / 4 * len(out)
    observed = np.bincount(sub, minlength=28)
    live = expected > 0
    assert observed[~live].sum() == 0
    assert stats.chisquare(observed[live], expected[live]).pvalue > 1e-3
    # the rest of u inside the bin is uniform on [0, 1]
    assert stats.kstest(out[:, 2], "uniform").pvalue > 1e-3


def test_single_bin_is_the_identity() -> None:
    u = np.random.default_rng(5).random(100)
    out = _draw_1d(build_cdf([2.5]), u)
    assert np.all(out[:, 0] == 0) and np.all(out[:, 1] == 1.0) and np.allclose(out[:, 3], u, atol=1e-15)


@njit(cache=True)
def _draw_2d(marginal, cond, u):  # type: ignore[no-untyped-def]
    out = np.empty((u.shape[0], 4))
    for i in range(u.shape[0]):
        x, y, pdf = sample_2d(marginal, cond, u[i, 0], u[i, 1])
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = x, y, pdf, pdf_2d(marginal, cond, x, y)
    return out


def test_2d_sampling_matches_its_density() -> None:
    rng = np.random.default_rng(6)
    weights = rng.random((6, 9)) ** 3
    weights[2] = 0.0  # an empty row
    weights[:, 4] = 0.0  # an empty column
    marginal, cond = build_cdf_2d(weights)
    out = _draw_2d(marginal, cond, rng.random((300_000, 2)))
    density = weights / weights.sum() * weights.size  # per unit area of [0, 1]^2
    r = np.minimum((out[:, 1] * 6).astype(int), 5)
    c = np.minimum((out[:, 0] * 9).astype(int), 8)
    assert np.allclose(out[:, 2], density[r, c]) and np.array_equal(out[:, 2], out[:, 3])
    observed = np.bincount(r * 9 + c, minlength=54)
    expected = (weights / weights.sum()).ravel() * len(out)
    live = expected > 0
    assert observed[~live].sum() == 0
    assert stats.chisquare(observed[live], expected[live]).pvalue > 1e-3
    # the density integrates to 1 over the square
    assert math.isclose(float(density.mean()), 1.0, rel_tol=1e-12)


@pytest.mark.parametrize(
    "weights, message",
    [
        ([0.0, 0.0, 0.0], "sum to zero"),
        ([1.0, np.nan, 2.0], "finite"),
        ([1.0, np.inf], "finite"),
        ([1.0, -0.5], "non-negative"),
        ([], "at least one bin"),
    ],
)
def test_bad_weights_are_refused(weights: list[float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        build_cdf(np.asarray(weights))
    if len(weights):
        with pytest.raises(ValueError, match=message):
            build_cdf_2d(np.asarray([weights, weights]))


@njit(cache=True)
def _warps(u):  # type: ignore[no-untyped-def]
    out = np.empty((u.shape[0], 12))
    for i in range(u.shape[0]):
        x, y, z = cosine_hemisphere(u[i, 0], u[i, 1])
        a, b = cosine_hemisphere_inverse(x, y, z)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = x, y, z, a, b
        out[i, 5] = cosine_hemisphere_pdf(z)
        x, y, z = uniform_sphere(u[i, 0], u[i, 1])
        a, b = uniform_sphere_inverse(x, y, z)
        out[i, 6], out[i, 7], out[i, 8], out[i, 9], out[i, 10] = x, y, z, a, b
        out[i, 11] = uniform_sphere_pdf()
    return out


def test_warps_are_unit_invertible_and_their_densities_integrate_to_one() -> None:
    u = np.random.default_rng(7).random((100_000, 2))
    out = _warps(u)
    for d, inv in ((out[:, 0:3], out[:, 3:5]), (out[:, 6:9], out[:, 9:11])):
        assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
        assert np.allclose(inv, u, atol=1e-9)
    assert np.all(out[:, 2] >= 0.0)
    # importance-sampling estimates of the densities' integrals: E[1] with weights p / p is trivial, so
    # integrate each density against the other's samples: the sphere's samples estimate the cosine density's
    # integral over the sphere (1), the cosine samples estimate the constant's over the hemisphere (1/2)
    cos_pdf = np.array([cosine_hemisphere_pdf(z) for z in out[:, 8]])
    assert math.isclose(float(np.mean(cos_pdf / out[:, 11])), 1.0, rel_tol=0.01)
    assert math.isclose(float(np.mean(out[:, 11] / out[:, 5])), 0.5, rel_tol=0.01)
    # the cosine warp's polar distribution: cos^2 theta is uniform
    assert stats.kstest(out[:, 2] ** 2, "uniform").pvalue > 1e-3
    assert stats.kstest((out[:, 8] + 1.0) / 2.0, "uniform").pvalue > 1e-3


def test_find_intervals_kernel() -> None:
    cdf = CDFS[3]
    u = np.random.default_rng(8).random(500)
    out = np.empty(500, dtype=np.int64)
    find_intervals(cdf, u, out)
    assert np.array_equal(out, _reference(cdf, 0, len(cdf), u))
