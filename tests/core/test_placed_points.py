"""A caller's own uniforms for a strategy's warp (``Sampler.sample_into(..., points=...)``, what the renderer
hands every strategy below its Sobol depth): the draws still follow the reported density (chi^2 with
independent points through that path, significance 0.01 with the Sidak correction over the cases), they are
a function of the points (same points, same draws; the strategy's own stream only for its other choices),
stratified points give stratified draws, and a bad shape is refused."""

from __future__ import annotations

import numpy as np
import pytest

from core.brdf import make_brdf
from core.chi2 import chi2_test, sidak_alpha
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.sampling import make_sampler

pytestmark = pytest.mark.usefixtures("private_tables")

CASES = [
    ("adaptive_exact", {}, "phong", {}, 40.0),
    ("adaptive_warp", {}, "ggx", {"alpha": 0.2}, 60.0),
    ("adaptive_warp", {}, "lambert", {}, 30.0),  # a flat table: the cosine density's own warp
    # half-vector trees in a frame turned with wo
    ("adaptive_warp", {}, "ward", {"sx": 0.05, "sy": 0.25}, 70.0),
    ("uniform_cdf", {}, "phong", {}, 40.0),
    ("factored", {}, "cook_torrance", {"m": 0.2}, 30.0),
    ("analytic", {}, "ggx", {"alpha": 0.2}, 60.0),
]
ALPHA = sidak_alpha(0.01, len(CASES))


def _draw(sampler, wo: np.ndarray, points: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    n = len(points)
    wi, pdf, f = np.empty((n, 3)), np.empty(n), np.empty((n, 3))
    sampler.sample_into(np.ascontiguousarray(np.tile(wo, (n, 1))), seed, wi, pdf, f, points=points)
    return wi, pdf


@pytest.mark.parametrize(("strategy", "options", "model", "params", "theta"), CASES)
def test_draws_from_placed_points_follow_the_reported_density(strategy, options, model, params, theta):
    sampler = make_sampler(strategy, make_brdf(model, params), **options)
    wo = degrees_to_dir(theta, 0.0)

    def sample(n: int, seed: int) -> np.ndarray:
        points = np.random.default_rng([seed, 7]).random((n, 2))
        return _draw(sampler, wo, points, seed)[0]

    def pdf(wi: np.ndarray) -> np.ndarray:
        return sampler.pdf(np.broadcast_to(wo, wi.shape), wi)

    result = chi2_test(sample, pdf, n_samples=200_000, seed=5, alpha=ALPHA, cell_tol=1e-2 / 200_000)
    assert result.passed, result.summary()
    # each draw carries the density pdf() reports at its direction
    points = np.random.default_rng(3).random((2000, 2))
    wi, p = _draw(sampler, wo, points, seed=4)
    ok = p > 0
    np.testing.assert_allclose(p[ok], pdf(wi[ok]), rtol=1e-6)


@pytest.mark.parametrize(("strategy", "options"), [("adaptive_warp", {}), ("uniform_cdf", {})])
def test_placed_points_decide_the_draws_and_keep_their_stratification(strategy, options):
    """The same points give the same draws whatever the seed (a warp reads nothing else), and a stratified
    set of points (one in each cell of a 32 x 32 grid) gives draws whose estimates of smooth integrals err
    far less than independent points' do (40 repeats each; three integrands, the spreads' ratios averaged):
    below 0.15 (both warps measure ~0.06; the adaptive warp's leaf chosen by one number along its leaves'
    order, before its tree was descended by both, 0.31 in `bench/placement.py`'s figures)."""
    sampler = make_sampler(strategy, make_brdf("phong", {"n": 8.0}), **options)
    wo = degrees_to_dir(35.0, 20.0)
    k = 32
    cells = np.stack(np.meshgrid(np.arange(k), np.arange(k), indexing="ij"), -1).reshape(-1, 2)
    a, _ = _draw(sampler, wo, (cells + 0.5) / k, seed=1)
    b, _ = _draw(sampler, wo, (cells + 0.5) / k, seed=2)
    np.testing.assert_array_equal(a, b)

    integrands = (lambda w: w[:, 0], lambda w: w[:, 1], lambda w: np.exp(3.0 * w[:, 0] - 2.0 * w[:, 1]))
    rng = np.random.default_rng(12)
    strat, iid = [], []
    for r in range(40):
        s = _draw(sampler, wo, (cells + rng.random((k * k, 2))) / k, seed=r)[0]
        i = _draw(sampler, wo, rng.random((k * k, 2)), seed=r)[0]
        strat.append([g(s).mean() for g in integrands])
        iid.append([g(i).mean() for g in integrands])
    ratio = np.mean(np.std(strat, axis=0) / np.std(iid, axis=0))
    assert ratio < 0.15, ratio


def test_points_of_the_wrong_shape_are_refused():
    sampler = make_sampler("adaptive_warp", make_brdf("phong"))
    wo = np.tile(degrees_to_dir(30.0, 0.0), (10, 1))
    wi, pdf, f = np.empty((10, 3)), np.empty(10), np.empty((10, 3))
    for bad in (np.zeros((9, 2)), np.zeros((10, 3)), np.zeros((10, 1)), np.zeros(10)):
        with pytest.raises(ValueError, match=r"points must be \(10, 2\)"):
            sampler.sample_into(wo, 1, wi, pdf, f, points=bad)


def test_points_on_the_edges_of_the_square_give_finite_draws():
    """Points at 0 (a Sobol point can be exactly 0) and just below 1, with corners that vanish on a leaf's
    edge (the exact mode's leaves store them relative to the largest, so some are 0): every draw finite,
    with a finite positive density."""
    for mode in ("exact", "warp"):
        sampler = make_sampler(f"adaptive_{mode}", make_brdf("ggx", {"alpha": 0.05}))
        edge = np.array([0.0, 1e-300, 0.5, 1.0 - 2.0**-53])
        points = np.stack(np.meshgrid(edge, edge, indexing="ij"), -1).reshape(-1, 2)
        for theta in (0.0, 45.0, 89.9):
            wi, pdf = _draw(sampler, degrees_to_dir(theta, 0.0), points, seed=1)
            assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)


@pytest.mark.parametrize("strategy", ["adaptive_exact", "uniform_cdf", "factored"])
@pytest.mark.parametrize("bad", [np.nan, -0.25, 1.0, np.inf])
def test_points_outside_the_unit_square_are_refused(strategy, bad):
    """NaN, negative, 1 or infinite: a clear error naming the range, and the caller's arrays untouched."""
    sampler = make_sampler(strategy, make_brdf("phong"))
    wo = np.tile(degrees_to_dir(30.0, 0.0), (10, 1))
    wi, pdf, f = np.full((10, 3), -7.0), np.full(10, -7.0), np.full((10, 3), -7.0)
    points = np.full((10, 2), 0.5)
    points[3, 1] = bad
    with pytest.raises(ParameterError, match=r"points must be numbers in \[0, 1\)"):
        sampler.sample_into(wo, 1, wi, pdf, f, points=points)
    assert np.all(wi == -7.0) and np.all(pdf == -7.0) and np.all(f == -7.0)


@pytest.mark.parametrize("strategy", ["uniform_cdf", "compress_cdf"])
def test_a_strategy_without_a_third_uniform_draws_nothing_of_its_own_beside_the_points(strategy):
    """``third_uniform = False``: given points, ``sample_into`` draws no uniforms of its own, and its draws are
    the ones its warp makes from the points with any third column beside them (it never reads one)."""
    sampler = make_sampler(strategy, make_brdf("ggx", {"alpha": 0.2}))
    assert not sampler.third_uniform and sampler.warp_dims == (0, 1)
    n = 4096
    rng = np.random.default_rng(8)
    wo = np.ascontiguousarray(np.tile(degrees_to_dir(50.0, 30.0), (n, 1)))
    points = rng.random((n, 2))
    wi, pdf = _draw(sampler, wo[0], points, seed=1)
    for third in (np.zeros(n), rng.random(n), np.full(n, 1.0 - 2.0**-53)):
        u = np.ascontiguousarray(np.column_stack([points, third]))
        wi3, pdf3 = np.empty((n, 3)), np.empty(n)
        sampler._directions_into(wo, u, wi3, pdf3)
        np.testing.assert_array_equal(wi, wi3)
        np.testing.assert_array_equal(pdf, pdf3)
