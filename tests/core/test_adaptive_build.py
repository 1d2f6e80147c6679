"""Construction of one adaptive tree (:func:`core.quadtree.build_tree`): the leaf bounds really bound ``g / c``
over the whole bin (checked on points independent of the construction, including the peaks of very sharp
lobes), the acceptance ``I / (c V)`` reaches ``1/n_max`` at every ``wo`` of the bin, and the arrays keep the
layout the table relies on (level order, boxes = the squares clipped to the disk, masses = area x bound).

Sharp lobes are also sampled through the sampler (>= 1e5 samples over ``wo`` spread across the bin) and
must give no bound violation. Everything uses fixed seeds; no statistical tolerance is involved (a bound either
holds at a point or not). Long sweeps are marked slow.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.geometry import degrees_to_dir
from core.model import all_models, make_brdf
from core.quadtree import (
    PROJECTIONS,
    BuildOptions,
    angles_to_wo,
    build_tree,
    clip_boxes,
    direction_to_disk,
    normalizer_values,
    target,
    theta_edges,
)
from core.sampler import make_sampler

MODEL_NAMES = {m.name for m in all_models()}


@pytest.fixture(autouse=True)
def _private_cache(private_tables):
    """Every test gets its own table cache folder and an empty in-memory cache (tests/core/conftest.py)."""


def _bin(model, theta_deg: float, phi_deg: float, opts: BuildOptions) -> tuple[float, float, float, float]:
    """The bin range ``(theta_lo, theta_hi, phi_lo, phi_hi)`` holding ``wo(theta, phi)``, as the table lays
    the bins out (theta edges from :func:`theta_edges`; when anisotropic, ``phi_bins`` equal phi bins over the
    circle, or a quarter as many over the first quadrant, with phi folded into it, for mirror-symmetric
    models)."""
    edges = theta_edges(opts.theta_step, opts.z_min)
    it = int(np.clip(np.searchsorted(edges, math.radians(theta_deg), side="right") - 1, 0, len(edges) - 2))
    if model.isotropic:
        return float(edges[it]), float(edges[it + 1]), 0.0, 0.0
    phi = math.radians(phi_deg)
    step = 2.0 * math.pi / opts.phi_bins
    if model.mirror_symmetric:
        phi = math.atan2(abs(math.sin(phi)), abs(math.cos(phi)))
        step = 0.5 * math.pi / -(-opts.phi_bins // 4)
    ip = int(phi // step)
    return float(edges[it]), float(edges[it + 1]), ip * step, (ip + 1) * step


_BUILT: dict[str, tuple] = {}


def _build(name: str, params: dict | None, theta: float, phi: float = 12.0, n_max: float = 2.0):
    """``(brdf, bin range, build_tree arrays)`` for the bin holding ``wo(theta, phi)`` (memoized: several
    tests look at the same sharp tree)."""
    key = repr((name, params, theta, phi, n_max))
    if key not in _BUILT:
        brdf = make_brdf(name, params)
        opts = BuildOptions(n_max=n_max)
        rng = _bin(brdf.model, theta, phi, opts)
        _BUILT[key] = (brdf, rng, build_tree(brdf.model, brdf.params, brdf.model.isotropic, rng, opts))
    return _BUILT[key]


def _wo_in_bin(rng: tuple, iso: bool, n: int, seed: int) -> np.ndarray:
    """``(n, 2)`` angles ``(theta_o, phi_o)`` uniform in the bin, its corners included."""
    r = np.random.default_rng(seed)
    t = r.uniform(rng[0], rng[1], n)
    p = np.zeros(n) if iso else r.uniform(rng[2], rng[3], n)
    t[:4] = [rng[0], rng[1], rng[0], rng[1]]
    if not iso:
        p[:4] = [rng[2], rng[2], rng[3], rng[3]]
    return np.stack([t, p], axis=1)


def _scale(arrays: dict, rng: tuple, ang: np.ndarray) -> np.ndarray:
    mt, mp = (int(v) for v in arrays["scale_shape"])
    meta = np.array([[0.0, mt, mp, *rng]])
    v = normalizer_values(meta, arrays["scale"], np.zeros(len(ang), dtype=np.int64), ang[:, 0], ang[:, 1])
    return np.maximum(v, float(arrays["scale_floor"]))


def _violations(brdf, rng: tuple, arrays: dict, n_wo: int = 24, per_leaf: int = 24, seed: int = 1) -> int:
    """Points where ``g(wo, X) > c(wo) M_L`` for the leaf ``L`` holding ``X``: random points in every leaf at
    random ``wo`` of the bin, plus points around the mirror direction of each ``wo`` (where sharp lobes
    peak) at several radii."""
    iso = brdf.model.isotropic
    proj = PROJECTIONS[int(arrays["projection"])]
    leaf = arrays["leaf"]
    live = leaf[:, 0] > 0.0
    M, boxes = leaf[live, 0], leaf[live, 1:]
    r = np.random.default_rng(seed)
    ang = _wo_in_bin(rng, iso, n_wo, seed)
    c = _scale(arrays, rng, ang)
    count = 0
    for k in range(n_wo):
        wo1 = angles_to_wo(ang[k : k + 1, 0], ang[k : k + 1, 1])
        # random points in every leaf
        u, v = r.random((2, len(M), per_leaf))
        X = (boxes[:, 0:1] + (boxes[:, 2:3] - boxes[:, 0:1]) * u).ravel()
        Y = (boxes[:, 1:2] + (boxes[:, 3:4] - boxes[:, 1:2]) * v).ravel()
        g = target(brdf.model, brdf.params, np.repeat(wo1, len(X), axis=0), X, Y, proj)
        count += int(np.count_nonzero(g.reshape(len(M), per_leaf) > c[k] * M[:, None]))
        # points around the mirror direction, in whichever leaf holds them
        mirror = direction_to_disk(angles_to_wo(ang[k : k + 1, 0], ang[k : k + 1, 1] + math.pi), proj)[0]
        radii = np.repeat([0.0, 1e-4, 1e-3, 3e-3, 1e-2, 3e-2], 32)
        a = r.uniform(0.0, 2.0 * math.pi, len(radii))
        P = mirror + radii[:, None] * np.stack([np.cos(a), np.sin(a)], axis=1)
        P = P[(P * P).sum(axis=1) < 1.0]
        inside = (
            (P[:, None, 0] >= boxes[None, :, 0]) & (P[:, None, 0] <= boxes[None, :, 2])
            & (P[:, None, 1] >= boxes[None, :, 1]) & (P[:, None, 1] <= boxes[None, :, 3])
        )  # fmt: skip
        pi, li = np.nonzero(inside)
        g = target(brdf.model, brdf.params, np.repeat(wo1, len(pi), axis=0), P[pi, 0], P[pi, 1], proj)
        count += int(np.count_nonzero(g > c[k] * M[li]))
    return count


# ------------------------------------------------------------------------------------------------ layout


@pytest.mark.parametrize(("name", "theta"), [("phong", 60.0), ("ward", 30.0), ("minnaert", 85.0)])
def test_tree_layout_is_what_the_table_expects(name, theta):
    """Level order (children of the r-th internal node at 1 + 4r, in the order (x0,y0), (x0+h,y0), (x0,y0+h),
    (x0+h,y0+h)); every leaf box is exactly ``clip_boxes`` of its square; ``vmass`` is area x M at the
    leaves and the sum of the children elsewhere; leaves are numbered in level order."""
    _, _, a = _build(name, None, theta)
    child, vmass, leaf = a["child"], a["vmass"], a["leaf"]
    n = len(child)
    x0, y0, size = np.zeros(n), np.zeros(n), np.zeros(n)
    x0[0], y0[0], size[0] = -1.0, -1.0, 2.0
    rank = 0
    for k in range(n):
        if child[k] >= 0:
            c = int(child[k])
            assert c == 1 + 4 * rank
            rank += 1
            h = 0.5 * size[k]
            x0[c : c + 4] = x0[k] + np.array([0.0, h, 0.0, h])
            y0[c : c + 4] = y0[k] + np.array([0.0, 0.0, h, h])
            size[c : c + 4] = h
            assert vmass[k] == vmass[c] + vmass[c + 1] + vmass[c + 2] + vmass[c + 3]
    leaves = np.flatnonzero(child < 0)
    np.testing.assert_array_equal(-child[leaves] - 1, np.arange(len(leaves)))
    boxes, ok = clip_boxes(x0[leaves], x0[leaves] + size[leaves], y0[leaves], y0[leaves] + size[leaves])
    live = leaf[:, 0] > 0.0
    assert np.all(ok[live])
    np.testing.assert_array_equal(leaf[live, 1:], boxes[live])
    assert np.all(leaf[~live] == 0.0)
    area = (leaf[:, 3] - leaf[:, 1]) * (leaf[:, 4] - leaf[:, 2])
    np.testing.assert_array_equal(vmass[leaves], area * leaf[:, 0])
    assert vmass[0] > 0.0 and np.all(np.isfinite(vmass))


# ------------------------------------------------------------------------------------------------ bounds

SHARP_FAST = [
    ("ward", {"sx": 0.005, "sy": 0.005}, 60.0),
    ("phong", {"n": 10000}, 45.0),
    ("blinn", {"n": 10000}, 70.0),
    ("cook_torrance", {"m": 0.005}, 30.0),
]
SHARP_SLOW = [
    ("ward", {"sx": 0.005, "sy": 0.005}, 0.0),
    ("ward", {"sx": 0.005, "sy": 0.005}, 30.0),
    ("ward", {"sx": 0.005, "sy": 0.005}, 80.0),
    ("ward", {"sx": 0.002, "sy": 0.01}, 45.0),
    ("phong", {"n": 10000}, 89.5),
    ("blinn", {"n": 10000}, 10.0),
    ("cook_torrance", {"m": 0.005}, 80.0),
    ("ggx", {"alpha": 0.001}, 45.0),
    ("ggx", {"alpha": 0.001}, 85.0),
    ("ashikhmin_shirley", {"nu": 1e5, "nv": 1e5}, 45.0),
    ("lafortune", {"n": 5000}, 60.0),
]


def _sharp_case(name, params, theta):
    if name not in MODEL_NAMES:
        pytest.skip(f"model {name} not in the library")
    brdf, rng, arrays = _build(name, params, theta)
    assert _violations(brdf, rng, arrays) == 0
    # and through the sampler: 1e5 samples, one per wo spread across the bin
    sampler = make_sampler("adaptive", brdf, n_max=2.0)
    ang = _wo_in_bin(rng, brdf.model.isotropic, 100_000, 3)
    if brdf.model.isotropic:
        ang[:, 1] = np.random.default_rng(4).uniform(0.0, 2.0 * math.pi, len(ang))
    wi, pdf = sampler.sample_each(angles_to_wo(ang[:, 0], ang[:, 1]), seed=2)
    assert np.all(np.isfinite(wi)) and np.all(pdf > 0.0)
    assert sampler.bound_violations == 0


@pytest.mark.parametrize(("name", "params", "theta"), SHARP_FAST, ids=lambda v: str(v))
def test_sharp_lobes_have_no_bound_violation(name, params, theta):
    _sharp_case(name, params, theta)


@pytest.mark.slow
@pytest.mark.parametrize(("name", "params", "theta"), SHARP_SLOW, ids=lambda v: str(v))
def test_sharp_lobes_have_no_bound_violation_sweep(name, params, theta):
    _sharp_case(name, params, theta)


# -------------------------------------------------------------------------------------------- acceptance

ACCEPTANCE_FAST = [
    ("ashikhmin_shirley", 80.0),
    ("lafortune", 80.0),
    ("phong", 89.0),
    ("minnaert", 30.0),
]


def _acceptance_case(name, theta, n_max=2.0):
    """Through the table, as sampling sees it: 400 ``wo`` over the base bin (its corners included, upper
    edges just inside), each in whichever tree serves it (the bin's own, or a half's when the bin was split).
    The bounds of those trees are checked by sampling 2e4 trials spread over the bin."""
    from core.quadtree_table import QuadtreeTable

    if name not in MODEL_NAMES:
        pytest.skip(f"model {name} not in the library")
    brdf = make_brdf(name)
    iso = brdf.model.isotropic
    opts = BuildOptions(n_max=n_max)
    rng = _bin(brdf.model, theta, 25.0, opts)
    inside = (
        rng[0],
        np.nextafter(rng[1], rng[0]),
        rng[2],
        np.nextafter(rng[3], rng[2]) if not iso else rng[3],
    )
    ang = _wo_in_bin(inside, iso, 400, 5)
    wo = angles_to_wo(ang[:, 0], ang[:, 1])
    table = QuadtreeTable(brdf.model, brdf.params, opts)
    acc = float(table.acceptance(wo).min())
    assert acc >= 1.0 / n_max, f"{name} theta={theta}: acceptance {acc:.3f} < 1/{n_max}"
    table.sample_each(np.repeat(wo, 50, axis=0), seed=3)
    assert table.violations == 0


@pytest.mark.parametrize(("name", "theta"), ACCEPTANCE_FAST, ids=lambda v: str(v))
def test_acceptance_over_the_whole_bin(name, theta):
    """The per-trial acceptance ``I(wo) / (c(wo) V)`` is >= 1/n_max at 400 wo of the bin (corners included),
    for the cases that missed it before (anisotropic models at grazing angles)."""
    _acceptance_case(name, theta)


_GRAZING_GAP = pytest.mark.xfail(
    strict=True,
    reason="known gap (docs/adaptive.md, section 9): Ashikhmin-Shirley's lobe in the last half degree before "
    "the horizon; halving its bin does not pay (the halves' own trees accept less than the whole bin's)",
)
_KNOWN_GAPS = {("ashikhmin_shirley", 89.5): _GRAZING_GAP}


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "theta"),
    [
        pytest.param(n, t, marks=[_KNOWN_GAPS[n, t]] if (n, t) in _KNOWN_GAPS else [])
        for n in sorted(MODEL_NAMES)
        for t in (0.0, 30.0, 60.0, 80.0, 88.0, 89.5)
    ],
)
def test_acceptance_over_the_whole_bin_every_model(name, theta):
    _acceptance_case(name, theta)


def test_wider_search_finds_what_a_plain_grid_misses():
    """The bound of the leaf holding the peak of a sharp lobe is at least the peak: the value at the mirror
    direction of the bin's centre (where Ward with sx = sy = 0.005 peaks) is below c M of its leaf."""
    brdf, rng, arrays = _build("ward", {"sx": 0.005, "sy": 0.005}, 60.0)
    proj = PROJECTIONS[int(arrays["projection"])]
    ang = np.array([[0.5 * (rng[0] + rng[1]), 0.5 * (rng[2] + rng[3])]])
    wo = angles_to_wo(ang[:, 0], ang[:, 1])
    p = direction_to_disk(angles_to_wo(ang[:, 0], ang[:, 1] + math.pi), proj)[0]
    leaf = arrays["leaf"]
    holds = (leaf[:, 1] <= p[0]) & (p[0] <= leaf[:, 3]) & (leaf[:, 2] <= p[1]) & (p[1] <= leaf[:, 4])
    assert holds.any()
    g = target(brdf.model, brdf.params, wo, p[:1], p[1:], proj)[0]
    assert g > 0.0
    assert np.all(g <= _scale(arrays, rng, ang)[0] * leaf[holds, 0])


def test_threads_sharing_a_tree_build_the_same_tree():
    """A tree built with several threads sharing its nodes (the app's view asks for one tree at a time) is the
    tree a single thread builds, array for array."""
    brdf = make_brdf("ggx", {"alpha": 0.05})
    opts = BuildOptions()
    rng = _bin(brdf.model, 30.0, 0.0, opts)
    one = build_tree(brdf.model, brdf.params, True, rng, opts, threads=1)
    three = build_tree(brdf.model, brdf.params, True, rng, opts, threads=3)
    assert len(one["leaf"]) > 64  # enough nodes per level for the work to be shared
    for key in one:
        if key != "build_seconds":
            np.testing.assert_array_equal(one[key], three[key], err_msg=key)


def test_a_thin_band_just_inside_the_horizon_is_bounded():
    """Poulin-Fournier at theta_o ~ 88 degrees peaks in a band at theta_i ~ 89.6 degrees, 1e-4 wide on the
    orthographic disk, that neither the lattice nor the rim's own points reach; without probes on circles near
    the rim, a leaf's bound fell 2.2x short of it. Here: dense circles theta_i in [89, 90) through every leaf
    they cross, at 24 wo of the bin, never exceed c M of the leaf holding them."""
    if "poulin_fournier" not in MODEL_NAMES:
        pytest.skip("model poulin_fournier not in the library")
    brdf, rng, arrays = _build("poulin_fournier", None, 88.0, 25.0)
    proj = PROJECTIONS[int(arrays["projection"])]
    t_i = np.radians(np.linspace(89.0, 89.999, 40))
    rho = np.sin(t_i) if proj == "orthographic" else t_i / (0.5 * math.pi)
    leaf = arrays["leaf"]
    far = np.hypot(np.maximum(abs(leaf[:, 1]), abs(leaf[:, 3])), np.maximum(abs(leaf[:, 2]), abs(leaf[:, 4])))
    M, boxes = leaf[far >= rho[0], 0], leaf[far >= rho[0], 1:]  # the leaves the circles can cross
    a = np.linspace(0.0, 2.0 * math.pi, 1800, endpoint=False)
    X = (rho[:, None] * np.cos(a)[None, :]).ravel()
    Y = (rho[:, None] * np.sin(a)[None, :]).ravel()
    inside = (boxes[None, :, 0] <= X[:, None]) & (X[:, None] <= boxes[None, :, 2])
    inside &= (boxes[None, :, 1] <= Y[:, None]) & (Y[:, None] <= boxes[None, :, 3])
    bound = np.where(inside, M[None, :], np.inf).min(axis=1)  # the leaf holding the point (ties: the lower)
    assert np.all(np.isfinite(bound))
    ang = _wo_in_bin(rng, False, 24, 11)
    c = _scale(arrays, rng, ang)
    worst = 0.0
    for k in range(len(ang)):
        wo = np.repeat(angles_to_wo(ang[k : k + 1, 0], ang[k : k + 1, 1]), len(X), axis=0)
        g = target(brdf.model, brdf.params, wo, X, Y, proj)
        worst = max(worst, float(np.max(g / (c[k] * bound))))
    assert worst <= 1.0, f"g / (c M) reaches {worst:.3f} on the band"


def test_degrees_helper_matches_the_table_layout():
    """``_bin`` above must place wo where the table does (else the tests would check the wrong tree)."""
    from core.quadtree_table import QuadtreeTable

    for name in ("phong", "ward"):
        if name not in MODEL_NAMES:
            continue
        brdf = make_brdf(name)
        opts = BuildOptions()
        table = QuadtreeTable(brdf.model, brdf.params, opts)
        for theta, phi in ((0.2, 3.0), (30.0, 12.0), (60.0, 202.0), (89.7, 358.0)):
            b = int(table.locate(degrees_to_dir(theta, phi)[None])[0][0])
            np.testing.assert_allclose(table.bin_range(b), _bin(brdf.model, theta, phi, opts))
