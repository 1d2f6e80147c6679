"""The adaptive quadtree sampler: its samples follow its pdf (chi-square), the pdf is a density, the trees keep
their promises (acceptance >= 1/n_max, no leaf-bound violation), batch and single sampling agree, the weight
``f cos / pdf`` is constant, tables are cached correctly, and hard cases stay finite.

Statistics: every chi-square test draws 1e6 samples with a fixed seed and uses alpha = 0.01, Sidak-corrected
over the tests of its group (the group size is written next to it). The full sweep (every model x theta_o in
{0, 30, 60, 80, 89} x n_max in {1.3, 2, 3} x {sphere, disk}) is marked slow; the default suite runs a subset.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.chi2 import chi2_test, integrate_pdf, sampler_functions, two_sample_test
from core.geometry import degrees_to_dir
from core.model import LUMINANCE, all_models, make_brdf
from core.sampler import make_sampler
from core.samplers.adaptive import AdaptiveSampler, clear_memory_cache

N = 1_000_000
THETAS = (0.0, 30.0, 60.0, 80.0, 89.0)
N_MAXES = (1.3, 2.0, 3.0)
MODELS = all_models()

# default suite: (model, theta_o, n_max, domain, phi_o); Ward in the third quadrant of phi_o, where its
# trees (built for the first quadrant) are mirrored in x and y
FAST_CASES = [
    ("lambert", 30.0, 2.0, "sphere", 17.0),
    ("phong", 80.0, 1.3, "disk", 17.0),
    ("ward", 60.0, 2.0, "sphere", 197.0),
    ("minnaert", 89.0, 3.0, "disk", 17.0),
    ("cook_torrance", 0.0, 2.0, "disk", 17.0),
]
FAST_CASES = [c for c in FAST_CASES if c[0] in {m.name for m in MODELS}]


@pytest.fixture(autouse=True)
def _private_cache(private_tables):
    """Every test gets its own table cache folder and an empty in-memory cache (tests/core/conftest.py)."""


def _adaptive(name, n_max=2.0, **kw) -> AdaptiveSampler:
    return make_sampler("adaptive", make_brdf(name, kw.pop("params", None)), n_max=n_max, **kw)


def _weights(sampler, wo, wi, pdf):
    f = sampler.eval(np.broadcast_to(wo, wi.shape), wi) @ LUMINANCE
    return f * np.maximum(wi[:, 2], 0.0) / pdf


def _check_sampler(sampler, theta, domain, n_tests, seed=11, phi=17.0):
    wo = degrees_to_dir(theta, phi)
    sample, pdf = sampler_functions(sampler, wo)
    res = chi2_test(sample, pdf, N, domain=domain, seed=seed, n_tests=n_tests)
    assert res.passed, f"{sampler.brdf.name} theta={theta}: {res.summary()}"
    assert sampler.bound_violations == 0
    return res


@pytest.mark.parametrize(("name", "theta", "n_max", "domain", "phi"), FAST_CASES, ids=lambda v: str(v))
def test_chi2_fast_subset(name, theta, n_max, domain, phi):
    # Sidak over the 5 fast cases
    _check_sampler(_adaptive(name, n_max), theta, domain, n_tests=len(FAST_CASES), phi=phi)


BRUSHED = {"sx": 0.05, "sy": 0.25}
"""The demo scene's brushed steel: a strongly anisotropic Ward lobe."""


def test_mirrored_quadrants_sample_the_mirror_images():
    """A mirror-symmetric model keeps trees for the first quadrant of phi_o only (18 phi bins, not 72): a
    direction in another quadrant draws the mirror images of the first quadrant's samples, with the same
    pdf, from the same tree."""
    sampler = _adaptive("ward", params=BRUSHED)
    assert sampler.table.mirror and sampler.table.n_phi == 18
    first, pdf = sampler.sample(degrees_to_dir(50.0, 20.0), 4000, seed=5)
    for phi, mirror in ((160.0, (-1.0, 1.0, 1.0)), (200.0, (-1.0, -1.0, 1.0)), (340.0, (1.0, -1.0, 1.0))):
        wo = degrees_to_dir(50.0, 20.0) * mirror
        np.testing.assert_allclose(wo, degrees_to_dir(50.0, phi), atol=1e-15)
        wi, pdf_m = sampler.sample(wo, 4000, seed=5)
        np.testing.assert_array_equal(wi, first * mirror)
        np.testing.assert_allclose(pdf_m, pdf, rtol=1e-12)
        np.testing.assert_array_equal(sampler.pdf(np.broadcast_to(wo, wi.shape), wi), pdf_m)
    assert sampler.info()["trees"] == 1
    assert sampler.bound_violations == 0


def test_directions_on_the_mirror_planes_and_the_horizon_stay_finite():
    """``wo`` on the folds of the quadrant layout (x or y exactly 0, signed zeros), the normal, 89.99 degrees
    and the horizon: finite samples, non-negative pdfs equal to ``pdf(wo, wi)``, no bound violation."""
    sampler = _adaptive("ward", params=BRUSHED)
    t = math.radians(89.99)
    for wo in (
        (0.0, 0.0, 1.0), (-0.0, -0.0, 1.0), (-0.0, 0.5, math.sqrt(0.75)), (0.5, -0.0, math.sqrt(0.75)),
        (-math.sin(t), 0.0, math.cos(t)), (0.0, -1.0, 0.0),
    ):  # fmt: skip
        wo = np.array(wo)
        wi, pdf = sampler.sample(wo, 3000, seed=2)
        assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
        np.testing.assert_array_equal(sampler.pdf(np.broadcast_to(wo, wi.shape), wi), pdf)
    assert sampler.bound_violations == 0


def test_the_whole_circle_layout_gives_the_same_density():
    """Without the trait the table lays 72 phi bins over the whole circle (a model that is not symmetric):
    the same densities, to the normalizers' interpolation tolerance, in every quadrant; its own key."""
    import dataclasses

    from core.model import BRDF, Traits

    mirrored = make_brdf("ward", BRUSHED)
    plain_model = dataclasses.replace(mirrored.model, traits=Traits.RECIPROCAL)
    plain = BRDF(plain_model, {}, params=mirrored.params)
    a = make_sampler("adaptive", mirrored, n_max=2.0)
    b = make_sampler("adaptive", plain, n_max=2.0)
    assert not b.table.mirror and b.table.n_phi == 72 and b.table.key != a.table.key
    for phi in (22.0, 158.0, 202.0, 338.0):  # one quadrant-folded bin, four whole-circle bins
        wo = degrees_to_dir(50.0, phi)
        wi, pdf = b.sample(wo, 4000, seed=2)
        np.testing.assert_array_equal(b.pdf(np.broadcast_to(wo, wi.shape), wi), pdf)
        np.testing.assert_allclose(a.pdf(np.broadcast_to(wo, wi.shape), wi), pdf, rtol=1e-4)
    assert b.info()["trees"] == 4 and a.info()["trees"] == 1
    assert a.bound_violations == 0 and b.bound_violations == 0


@pytest.mark.slow
@pytest.mark.parametrize(
    ("model", "n_max"),
    [pytest.param(m, n, id=f"{m.name}-{n}") for m in MODELS for n in N_MAXES],
)
def test_chi2_full_sweep(model, n_max):
    n_tests = len(MODELS) * len(N_MAXES) * len(THETAS) * 2
    sampler = make_sampler("adaptive", model.bind(), n_max=n_max)
    for theta in THETAS:
        for domain in ("sphere", "disk"):
            _check_sampler(sampler, theta, domain, n_tests=n_tests)
        acc = sampler.acceptance(degrees_to_dir(theta))[0]
        assert acc >= 1.0 / n_max, f"acceptance {acc:.3f} < 1/{n_max} at theta={theta}"


@pytest.mark.parametrize("name", ["lambert", "phong", "ward", "minnaert", "lewis"])
def test_pdf_integrates_to_one(name):
    if name not in {m.name for m in MODELS}:
        pytest.skip(f"model {name} not in the library")
    sampler = _adaptive(name)
    for theta in (0.0, 60.0, 89.9):
        wo = degrees_to_dir(theta, 40.0)
        total = integrate_pdf(
            lambda wi, wo=wo: sampler.pdf(np.broadcast_to(wo, wi.shape), wi), (32, 32), 1e-7
        )
        assert abs(total - 1.0) < 1e-3, f"{name} theta={theta}: integral {total}"


def test_the_normalizer_is_accurate_for_a_lobe_held_by_few_leaves(monkeypatch):
    """At ``n_max`` 3 a few large leaves hold Cook-Torrance's lobe, and their 6 x 6 rule alone puts the
    normalizer 0.11 % off at theta_o = 60 degrees (the reported pdf integrated to 1.0011); the normalizer's
    quadrature quarters the boxes whose rule disagrees with their quarters' (``QUAD_TOL`` 5e-5). Checked
    against the chi-square library's independent self-refining cell rule, with and without the refinement,
    so the test can fail."""
    import core.quadtree as quadtree

    if "cook_torrance" not in {m.name for m in MODELS}:
        pytest.skip("model cook_torrance not in the library")
    wo = degrees_to_dir(60.0)

    def integral() -> float:
        sampler = _adaptive("cook_torrance", 3.0, cache=False)
        return integrate_pdf(lambda wi: sampler.pdf(np.broadcast_to(wo, wi.shape), wi), (32, 32), 1e-7)

    monkeypatch.setattr(quadtree, "QUAD_LEVELS", 0)  # the leaves' own rules only
    assert abs(integral() - 1.0) > 1e-3
    clear_memory_cache()
    monkeypatch.undo()
    assert abs(integral() - 1.0) < 2e-4


FAST_MODELS = [m for m in MODELS if m.name in ("lambert", "phong", "minnaert", "cook_torrance", "lafortune")]


def _acceptance_floor(model, n_max):
    """1/n_max for every model: the construction refines until the acceptance reaches it at every
    normalizer node of the bin (tests/core/test_adaptive_build.py checks it over the whole bin)."""
    return 1.0 / n_max


@pytest.mark.parametrize("model", FAST_MODELS, ids=[m.name for m in FAST_MODELS])
def test_acceptance_and_zero_variance(model):
    _acceptance_and_zero_variance(model)


@pytest.mark.slow
@pytest.mark.parametrize("model", MODELS, ids=[m.name for m in MODELS])
def test_acceptance_and_zero_variance_every_model(model):
    _acceptance_and_zero_variance(model)


def _acceptance_and_zero_variance(model):
    """Per-trial acceptance I/V >= 1/n_max at the default parameters; the mean number of trials measured
    agrees with 1/acceptance; the luminance weight f cos / pdf equals I(wo) for every sample."""
    sampler = make_sampler("adaptive", model.bind(), n_max=2.0)
    for theta in (30.0, 80.0):
        wo = degrees_to_dir(theta, 25.0)
        acc = float(sampler.acceptance(wo)[0])
        floor = _acceptance_floor(model, 2.0)
        assert acc >= floor, f"{model.name} theta={theta}: acceptance {acc:.3f} < {floor:.3f}"
        wi, pdf, trials = sampler.sample_with_trials(np.repeat(wo[None, :], 20_000, axis=0), seed=3)
        # trials are geometric with mean 1/acc: 20000 draws give a standard error of sqrt(1-acc)/acc/141
        assert (
            abs(trials.mean() - 1.0 / acc) < 5.0 * math.sqrt(1.0 - acc) / acc / math.sqrt(len(trials)) + 1e-9
        )
        assert np.all(np.isfinite(wi)) and np.all(pdf > 0.0)
        w = _weights(sampler, wo, wi, pdf)
        norm = sampler.normalizer(wo)[0]
        assert np.std(w) / np.mean(w) < 1e-9
        np.testing.assert_allclose(w, norm, rtol=1e-9)
    assert sampler.bound_violations == 0


def test_pdf_equals_the_returned_pdf_and_seeds_reproduce():
    sampler = _adaptive("phong", 1.3)
    rng = np.random.default_rng(5)
    theta = np.radians(rng.choice([0.0, 10.0, 45.0, 70.0, 85.0, 89.9], 2000) + rng.uniform(-0.4, 0.4, 2000))
    theta = np.abs(theta)
    phi = rng.uniform(0.0, 2 * math.pi, 2000)
    wo = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    wi, pdf = sampler.sample_each(wo, seed=9)
    np.testing.assert_array_equal(sampler.pdf(wo, wi), pdf)
    wi2, pdf2 = sampler.sample_each(wo, seed=9)
    np.testing.assert_array_equal(wi, wi2)
    wi3, _ = sampler.sample_each(wo, seed=10)
    assert not np.array_equal(wi, wi3)
    # sample i depends only on (seed, i): a prefix gives the same first rows
    wi4, _ = sampler.sample_each(wo[:100], seed=9)
    np.testing.assert_array_equal(wi4, wi[:100])
    one = degrees_to_dir(45.0, 10.0)
    wi5, pdf5 = sampler.sample(one, 5000, seed=1)
    np.testing.assert_array_equal(sampler.pdf(np.broadcast_to(one, wi5.shape), wi5), pdf5)
    assert sampler.bound_violations == 0


def test_batch_and_single_sampling_agree():
    """Two-sample chi-square (alpha = 0.01) between the batch variant and independent single draws."""
    sampler = _adaptive("phong", 2.0)
    wo = degrees_to_dir(60.0, 33.0)
    batch, _ = sampler.sample(wo, N, seed=1)
    single, _ = sampler.sample_each(np.repeat(wo[None, :], N, axis=0), seed=2)
    for domain in ("sphere", "disk"):
        res = two_sample_test(batch, single, domain=domain, n_tests=2)
        assert res.passed, res.summary()
    assert sampler.bound_violations == 0


def test_a_wrong_pdf_is_caught():
    """The adaptive samples of Phong n=100 against the pdf of Phong n=70: the test must fail."""
    right = _adaptive("phong", params={"n": 100})
    wrong = _adaptive("phong", params={"n": 70})
    wo = degrees_to_dir(30.0)
    sample, _ = sampler_functions(right, wo)
    _, pdf = sampler_functions(wrong, wo)
    res = chi2_test(sample, pdf, N, domain="sphere", seed=4)
    assert not res.passed and res.p_value < 1e-6, res.summary()


@pytest.mark.parametrize(
    ("name", "params", "theta"),
    [
        ("phong", {"n": 10000}, 30.0),
        ("phong", {"n": 10000}, 89.9),
        ("ward", {"sx": 0.005, "sy": 0.005}, 60.0),
        ("lambert", {}, 90.0),
        ("minnaert", {"k": 0.2}, 89.9),
    ],
)
def test_hard_cases_stay_finite(name, params, theta):
    if name not in {m.name for m in MODELS}:
        pytest.skip(f"model {name} not in the library")
    sampler = _adaptive(name, params=params)
    wo = degrees_to_dir(theta, 12.0)
    wi, pdf = sampler.sample(wo, 20_000, seed=2)
    assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-12)
    w = _weights(sampler, wo, wi, pdf)
    assert np.all(np.isfinite(w))
    if theta == 90.0:  # f vanishes: the cosine fallback, with its own pdf
        np.testing.assert_allclose(pdf, wi[:, 2] / math.pi)
    else:
        assert np.std(w) / np.mean(w) < 1e-9
    assert sampler.bound_violations == 0


def test_invalid_options_are_user_errors():
    from core.errors import ParameterError

    brdf = make_brdf("lambert")
    for bad in (1.0, 0.5, -2.0, float("nan"), "x"):
        with pytest.raises(ParameterError, match="n_max"):
            make_sampler("adaptive", brdf, n_max=bad)
    with pytest.raises(ParameterError, match="projection"):
        make_sampler("adaptive", brdf, projection="mercator")
    for name in ("phi_bins", "max_nodes"):
        for bad in (0, -4):
            with pytest.raises(ParameterError, match=name):
                make_sampler("adaptive", make_brdf("ward"), **{name: bad})
    for bad in (-1, 17, 2.5, float("nan"), "x", True):
        with pytest.raises(ParameterError, match="max_splits must be a whole number from 0 to 16"):
            make_sampler("adaptive", brdf, max_splits=bad)
    with pytest.raises(ParameterError, match="phi_bins must be a whole number >= 1"):
        make_sampler("adaptive", make_brdf("ward"), phi_bins=float("nan"))
    with pytest.raises(ParameterError, match="positive"):
        make_sampler("adaptive", brdf).sample(degrees_to_dir(0.0), 0)


def test_tables_are_cached_on_disk_and_corruption_is_detected(tmp_path):
    folder = tmp_path / "tables"
    wo = degrees_to_dir(40.0)
    first = _adaptive("phong", cache=folder)
    a, pa = first.sample(wo, 1000, seed=3)
    assert first.info()["trees"] == 1 and first.info()["cache_hits"] == 0
    files = list(folder.rglob("*.npz"))
    assert len(files) == 1
    clear_memory_cache()
    second = _adaptive("phong", cache=folder)
    b, pb = second.sample(wo, 1000, seed=3)
    assert second.info()["cache_hits"] == 1
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(pa, pb)
    # corrupt the file: it is detected, rebuilt, and the result is the same
    data = files[0].read_bytes()
    files[0].write_bytes(data[: len(data) // 2])
    clear_memory_cache()
    third = _adaptive("phong", cache=folder)
    c, pc = third.sample(wo, 1000, seed=3)
    assert third.info()["cache_hits"] == 0
    np.testing.assert_array_equal(a, c)
    assert third.table.cache.rejected == 1
    # different parameters or n_max give a different key
    assert _adaptive("phong", n_max=3.0, cache=folder).table.key != first.table.key
    assert _adaptive("phong", params={"n": 50}, cache=folder).table.key != first.table.key


def test_bins_built_together_on_threads_equal_bins_built_one_by_one(monkeypatch):
    """A table asked for several missing bins at once builds them on threads: the same trees, bit for bit, as
    building them one at a time."""
    import core.quadtree_table as qt
    from core.quadtree import BuildOptions

    brdf = make_brdf("ward", BRUSHED)
    wo = np.stack([degrees_to_dir(t, p) for t, p in ((10, 5), (40, 33), (70, 61), (85, 80), (89.2, 44))])
    together = qt.QuadtreeTable(brdf.model, brdf.params, BuildOptions())
    monkeypatch.setattr(qt, "BUILD_THREADS", 4)
    together.ensure_rows(wo)
    monkeypatch.setattr(qt, "BUILD_THREADS", 1)
    alone = qt.QuadtreeTable(brdf.model, brdf.params, BuildOptions())
    for row in wo:
        alone.ensure_rows(row[None])
    # slots are numbered in the order bins were split (threads finish in any order): compare by path
    by_path = {together.paths[b]: tree for b, tree in together.bins.items()}
    assert sorted(by_path) == sorted(alone.paths[b] for b in alone.bins) and len(alone.bins) == len(wo)
    for b, tree in alone.bins.items():
        mine, theirs = tree.arrays(), by_path[alone.paths[b]].arrays()
        for name in mine:
            if name != "build_seconds":
                np.testing.assert_array_equal(
                    mine[name], theirs[name], err_msg=f"bin {alone.paths[b]}: {name}"
                )


def test_preload_loads_every_cached_tree_and_builds_none(tmp_path):
    """A render's preparation loads the trees earlier runs stored (then its passes find them in memory)."""
    folder = tmp_path / "tables"
    first = _adaptive("ward", params=BRUSHED, cache=folder)
    wo = np.stack([degrees_to_dir(t, p) for t, p in ((10, 5), (40, 33), (70, 61), (75, 170))])
    first.sample_each(wo, seed=1)
    assert first.info()["trees"] == 4
    clear_memory_cache()
    second = _adaptive("ward", params=BRUSHED, cache=folder)
    assert second.info()["trees"] == 0
    assert second.preload() == 4
    info = second.info()
    assert info["trees"] == 4 and info["cache_hits"] == 4
    wi, pdf = second.sample_each(wo, seed=1)
    wi1, pdf1 = first.sample_each(wo, seed=1)
    np.testing.assert_array_equal(wi, wi1)
    np.testing.assert_array_equal(pdf, pdf1)
    assert second.info()["trees"] == 4  # sampling found them all in memory
    assert second.preload() == 0  # nothing new on disk
    assert _adaptive("ward", params=BRUSHED, cache=False).preload() == 0  # no disk cache


def test_laziness_and_info():
    sampler = _adaptive("lewis")
    assert sampler.info()["trees"] == 0
    sampler.sample(degrees_to_dir(20.0), 10)
    info = sampler.info()
    assert info["trees"] == 1 and info["memory_bytes"] > 0 and info["build_seconds"] > 0.0
    sampler.sample_each(np.stack([degrees_to_dir(20.0), degrees_to_dir(50.0), degrees_to_dir(50.2)]))
    assert sampler.info()["trees"] == 2


def test_measured_brdf_passes_the_same_tests(bundled_merl_brdf):
    brdf = bundled_merl_brdf
    sampler = make_sampler("adaptive", brdf, n_max=2.0)
    for theta, domain in ((30.0, "sphere"), (75.0, None)):
        if domain is not None:
            _check_sampler(sampler, theta, domain, n_tests=1)
        wo = degrees_to_dir(theta, 17.0)
        assert sampler.acceptance(wo)[0] >= 0.5
        total = integrate_pdf(
            lambda wi, wo=wo: sampler.pdf(np.broadcast_to(wo, wi.shape), wi), (32, 32), 1e-7
        )
        assert abs(total - 1.0) < 1e-3
        wi, pdf = sampler.sample(wo, 10_000, seed=1)
        w = _weights(sampler, wo, wi, pdf)
        assert np.std(w) / np.mean(w) < 1e-9
    assert sampler.bound_violations == 0


# ------------------------------------------------------------------------------------------- split bins

SPLIT_CASE = ("lafortune", 89.5, 25.0)
"""Lafortune's default lobe in the bin theta_o 89.5-89.75, phi_o 25-30 degrees: its lobe changes across the
bin faster than one tree can follow (acceptance 0.48 < 1/2); halved in phi_o, each half reaches 1/2."""


def _rows_in_base_bin(table, theta, phi, n=400, seed=5):
    """``n`` directions spread over the base bin holding ``wo(theta, phi)`` (its edges included, upper edges
    just inside) and the bin's range."""
    from core.quadtree import angles_to_wo

    base = int(table.locate(degrees_to_dir(theta, phi)[None])[0][0])
    while table.parent[base] >= 0:
        base = table.parent[base]
    t_lo, t_hi, f_lo, f_hi = table.bin_range(base)
    r = np.random.default_rng(seed)
    t = np.r_[t_lo, np.nextafter(t_hi, t_lo), r.uniform(t_lo, t_hi, n - 2)]
    p = np.r_[f_lo, np.nextafter(f_hi, f_lo), r.uniform(f_lo, f_hi, n - 2)]
    return angles_to_wo(t, p), (t_lo, t_hi, f_lo, f_hi)


def test_a_bin_whose_tree_misses_the_acceptance_is_split():
    """One tree for the whole bin misses 1/n_max somewhere; the table halves the bin, and every direction of
    the bin then accepts with probability >= 1/n_max, with exact pdfs and no bound violation. The halves tile
    their parent, and ``max_splits=0`` keeps the single tree (and its lower acceptance)."""
    from core.quadtree_table import QuadtreeTable, min_acceptance

    name, theta, phi = SPLIT_CASE
    brdf = make_brdf(name)
    sampler = make_sampler("adaptive", brdf, n_max=2.0)
    table = sampler.table
    wo, rng = _rows_in_base_bin(table, theta, phi)
    acc = sampler.acceptance(wo)
    assert table.n_split >= 1
    assert acc.min() >= 0.5, acc.min()
    slots = np.unique(table.locate(wo)[0])
    assert len(slots) >= 2 and all(table.depth(int(b)) >= 1 for b in slots)
    for b in np.flatnonzero(table.sub >= 0):  # halves tile their parent
        first, dim = divmod(int(table.sub[b]), 2)
        lo, hi, whole = table.ranges[first], table.ranges[first + 1], table.ranges[b]
        assert lo[2 * dim] == whole[2 * dim] and hi[2 * dim + 1] == whole[2 * dim + 1]
        assert lo[2 * dim + 1] == hi[2 * dim]
        np.testing.assert_array_equal(
            np.delete(lo, [2 * dim, 2 * dim + 1]), np.delete(whole, [2 * dim, 2 * dim + 1])
        )
    wi, pdf = sampler.sample_each(wo, seed=4)
    np.testing.assert_array_equal(sampler.pdf(wo, wi), pdf)
    assert np.all(np.isfinite(pdf)) and np.all(pdf > 0.0)
    assert sampler.bound_violations == 0
    # the same bin without splits: one tree, below 1/n_max somewhere
    from core.quadtree import BuildOptions

    single = QuadtreeTable(brdf.model, brdf.params, BuildOptions(n_max=2.0, max_splits=0))
    assert single.acceptance(wo).min() < 0.5 and single.n_split == 0
    b0, tree = single.tree_at(wo[0])
    assert min_acceptance(tree, single.bin_range(b0), False) < 0.5


def test_halving_pays_by_a_factor_or_by_closing_the_gap():
    """A half is halved again when it gained ``SPLIT_GAIN`` over its parent's tree, or closed ``SPLIT_CLOSED``
    of the gap to the target (near the target a 7 % gain can be all that is missing: Lafortune at 30 degrees,
    n_max 1.3, went 0.679 -> 0.732 and stopped below 1/1.3 under the factor rule alone); it is not when it
    gained too little either way. More halvings are allowed for a tighter target."""
    from core.quadtree import BuildOptions, default_max_splits
    from core.quadtree_table import SPLIT_CLOSED, SPLIT_GAIN, SPLIT_MARGIN, halving_paid

    target = (1.0 + SPLIT_MARGIN) / 1.3
    assert halving_paid(0.732, 0.679, 1.3) and 0.732 < SPLIT_GAIN * 0.679
    assert not halving_paid(0.679 + 0.9 * SPLIT_CLOSED * (target - 0.679), 0.679, 1.3)
    assert halving_paid(0.111, 0.1, 2.0) and not halving_paid(0.105, 0.1, 2.0)  # far from 0.505: the factor
    assert halving_paid(0.2, 0.0, 2.0)  # a base bin has inherited nothing
    assert not halving_paid(0.5, 0.5, 1.3)
    splits = [default_max_splits(n) for n in (1.05, 1.3, 1.5, 1.9, 2.0, 3.0, 100.0)]
    assert splits == sorted(splits, reverse=True) and splits[0] == 8 and splits[-1] == 4
    assert default_max_splits(2.0) == 4 and BuildOptions(n_max=1.3).max_splits == default_max_splits(1.3)
    assert BuildOptions(n_max=1.3, max_splits=2).max_splits == 2


def test_a_split_never_lowers_the_acceptance():
    """Every half's tree accepts, over the half, at least what its parent's tree did there (a half whose own
    tree is worse is served by the parent's tree, over the parent's range)."""
    from core.quadtree_table import min_acceptance

    sampler = _adaptive("ward", params=BRUSHED)
    table = sampler.table
    wo, _ = _rows_in_base_bin(table, 89.2, 44.0, n=200)
    sampler.acceptance(wo)
    halves = [b for b in table.bins if table.parent[b] >= 0]
    assert halves
    for b in halves:
        tree = table.bins[b]
        domain = tree.domain if tree.domain is not None else table.bin_range(b)
        mine = min_acceptance(tree, domain, False, part=table.bin_range(b))
        assert mine >= table.inherited[b] * (1.0 - 1e-12), (table.paths[b], mine, table.inherited[b])


def test_splits_are_cached_and_reload_to_the_same_samples(tmp_path):
    """A second process loads the split markers and the halves' trees from disk (building nothing) and draws
    the same samples; preload follows the splits; a corrupt split marker is detected and rebuilt."""
    name, theta, phi = SPLIT_CASE
    folder = tmp_path / "tables"
    first = _adaptive(name, cache=folder)
    wo, _ = _rows_in_base_bin(first.table, theta, phi, n=100)
    wi1, pdf1 = first.sample_each(wo, seed=2)
    n_trees, n_split = first.info()["trees"], first.table.n_split
    assert n_split >= 1
    for load in ("sample", "preload"):
        clear_memory_cache()
        second = _adaptive(name, cache=folder)
        if load == "preload":
            assert second.preload() == n_trees
        wi2, pdf2 = second.sample_each(wo, seed=2)
        np.testing.assert_array_equal(wi1, wi2)
        np.testing.assert_array_equal(pdf1, pdf2)
        assert second.info()["trees"] == n_trees and second.table.n_split == n_split
        assert second.info()["cache_hits"] == n_trees + n_split
        assert second.table.split_seconds == 0.0  # nothing built
    # corrupt the base bin's split marker: rebuilt, the same samples
    base = next(b for b in range(first.table.n_bins) if first.table.sub[b] >= 0)
    marker = folder / first.table.key[:32] / f"bin{first.table.paths[base]}.npz"
    marker.write_bytes(marker.read_bytes()[:100])
    clear_memory_cache()
    third = _adaptive(name, cache=folder)
    wi3, pdf3 = third.sample_each(wo, seed=2)
    np.testing.assert_array_equal(wi1, wi3)
    np.testing.assert_array_equal(pdf1, pdf3)
    assert third.table.cache.rejected == 1 and third.table.split_seconds > 0.0


def test_samples_in_a_split_bin_follow_the_pdf():
    """Chi-square (1e6 samples, alpha = 0.01, one test) at a direction whose bin was halved."""
    name, theta, phi = SPLIT_CASE
    sampler = _adaptive(name)
    _check_sampler(sampler, theta, "sphere", n_tests=1, phi=phi + 3.0)
    assert sampler.table.n_split >= 1


@pytest.mark.parametrize(
    ("name", "params", "theta", "phi"),
    [
        ("ward", {"ks": (0.0, 0.0, 0.0), "kd": (0.0, 0.0, 0.0)}, 60.0, 12.0),
        ("ashikhmin_shirley", None, 89.99, 25.0),
        ("lafortune", None, 89.9, 3.0),
    ],
)
def test_split_decisions_on_hard_cases_stay_finite(name, params, theta, phi):
    """Zero albedo (nothing to split: the cosine density) and the last fraction of a degree before the horizon
    (where bins split): finite samples and pdfs, the pdf is the returned one, no bound violation."""
    sampler = _adaptive(name, params=params)
    wo = degrees_to_dir(theta, phi)
    wi, pdf = sampler.sample_each(np.repeat(wo[None], 5000, axis=0), seed=7)
    assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
    np.testing.assert_array_equal(sampler.pdf(np.repeat(wo[None], 5000, axis=0), wi), pdf)
    assert np.isfinite(sampler.acceptance(wo)).all() and sampler.bound_violations == 0
    if params and params.get("ks") == (0.0, 0.0, 0.0):
        assert sampler.table.n_split == 0
        np.testing.assert_allclose(pdf, wi[:, 2] / math.pi)
