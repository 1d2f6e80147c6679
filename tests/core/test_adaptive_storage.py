"""The adaptive table's stored leaves (``core/sampling/adaptive/table.py``, format 9): relative corner values in
16 bits and leaf probabilities in whole units of ``2^-31``, each rounded so that the exact mode's envelope stays
a bound and its draws' density stays the one they report (see docs/adaptive.md, "Tables, storage")."""

from __future__ import annotations

import numpy as np
import pytest

from core.brdf import make_brdf
from core.errors import ParameterError
from core.sampling import make_sampler
from core.sampling.adaptive.draw import _bilinear_density, _pick_leaf, descend_at
from core.sampling.adaptive.pack import CDF_ONE, CORNER_ONE, _leaf_cdf, _leaf_corners

U53 = 2.0**-53
"""The uniforms' spacing (``core.rng.next_u01``)."""


def _weights(rng: np.random.Generator, n: int) -> np.ndarray:
    """Leaf weights over 15 orders of magnitude, as a sharp lobe's tree has (peak leaves and the floor's)."""
    return 10.0 ** rng.uniform(-15.0, 0.0, n)


@pytest.mark.parametrize("n", [1, 2, 7, 400, 12289])
def test_every_leaf_gets_a_whole_positive_count_and_the_envelope_covers_its_weight(n, rng):
    weight = _weights(rng, n)
    cdf, guide, total = _leaf_cdf(weight, True)
    counts = np.diff(cdf, prepend=0)
    assert cdf[-1] == CDF_ONE and np.all(counts >= 1)
    # the envelope V P_L is at least the leaf's envelope mass, and V is the weights' sum but for the rounding
    assert np.all(total * counts / CDF_ONE >= weight)
    assert weight.sum() <= total <= weight.sum() * CDF_ONE / (CDF_ONE - n) * (1.0 + 1e-11)
    # the guide never points past the leaf a uniform of its bucket picks
    buckets = (np.arange(n) * CDF_ONE) // n
    assert np.all(guide <= np.searchsorted(cdf, buckets, side="right"))


def test_a_rejection_free_tables_leaves_keep_their_share_but_for_whole_units(rng):
    weight = _weights(rng, 3000)
    cdf, _, total = _leaf_cdf(weight, False)
    share = np.diff(cdf, prepend=0) / CDF_ONE
    assert total == pytest.approx(weight.sum())
    big = weight / weight.sum() > 1e-6
    np.testing.assert_allclose(share[big], (weight / weight.sum())[big], rtol=1e-3)
    assert np.all(share > 0.0)


def test_a_leaf_is_picked_by_the_interval_of_its_count_exactly(rng):
    """Uniforms at both sides of every interval edge (on the 2^-53 grid) pick the leaf whose interval holds
    them, and report its count times 2^-31."""
    weight = _weights(rng, 300)
    cdf, guide, _ = _leaf_cdf(weight, True)
    cdf32 = cdf.astype(np.uint32)
    counts = np.diff(cdf, prepend=0)
    for j in range(len(cdf) - 1):
        edge = cdf[j] / CDF_ONE
        for u, leaf in ((edge - U53, j), (edge, j + 1)):
            picked, prob = _pick_leaf(cdf32, guide, 0, len(cdf), u)
            assert picked == leaf
            assert prob == counts[leaf] / CDF_ONE
    assert _pick_leaf(cdf32, guide, 0, len(cdf), 1.0 - U53)[0] == len(cdf) - 1


def test_the_stored_corners_density_times_the_widening_bounds_the_fitted_one(rng):
    """``q / q'`` (the fitted leaf density over the stored corners') is at most ``widen`` at every point of the
    leaf (checked on a grid and at the corners), and ``widen`` is at most ``1 + 3 / 65535``."""
    corners = 10.0 ** rng.uniform(-9.0, 3.0, (2000, 4))
    corners[::7, 2] = corners[::7, 0]  # ties
    stored, widen = _leaf_corners(corners)
    assert stored.dtype == np.uint16 and np.all(stored.max(axis=1) == CORNER_ONE) and np.all(stored >= 1)
    assert np.all(widen >= 1.0) and np.all(widen <= 1.0 + 3.0 / CORNER_ONE + 1e-9)
    t = np.linspace(0.0, 1.0, 9)
    for leaf in range(0, len(corners), 13):
        c = corners[leaf]
        s = stored[leaf].astype(np.float64)
        for tx in t:
            for ty in t:
                fitted = _bilinear_density(c[0], c[1], c[2], c[3], tx, ty)
                kept = _bilinear_density(s[0], s[1], s[2], s[3], tx, ty)
                assert fitted <= widen[leaf] * kept


@pytest.mark.parametrize(
    ("name", "params"),
    [("ashikhmin_shirley", {"nu": 10.0, "nv": 200.0}), ("ward", {"sx": 0.05, "sy": 0.25})],
)
def test_the_issues_anisotropic_exact_tables_fit_in_1_mb(name, params):
    """The issue's target for both anisotropic cases (measured: 0.78 and 0.56 MB; 1.32 and 0.93 MB in the
    previous format)."""
    info = make_sampler("adaptive_exact", make_brdf(name, params)).info()
    assert info["memory_bytes"] <= 1_000_000


def test_a_capacity_whose_leaves_a_table_cannot_index_is_refused():
    """A tree's leaves are indexed in 16 bits (``guide``): at most 2^16 nodes, 49 153 leaves."""
    with pytest.raises(ParameterError, match="capacity"):
        make_sampler("adaptive_exact", make_brdf("phong"), capacity=(1 << 16) + 1)
    with pytest.raises(ValueError, match="at most 65536"):
        _leaf_cdf(np.ones((1 << 16) + 1), True)


def _leaf_counts(table) -> np.ndarray:
    """Each leaf's count of ``2^-31`` (its ``cdf`` interval, the first of a tree from 0)."""
    cdf = table.cdf.astype(np.int64)
    counts = np.diff(cdf, prepend=0)
    starts = table.leaf_base[:-1]
    counts[starts] = cdf[starts]
    return counts


@pytest.mark.parametrize(("name", "params"), [("ggx", {"alpha": 0.2}), ("ward", {"sx": 0.05, "sy": 0.25})])
def test_a_rejection_free_tables_node_masses_are_its_leaves_counts(name, params):
    """Every node's mass is the sum of its leaves' counts: a leaf's own, a node's four children's, a root's
    ``2^31``; an exact table keeps none."""
    table = make_sampler("adaptive_warp", make_brdf(name, params), cache=False).table
    child, mass = table.child.astype(np.int64), table.node_mass
    assert mass.shape == child.shape and np.all(mass == np.rint(mass))
    leaf = child < 0
    np.testing.assert_array_equal(mass[leaf], _leaf_counts(table)[-1 - child[leaf]])
    first = child[~leaf]
    np.testing.assert_array_equal(
        mass[~leaf], mass[first] + mass[first + 1] + mass[first + 2] + mass[first + 3]
    )
    np.testing.assert_array_equal(mass[table.root], np.full(len(table.root), float(CDF_ONE)))
    exact = make_sampler("adaptive_exact", make_brdf(name, params), cache=False).table
    assert exact.node_mass.shape == (0,)


def test_the_descent_maps_a_rectangle_of_the_square_onto_each_leaf_with_its_probability():
    """A caller's point descends the tree by both numbers (``descend_at``): the points that reach a leaf
    are those of an axis-aligned rectangle of the unit square, of area the leaf's probability, and what is
    left of the point is its place in that rectangle (affine in each number; exact to the rounding). Checked
    on a 512 x 512 grid of points over every tree of a glossy table."""
    table = make_sampler("adaptive_warp", make_brdf("ggx", {"alpha": 0.1}), cache=False).table
    counts = _leaf_counts(table)
    k = 512
    grid = (np.arange(k) + 0.5) / k
    a, b = (g.ravel() for g in np.meshgrid(grid, grid, indexing="ij"))
    checked = 0
    for t in range(0, len(table.root), 7):
        found = [
            descend_at(table.child, table.node_mass, table.root[t], x, y) for x, y in zip(a, b, strict=True)
        ]
        leaves, ra, rb = (np.array(v) for v in zip(*found, strict=True))
        assert np.all((table.leaf_base[t] <= leaves) & (leaves < table.leaf_base[t + 1]))
        assert np.all((ra >= 0.0) & (ra < 1.0) & (rb >= 0.0) & (rb < 1.0))
        for leaf in np.unique(leaves):
            m = leaves == leaf
            xa, xb, ya, yb = a[m], b[m], ra[m], rb[m]
            if np.ptp(xa) == 0.0 or np.ptp(xb) == 0.0:
                continue  # one row or column of points: no slope to measure
            sa = np.ptp(ya) / np.ptp(xa)  # the rectangle's 1 / width
            sb = np.ptp(yb) / np.ptp(xb)
            np.testing.assert_allclose(ya, ya.min() + (xa - xa.min()) * sa, atol=1e-9)
            np.testing.assert_allclose(yb, yb.min() + (xb - xb.min()) * sb, atol=1e-9)
            assert 1.0 / (sa * sb) == pytest.approx(counts[leaf] / CDF_ONE, rel=1e-9)
            checked += 1
    assert checked > 100
