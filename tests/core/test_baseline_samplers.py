"""The seed's comparison samplers (UniformCDF, CompressCDF, Factored) and RIS: exact densities, proven by
chi-square tests (1e6 samples, alpha = 0.01 Sidak-corrected over the tests of this module), the integral of
the pdf, sample/pdf agreement, and the building blocks (Douglas-Peucker, NMF) on their own."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.brdf import LUMINANCE, make_brdf
from core.chi2 import chi2_test, sampler_functions
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.sampling import make_sampler
from core.sampling.factored import nmf
from core.sampling.ris import ris_sample
from core.sampling.tabulated import douglas_peucker
from core.study_lights import CapLight, LatLongEnvironment

BASELINES = ["uniform_cdf", "compress_cdf", "factored"]
FAST_CASES = [
    ("phong", "uniform_cdf", 30.0, "sphere"),
    ("phong", "compress_cdf", 60.0, "disk"),
    ("ward", "compress_cdf", 30.0, "sphere"),
    ("ward", "factored", 30.0, "disk"),
    ("lambert", "factored", 80.0, "disk"),
    ("blinn", "uniform_cdf", 89.0, "disk"),
]
N_TESTS = len(FAST_CASES)
# The densities are piecewise constant: a coarse per-cell tolerance (0.1 expected counts) is plenty where the
# rule's nodes see the steps, as in the fast cases (nodes even in cos theta, order 2: seconds a case).
CHI2 = dict(n_samples=1_000_000, cell_tol=1e-7, order=2)
# The sweep's cases include lobes at normal incidence and narrow compressed segments: the tables' cells are even
# in theta (1.4 degrees in the first rows) and the chi-square grid's polar cells even in cos theta (~16 degrees
# wide at the pole), so nodes even in cos missed the first rows at every level of refinement (a lobe at
# normal incidence integrated up to 0.5 % off, 48 of the 240 cases failed); nodes even in theta
# (core.chi2._cell_rule) of order 4 see them, to 1 expected count a cell (plenty against ~200 counts a cell).
CHI2_SWEEP = dict(n_samples=1_000_000, cell_tol=1e-6, order=4, variable="theta")

_cache: dict[tuple[str, str], object] = {}


def _sampler(model: str, name: str):
    key = (model, name)
    if key not in _cache:
        _cache[key] = make_sampler(name, make_brdf(model))
    return _cache[key]


@pytest.mark.parametrize("model,name,theta,domain", FAST_CASES)
def test_chi2(model, name, theta, domain):
    s = _sampler(model, name)
    r = chi2_test(
        *sampler_functions(s, degrees_to_dir(theta, 20.0)), domain=domain, seed=11, n_tests=N_TESTS, **CHI2
    )
    assert r.passed, r.reason
    assert abs(r.integral - 1.0) < 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("name", BASELINES)
@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0, 80.0, 89.0])
@pytest.mark.parametrize("domain", ["sphere", "disk"])
@pytest.mark.parametrize(
    "model", ["lambert", "phong", "blinn", "lewis", "ward", "cook_torrance", "ggx", "oren_nayar"]
)
def test_chi2_sweep(model, name, theta, domain):
    s = _sampler(model, name)
    r = chi2_test(
        *sampler_functions(s, degrees_to_dir(theta, 20.0)),
        domain=domain,
        seed=12,
        n_tests=8 * 3 * 5 * 2,
        **CHI2_SWEEP,
    )
    assert r.passed, r.reason


def test_a_wrong_pdf_is_caught():
    """The test can fail: the UniformCDF density scaled up by 10% on half the hemisphere is rejected."""
    s = _sampler("phong", "uniform_cdf")
    sample, pdf = sampler_functions(s, degrees_to_dir(30.0))

    def wrong(wi):
        return pdf(wi) * np.where(wi[:, 1] > 0.0, 1.1, 0.9)

    r = chi2_test(sample, wrong, domain="disk", seed=3, integral_tol=0.2, **CHI2)
    assert not r.passed


@pytest.mark.parametrize("name", BASELINES)
@pytest.mark.parametrize("model", ["phong", "ward"])
def test_pdf_of_sample_matches_pdf_function(model, name):
    """(The integral of each density is checked by the chi-square tests above, which integrate it per cell.)"""
    s = _sampler(model, name)
    for theta in (0.0, 45.0, 89.9):
        wo = degrees_to_dir(theta, 70.0)
        drawn = s.sample(wo, 20_000, seed=5)
        wi, pdf = drawn.wi, drawn.pdf
        assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
        np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-9)
        up = wi[:, 2] > 1e-6  # below the horizon the half-vector map degenerates near wi = -wo
        np.testing.assert_allclose(s.pdf(wo, wi[up]), pdf[up], rtol=1e-9)


@pytest.mark.parametrize("name", BASELINES)
def test_grazing_and_hard_cases_are_finite(name):
    for model, params in (("phong", {"n": 1e4}), ("ward", {"sx": 0.005, "sy": 0.005})):
        s = make_sampler(name, make_brdf(model, params))
        for theta in (0.0, 89.9, 90.0):
            wo = degrees_to_dir(theta)
            drawn = s.sample(wo, 5000, seed=1)
            wi, pdf, f = drawn.wi, drawn.pdf, drawn.f
            assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(np.isfinite(f))


def test_compression_shrinks_memory_and_keeps_the_estimate():
    u = _sampler("phong", "uniform_cdf")
    c = _sampler("phong", "compress_cdf")
    assert c.info()["memory_bytes"] < u.info()["memory_bytes"] / 5
    wo = degrees_to_dir(30.0)
    estimates = []
    for s in (u, c):
        drawn = s.sample(wo, 400_000, seed=9)
        g = (drawn.f @ LUMINANCE) * np.maximum(drawn.wi[:, 2], 0.0) / drawn.pdf
        estimates.append((g.mean(), g.std() / np.sqrt(len(g))))
    (a, sa), (b, sb) = estimates
    assert abs(a - b) < 5.0 * np.hypot(sa, sb)  # both unbiased for the same albedo


def test_bad_options_are_rejected_clearly():
    b = make_brdf("lambert")
    with pytest.raises(ParameterError, match="n_theta"):
        make_sampler("uniform_cdf", b, n_theta=0)
    with pytest.raises(
        ParameterError, match=r"'tol' of the sampler 'compress_cdf' must be a number in \(0, 0.5\]"
    ):
        make_sampler("compress_cdf", b, tol=0.0)
    with pytest.raises(ParameterError, match="the sampler 'factored' has no option 'terms'"):
        make_sampler("factored", b, terms=3)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 10.0), min_size=3, max_size=80), st.floats(1e-4, 0.2))
def test_douglas_peucker_error_is_within_tolerance(increments, tol):
    y = np.concatenate([[0.0], np.cumsum(increments)])
    y = y / y[-1] if y[-1] > 0 else np.linspace(0.0, 1.0, len(y))
    x = np.linspace(0.0, 1.0, len(y))
    keep = douglas_peucker(x, y, tol)
    assert keep[0] == 0 and keep[-1] == len(y) - 1 and np.all(np.diff(keep) > 0)
    assert np.max(np.abs(np.interp(x, x[keep], y[keep]) - y)) <= tol + 1e-12


def test_nmf_recovers_a_non_negative_rank_two_matrix(rng):
    W = rng.uniform(0.1, 1.0, (30, 2))
    H = rng.uniform(0.1, 1.0, (2, 40))
    Y = W @ H
    W2, H2 = nmf(Y, 2, iterations=2000)
    assert np.all(W2 >= 0) and np.all(H2 >= 0)
    assert np.linalg.norm(W2 @ H2 - Y) / np.linalg.norm(Y) < 1e-2


@pytest.mark.parametrize("light_kind", ["cap", "environment"])
def test_ris_is_unbiased(light_kind):
    """RIS (8 candidates from the cosine sampler) agrees with light sampling, the best estimator here,
    within 5 combined standard errors."""
    brdf = make_brdf("phong")
    wo = degrees_to_dir(30.0)
    if light_kind == "cap":
        light = CapLight(axis=degrees_to_dir(35.0, 180.0), half_angle=0.2, radiance=50.0)
    else:
        light = LatLongEnvironment(LatLongEnvironment.procedural_sky(64, 32))

    def g(wi):
        return (brdf.eval(wo, wi) @ LUMINANCE) * np.maximum(wi[:, 2], 0.0) * light.radiance(wi)

    wl, pl = light.sample(400_000, np.random.default_rng(1))
    ref = g(wl) / pl
    kept = ris_sample(make_sampler("cosine", brdf), wo, light.radiance, 100_000, 8, seed=2)
    np.testing.assert_array_equal(kept.f, brdf.eval(wo, kept.wi))
    est = g(kept.wi) * kept.weight
    assert np.all(np.isfinite(est))
    diff = abs(est.mean() - ref.mean())
    assert diff < 5.0 * np.hypot(est.std() / np.sqrt(len(est)), ref.std() / np.sqrt(len(ref)))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    steps=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=40),
    queries=st.lists(st.floats(0.0, 1.0, exclude_max=True), min_size=1, max_size=30),
    size=st.integers(1, 9),
    guess=st.integers(-3, 50),
)
def test_the_narrowed_searches_find_the_binary_searchs_cell(steps, queries, size, guess):
    """The tabulated CDFs' draws search inside a guide table's interval (``guided_interval``) and their
    densities step from a guessed cell (``walk_interval``): both must return exactly ``find_interval``'s index
    (numpy's ``searchsorted``), for any nondecreasing CDF from 0 to 1 (flat steps included), placed after other
    CDFs in the flat array."""
    from core.sampling.distributions import find_interval, guided_interval, interval_guides, walk_interval

    cdf = np.concatenate([[0.0], np.cumsum(steps)])
    cdf = cdf / cdf[-1] if cdf[-1] > 0 else np.linspace(0.0, 1.0, len(cdf))
    cdf[-1] = 1.0
    flat = np.concatenate([[0.0, 0.5, 1.0], cdf])  # a first CDF of two cells, then this one
    offsets = np.array([0, 3, len(flat)], dtype=np.int64)
    guides = interval_guides(flat, offsets, size)
    lo, hi = 3, len(flat)
    for u in queries:
        want = find_interval(flat, lo, hi, u)
        assert want == min(max(lo + int(np.searchsorted(flat[lo:hi], u, side="right")) - 1, lo), hi - 2)
        assert guided_interval(flat, lo, hi, guides[1], u) == want
        assert walk_interval(flat, lo, hi, u, lo + guess) == want


@pytest.mark.parametrize("name", BASELINES)
@pytest.mark.parametrize(("model", "params"), [("phong", {"n": 1e4}), ("ward", {"sx": 0.01, "sy": 0.5})])
def test_hard_views_draw_finite_samples_with_their_own_density(model, params, name):
    """Views whose azimuth is (almost) undefined — exactly normal, x and y ~1e-160 or ~1e-300 (squares below the
    smallest float) — and grazing ones (89.99 degrees, cos 1e-17), through the renderer's in-place calls: every
    draw finite with a density equal to ``pdf`` there; views on or below the horizon draw nothing."""
    s = make_sampler(name, make_brdf(model, params))
    views = np.array([[0, 0, 1.0], [1e-160, 0, 1.0], [1e-300, 1e-300, 1.0], [1.0, 0, 1e-17],
                      [np.sin(np.radians(89.99)), 0, np.cos(np.radians(89.99))], [0, -1.0, 0], [0.6, 0.8, -1e-12]])  # fmt: skip
    views /= np.linalg.norm(views, axis=1)[:, None]
    wo = np.repeat(views, 500, axis=0)
    n = len(wo)
    wi, pdf, f = np.empty((n, 3)), np.empty(n), np.empty((n, 3))
    s.sample_into(wo, 3, wi, pdf, f, points=np.random.default_rng(0).random((n, 2)))
    f_l, pdf_l = np.empty((n, 3)), np.empty(n)
    s.eval_pdf_where(wo, wi, np.ones(n, dtype=bool), f_l, pdf_l)
    for a in (wi, pdf, f, f_l, pdf_l):
        assert np.all(np.isfinite(a))
    above = wo[:, 2] > 0.0
    assert np.all(pdf[above] > 0.0) and np.all(pdf[~above] == 0.0) and np.all(f[~above] == 0.0)
    np.testing.assert_allclose(pdf_l[above], pdf[above], rtol=1e-9, atol=0)


@pytest.mark.parametrize(
    ("model", "params"),
    [
        ("lambert", {}),
        ("ggx", {"alpha": 0.2}),
        ("oren_nayar", {}),
        ("phong", {}),
        ("ward", {"sx": 0.05, "sy": 0.25}),
    ],
)
def test_factored_draws_carry_the_density_pdf_reports_to_the_bit(model, params):
    """Each draw's density is ``pdf()``'s at the returned direction exactly: read from the drawn cell when the
    draw is inside it (without the half-vector reparameterization), recomputed from the direction otherwise.
    Uniforms on and next to every knot of the factors' CDFs put draws on cell edges, where the two could part."""
    sampler = make_sampler("factored", make_brdf(model, params))
    rng = np.random.default_rng(21)
    knots = np.unique(np.concatenate([sampler._u_cdf.ravel(), sampler._v_cdf.ravel()]))
    knots = knots[(knots > 0.0) & (knots < 1.0)]
    edges = np.concatenate([knots, np.nextafter(knots, 0.0), np.nextafter(knots, 1.0), knots + 1e-12, [0.0]])
    n = 20_000
    u = rng.random((n, 3))
    u[: n // 2, 1] = rng.choice(edges, n // 2)
    u[n // 4 : 3 * n // 4, 2] = rng.choice(edges, n // 2)
    u = np.clip(u, 0.0, 1.0 - 2.0**-53)
    d = rng.normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2]) + 1e-3
    wo = np.ascontiguousarray(d / np.linalg.norm(d, axis=1, keepdims=True))
    wi, pdf = np.empty((n, 3)), np.empty(n)
    sampler._directions_into(wo, np.ascontiguousarray(u), wi, pdf)
    np.testing.assert_array_equal(pdf, sampler.pdf(wo, wi))
    assert np.all(np.isfinite(pdf)) and np.mean(pdf > 0.0) > 0.9


@pytest.mark.parametrize("strategy", ["uniform_cdf", "compress_cdf", "factored"])
def test_densities_next_to_an_azimuth_edge_are_their_cells(strategy):
    """The densities find ``phi_i``'s cell from an arc tangent's estimate (error < 2e-6) and from the exact
    angle only within that error of an edge: a direction 1e-9 rad to either side of an edge has the density of
    its own side's cell (the one a point well inside that cell has), never the neighbour's."""
    sampler = make_sampler(strategy, make_brdf("ggx", {"alpha": 0.3}))
    wo = degrees_to_dir(40.0, 0.0)  # isotropic tables turned by phi_o = 0: the table's azimuth is phi_i
    if strategy == "factored":
        n = sampler.settings.n_phi_p
        edges = np.arange(1, n) * (2.0 * np.pi / n)
        width = 2.0 * np.pi / n
    else:
        edges = np.unique(sampler._cx)
        edges = edges[(edges > 0.0) & (edges < 2.0 * np.pi)]
        width = float(np.min(np.diff(np.unique(sampler._cx))))
    theta = np.radians(35.3)  # inside a polar cell of every table here
    differ = 0
    for e in edges:
        for side in (-1.0, 1.0):
            near, inside = e + side * 1e-9, e + side * 0.25 * width
            wi = np.array(
                [
                    [np.sin(theta) * np.cos(p), np.sin(theta) * np.sin(p), np.cos(theta)]
                    for p in (near, inside)
                ]
            )
            p_near, p_inside = sampler.pdf(np.tile(wo, (2, 1)), wi)
            assert p_near == p_inside, (e, side)
        differ += (
            sampler.pdf(wo, wi[:1])[0]
            != sampler.pdf(
                wo,
                np.array(
                    [[np.sin(theta) * np.cos(e - 1e-9), np.sin(theta) * np.sin(e - 1e-9), np.cos(theta)]]
                ),
            )[0]
        )
    assert differ > len(edges) // 4  # the two sides of an edge do differ (the test can tell the cells apart)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    keep=st.sets(st.integers(1, 63), max_size=40),
    n_cells=st.sampled_from([1, 5, 16, 64, 100]),
)
def test_cell_knots_start_at_the_segment_holding_each_cells_start(keep, n_cells):
    """``cell_knots``: the knot where a density's search starts is the last one at or below the cell's lower
    edge (a simplified curve's knots are some of a 64-cell grid's edges), and never the curve's last knot."""
    from core.sampling.tabulated import cell_knots

    knots = np.array(sorted({0, 64} | keep))
    starts = cell_knots([knots, np.array([0, 64])], 64, n_cells)
    assert starts.shape == (2, n_cells) and np.all(starts[1] == 0)
    for g, k in enumerate(starts[0].astype(int)):
        edge = g * 64 / n_cells
        assert knots[k] <= edge < knots[k + 1]


@pytest.mark.parametrize(
    ("model", "params"), [("lambert", {}), ("ggx", {"alpha": 0.3}), ("ward", {"sx": 0.05, "sy": 0.25})]
)
def test_compressed_densities_do_not_depend_on_where_the_marginal_search_starts(model, params):
    """``compress_cdf``'s densities start the marginal's search at the knot of ``theta_i``'s row
    (``cell_knots``): directions exactly on every knot of the marginals, one ulp of ``cos`` either side and
    inside the segments have the density a search from each curve's first knot finds, to the bit."""
    sampler = make_sampler("compress_cdf", make_brdf(model, params))
    blind = make_sampler("compress_cdf", make_brdf(model, params))
    blind._mrow = np.zeros_like(blind._mrow)
    rng = np.random.default_rng(4)
    wo_rows, wi_rows = [], []
    for theta_o in (5.0, 40.0, 75.0, 89.0):
        wo = degrees_to_dir(theta_o, 30.0)
        b = min(int(np.radians(theta_o) / (np.pi / 2) * sampler.n_theta_o), sampler.n_theta_o - 1)
        lo, hi = sampler._moff[b * sampler.n_phi_o], sampler._moff[b * sampler.n_phi_o + 1]
        xs = np.asarray(sampler._mx[lo:hi])
        cos_t = np.concatenate(
            [-xs, np.nextafter(-xs, 2.0), np.nextafter(-xs, -2.0), -0.5 * (xs[1:] + xs[:-1])]
        )
        cos_t = cos_t[(cos_t >= 0.0) & (cos_t <= 1.0)]
        phi = rng.random(len(cos_t)) * 2.0 * np.pi
        s = np.sqrt(1.0 - cos_t**2)
        wi_rows.append(np.stack([s * np.cos(phi), s * np.sin(phi), cos_t], axis=1))
        wo_rows.append(np.tile(wo, (len(cos_t), 1)))
    wo, wi = np.concatenate(wo_rows), np.concatenate(wi_rows)
    pdf = sampler.pdf(wo, wi)
    np.testing.assert_array_equal(pdf, blind.pdf(wo, wi))
    assert np.all(np.isfinite(pdf)) and np.mean(pdf > 0.0) > 0.9
    # and the start is the answer inside every row (the walk takes no step there)
    edges = -np.cos(np.arange(sampler.n_theta + 1) * (np.pi / 2) / sampler.n_theta)
    mids = 0.5 * (edges[1:] + edges[:-1])
    for b in range(len(sampler._moff) - 1):
        lo, hi = sampler._moff[b], sampler._moff[b + 1]
        found = np.searchsorted(np.asarray(sampler._mx[lo:hi]), mids, side="right") - 1
        np.testing.assert_array_equal(sampler._mrow[b], found)
