"""The adaptive sampler's fused numba kernels and compact trees (core/quadtree_kernels.py, core/quadtree_table.py).

What is checked: the leaf boxes recomputed from a leaf's position are bit for bit the builder's, the integer
masses keep every bound (``M_L >= M``) and sum exactly; samples from ``sample_each`` (one draw per row) and
from the batch variant follow the pdf (chi-square); the pdf returned with a sample is the pdf of ``pdf(wo, wi)``
bit for bit and ``f cos / pdf = I(wo)``; counters, the cosine fallback rows, hard directions; the path for a
kernel that cannot be specialized gives the same numbers as the specialized one; a measured (MERL) BRDF.

Statistics: fixed seeds; chi-square tests at alpha = 0.01, Sidak-corrected over the 3 chi-square tests of this
file; the two-sample tests at alpha = 0.01, Sidak-corrected over their 2 domains.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from core.chi2 import chi2_test, two_sample_test
from core.geometry import degrees_to_dir
from core.model import BRDF, LUMINANCE, make_brdf
from core.quadtree import BuildOptions, build_tree, normalizer_values
from core.quadtree_kernels import LUM_B, LUM_G, LUM_R, model_kernels
from core.quadtree_table import Bin, QuadtreeTable
from core.sampler import make_sampler
from core.samplers.adaptive import clear_memory_cache

N_CHI2 = 1_000_000
CHI2_TESTS = 3


@pytest.fixture(autouse=True)
def _private_cache(private_tables):
    """Every test gets its own table cache folder and an empty in-memory cache (tests/core/conftest.py)."""


def _adaptive(name, n_max=2.0, params=None, **kw):
    return make_sampler("adaptive", make_brdf(name, params), n_max=n_max, cache=False, **kw)


def _directions(thetas_deg, phis_deg) -> np.ndarray:
    t = np.radians(np.asarray(thetas_deg, dtype=np.float64))
    p = np.radians(np.asarray(phis_deg, dtype=np.float64))
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)


def _luminance_weights(sampler, wo, wi, pdf):
    f = sampler.eval(wo, wi) @ LUMINANCE
    return f * np.maximum(wi[:, 2], 0.0) / pdf


def test_luminance_weights_are_the_models():
    np.testing.assert_array_equal([LUM_R, LUM_G, LUM_B], LUMINANCE)


# ------------------------------------------------------------------------------------------- storage


@pytest.mark.parametrize(
    ("name", "theta", "phi"),
    [("lambert", 30.0, 0.0), ("phong", 80.0, 0.0), ("minnaert", 60.0, 0.0), ("ward", 60.0, 12.0)],
)
def test_recomputed_leaf_boxes_are_the_builders(name, theta, phi):
    """Every leaf's clipped box, recomputed from its position as the sampler does, equals the box the builder
    computed its area and mass from, bit for bit; the bound derived from the integer mass is never below the
    builder's bound, and the masses add up exactly."""
    brdf = make_brdf(name)
    opts = BuildOptions(n_max=2.0)
    table = QuadtreeTable(brdf.model, brdf.params, opts)
    b = int(table.locate(degrees_to_dir(theta, phi)[None, :])[0][0])
    raw = build_tree(brdf.model, brdf.params, brdf.model.isotropic, table.bin_range(b), opts)
    tree = Bin(raw)
    rows = tree.leaf_rows()
    leaf = raw["leaf"]
    assert rows.shape == leaf.shape
    used = leaf[:, 0] > 0.0
    assert used.sum() > 4
    np.testing.assert_array_equal(rows[used, 1:], leaf[used, 1:])
    np.testing.assert_array_equal(rows[~used], 0.0)
    assert np.all(rows[used, 0] >= leaf[used, 0])
    area = (leaf[:, 3] - leaf[:, 1]) * (leaf[:, 4] - leaf[:, 2])
    # the envelope grows by at most one mass unit (V / 2^30) per leaf
    assert math.isclose(
        float((rows[:, 0] * area).sum()), float(raw["vmass"][0]), rel_tol=len(leaf) * 2.0**-29
    )
    # internal masses are the exact sums of their children's (level order: children of internal r at 1 + 4 r)
    child = raw["child"].astype(np.int64)
    internal = np.flatnonzero(child >= 0)
    m = tree.mass.astype(np.int64)
    kids = child[internal][:, None] + np.arange(4)[None, :]
    np.testing.assert_array_equal(m[internal], m[kids].sum(axis=1))
    assert tree.n_leaves == len(leaf) and tree.n_nodes == len(child)
    # the stored (cached) form gives the same tree, and nbytes is what is held
    again = Bin(tree.arrays())
    np.testing.assert_array_equal(again.leaf_rows(), rows)
    held = sum(getattr(tree, a).nbytes for a in ("mass", "bits", "cum", "norm_coef", "scale_coef"))
    assert tree.nbytes == held
    # far below the seed's layout of 5 float64 per leaf + int32 child + float64 mass per node
    tables = tree.norm_coef.nbytes + tree.scale_coef.nbytes
    assert tree.nbytes - tables < 0.2 * (40 * len(leaf) + 12 * len(child))
    # the stored Chebyshev coefficients give the builder's interpolant of I(wo) (its values at the nodes)
    t_lo, t_hi, f_lo, f_hi = table.bin_range(b)
    rng = np.random.default_rng(2)
    th = rng.uniform(t_lo, t_hi, 200)
    ph = rng.uniform(f_lo, f_hi, 200) if f_hi > f_lo else np.zeros(200)
    meta = np.array([[0.0, *raw["shape"], t_lo, t_hi, f_lo, f_hi]])
    zero = np.zeros(200, dtype=np.int64)
    reference = normalizer_values(meta, raw["norm"], zero, th, ph)
    table.ensure(np.array([b]))
    np.testing.assert_allclose(table.normalizer(np.full(200, b), th, ph), reference, rtol=1e-9)


# -------------------------------------------------------------------------------------------- samples


def _each(sampler, wo):
    def sample(n, seed):
        return sampler.sample_each(np.repeat(wo[None, :], n, axis=0), seed)[0]

    return sample


def _pdf_at(sampler, wo):
    return lambda wi: sampler.pdf(np.broadcast_to(wo, wi.shape), wi)


@pytest.mark.parametrize(
    ("name", "theta", "domain"),
    [("blinn", 45.0, "sphere"), ("ward", 30.0, "disk"), ("oren_nayar", 75.0, "sphere")],
)
def test_sample_each_follows_the_pdf(name, theta, domain):
    """One draw per row (the renderer's path), chi-square against the pdf."""
    sampler = _adaptive(name)
    wo = degrees_to_dir(theta, 23.0)
    res = chi2_test(
        _each(sampler, wo), _pdf_at(sampler, wo), N_CHI2, domain=domain, seed=5, n_tests=CHI2_TESTS
    )
    assert res.passed, res.summary()
    assert sampler.bound_violations == 0


def test_batch_of_an_anisotropic_model_matches_single_draws():
    sampler = _adaptive("ward")
    wo = degrees_to_dir(50.0, 40.0)
    batch, _ = sampler.sample(wo, 400_000, seed=3)
    single, _ = sampler.sample_each(np.repeat(wo[None, :], 400_000, axis=0), seed=4)
    for domain in ("sphere", "disk"):
        res = two_sample_test(batch, single, domain=domain, n_tests=2)
        assert res.passed, res.summary()
    assert sampler.bound_violations == 0


@pytest.mark.parametrize("name", ["phong", "ward", "cook_torrance"])
def test_returned_pdf_is_the_pdf_and_the_weight_is_the_normalizer(name):
    sampler = _adaptive(name)
    rng = np.random.default_rng(1)
    # every row a different wo, within a few bins (a tree per bin is built: anisotropic bins are 1 x 5 deg)
    n = 4000
    theta = rng.choice([0.0, 30.0, 60.0], n) + rng.uniform(-0.45, 0.45, n)
    theta[:2] = (0.0, 89.99)
    wo = _directions(np.abs(theta), 150.0 + rng.uniform(0.5, 4.5, n))
    wi, pdf, trials = sampler.sample_with_trials(wo, seed=2)
    np.testing.assert_array_equal(sampler.pdf(wo, wi), pdf)
    assert np.all(np.isfinite(wi)) and np.all(pdf > 0.0) and np.all(wi[:, 2] > 0.0)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-12)
    w = _luminance_weights(sampler, wo, wi, pdf)
    np.testing.assert_allclose(w, sampler.normalizer(wo), rtol=1e-9)
    assert np.all(trials >= 1)
    assert sampler.bound_violations == 0
    info = sampler.info()
    assert info["mean_trials"] == pytest.approx(trials.mean())
    # batch variant: same properties for one direction
    one = degrees_to_dir(60.0, 10.0)
    wi_b, pdf_b = sampler.sample(one, 5000, seed=7)
    np.testing.assert_array_equal(sampler.pdf(np.broadcast_to(one, wi_b.shape), wi_b), pdf_b)
    w_b = _luminance_weights(sampler, np.broadcast_to(one, wi_b.shape), wi_b, pdf_b)
    np.testing.assert_allclose(w_b, sampler.normalizer(one)[0], rtol=1e-9)


def test_rows_are_reproducible_and_independent_of_the_batch():
    sampler = _adaptive("phong", 1.3)
    wo = _directions(np.linspace(40.0, 44.0, 3000), np.linspace(0.0, 720.0, 3000))
    wi, pdf = sampler.sample_each(wo, seed=11)
    wi2, pdf2 = sampler.sample_each(wo[1000:1010], seed=11)  # rows keep their own streams only by index
    np.testing.assert_array_equal(sampler.sample_each(wo[:10], seed=11)[0], wi[:10])
    assert not np.array_equal(wi2, wi[1000:1010])
    np.testing.assert_array_equal(sampler.sample_each(wo, seed=11)[1], pdf)


def test_threads_give_the_same_samples():
    """The threaded variant (chunks of rows on numba's threads) draws every row from the same stream."""
    wo = _directions(np.linspace(40.0, 44.0, 20_000), np.linspace(0.0, 720.0, 20_000))
    serial = _adaptive("phong").sample_each(wo, seed=12)
    clear_memory_cache()
    threaded = _adaptive("phong", threads=True)
    wi, pdf, trials = threaded.table.sample_each(wo, 12, threads=True)
    np.testing.assert_array_equal(wi, serial[0])
    np.testing.assert_array_equal(pdf, serial[1])
    assert threaded.table.trials == trials.sum() and threaded.bound_violations == 0


def test_fallback_rows_use_the_cosine_density():
    """Rows beyond the last bin (cos theta_o < 1e-6), at the horizon and below it: cosine-weighted directions
    with pdf cos / pi, one trial each, next to ordinary rows in the same call."""
    sampler = _adaptive("phong")
    wo = np.array(
        [
            [math.sqrt(1 - 1e-14), 0.0, 1e-7],
            [1.0, 0.0, 0.0],
            [0.6, 0.0, -0.8],
            [0.0, 0.0, 1.0],
            [0.5, 0.0, 0.8660254037844386],
        ]
    )
    wi, pdf, trials = sampler.sample_with_trials(wo, seed=3)
    fb = slice(0, 3)
    np.testing.assert_array_equal(pdf[fb], wi[fb, 2] / math.pi)
    assert np.all(trials[fb] == 1) and np.all(wi[fb, 2] > 0.0)
    np.testing.assert_array_equal(sampler.pdf(wo, wi), pdf)
    np.testing.assert_array_equal(sampler.normalizer(wo)[fb], 0.0)
    assert np.all(sampler.normalizer(wo)[3:] > 0.0)
    # the pdf of a direction below the horizon is 0 for every row
    below = np.broadcast_to([0.0, 0.6, -0.8], wo.shape)
    np.testing.assert_array_equal(sampler.pdf(wo, below), 0.0)


@pytest.mark.parametrize(
    ("name", "params"), [("phong", {"n": 10000}), ("cook_torrance", None), ("minnaert", {"k": 0.2})]
)
def test_hard_directions_stay_finite(name, params):
    """Exactly at the normal, at 89.99 degrees, and a huge exponent."""
    sampler = _adaptive(name, params=params)
    wo = np.repeat(_directions([0.0, 89.99], [0.0, 31.0]), 5000, axis=0)
    wi, pdf = sampler.sample_each(wo, seed=1)
    assert np.all(np.isfinite(wi)) and np.all(np.isfinite(pdf)) and np.all(pdf > 0.0)
    w = _luminance_weights(sampler, wo, wi, pdf)
    np.testing.assert_allclose(w, sampler.normalizer(wo), rtol=1e-9)
    assert sampler.bound_violations == 0


# ------------------------------------------------------------------------------ kernels that cannot be specialized


def _closure_model():
    from numba import njit

    from core.models.phong import PHONG

    inner = PHONG.eval

    @njit(nogil=True)
    def eval_closure(wi, wo, p):  # a local function: core.specialize cannot import it by name
        return inner(wi, wo, p)

    return dataclasses.replace(PHONG, name="phong_closure", eval=eval_closure)


def test_a_kernel_that_cannot_be_specialized_gives_the_same_samples():
    model = _closure_model()
    kernels = model_kernels(model.eval)
    assert not hasattr(kernels, "__file__")  # compiled in a namespace, not a generated module
    closure = make_sampler(
        "adaptive", BRDF(model, {}, params=make_brdf("phong").params), n_max=2.0, cache=False
    )
    named = _adaptive("phong")
    wo = _directions(np.linspace(20.0, 25.0, 2000), np.linspace(0.0, 300.0, 2000))
    a, pa = closure.sample_each(wo, seed=4)
    b, pb = named.sample_each(wo, seed=4)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(pa, pb)
    np.testing.assert_array_equal(closure.pdf(wo, a), pa)
    assert closure.bound_violations == 0


# ------------------------------------------------------------------------------------------ measured data


def test_measured_brdf_through_the_fused_kernels(bundled_merl_brdf):
    sampler = make_sampler("adaptive", bundled_merl_brdf, n_max=2.0, cache=False)
    wo = np.repeat(_directions([20.0, 65.0], [0.0, 140.0]), 3000, axis=0)
    wi, pdf = sampler.sample_each(wo, seed=6)
    np.testing.assert_array_equal(sampler.pdf(wo, wi), pdf)
    w = _luminance_weights(sampler, wo, wi, pdf)
    np.testing.assert_allclose(w, sampler.normalizer(wo), rtol=1e-9)
    assert sampler.bound_violations == 0


def test_threads_can_build_and_read_one_table_at_once():
    """The app samples one shared table from several worker threads: bins built concurrently, ``info`` read
    meanwhile (it once iterated the bins while another thread added one)."""
    import threading

    sampler = make_sampler("adaptive", make_brdf("phong"), n_max=2.0)
    errors: list[BaseException] = []

    def work(theta):
        try:
            wo = np.repeat(degrees_to_dir(theta, 0.0)[None, :], 64, axis=0)
            sampler.sample_each(wo, seed=int(theta))
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(t,)) for t in (5.0, 25.0, 45.0, 65.0)]
    for t in threads:
        t.start()
    while any(t.is_alive() for t in threads):
        sampler.info()
    for t in threads:
        t.join()
    assert not errors
    assert sampler.info()["trees"] == 4
