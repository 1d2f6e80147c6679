"""The arrays the views draw, checked against direct evaluation (no Qt)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.sampling_data import leaf_colours, leaf_edges, ratio_colours, sampling_snapshot
from app.view_data import (
    direction_from_disk,
    grid_normals,
    grid_quads,
    hemisphere_grid,
    incidence_plane,
    light_from_disk,
    lit_sphere,
    lobe,
    to_srgb8,
)
from core.brdf import get_model
from core.sampling.adaptive.inspect import (
    TreeView,
    disk_to_square,
    from_tree_disk,
    leaf_image,
    leaf_lookup,
    leaf_outlines,
    square_to_disk,
    to_tree_disk,
)


def test_lambert_lobe_is_a_sphere_of_radius_kd_over_pi():
    brdf = get_model("lambert").bind(kd=0.6)
    dirs = hemisphere_grid(10, 12)
    points, value = lobe(brdf, np.array([0.0, 0.0, 1.0]), dirs)
    # f cos = kd/pi cos(theta): the lobe is a sphere of diameter kd/pi tangent to the surface at the origin.
    centre = np.array([0.0, 0.0, 0.3 / math.pi])
    assert np.allclose(np.linalg.norm(points - centre, axis=-1), 0.3 / math.pi, atol=1e-12)
    assert np.allclose(value, 0.6 / math.pi * dirs[..., 2])


def test_incidence_plane_is_symmetric_for_lambert_and_signed():
    brdf = get_model("lambert").bind(kd=0.5)
    wo = np.array([math.sin(0.5), 0.0, math.cos(0.5)])
    theta, rgb = incidence_plane(brdf, wo, 41)
    assert np.allclose(rgb[:, 0], 0.5 / math.pi * np.cos(theta), atol=1e-12)
    assert np.allclose(rgb[::-1], rgb, atol=1e-12)


def test_incidence_plane_puts_the_mirror_peak_on_the_positive_side():
    brdf = get_model("phong").bind()
    wo = np.array([math.sin(0.6), 0.0, math.cos(0.6)])
    theta, rgb = incidence_plane(brdf, wo, 721)
    assert abs(theta[np.argmax(rgb[:, 1])] - 0.6) < 0.15


def test_lit_sphere_lambert_follows_the_cosine_law():
    brdf = get_model("lambert").bind(kd=1.0)
    img = lit_sphere(brdf, np.array([0.0, 0.0, 1.0]), size=33, ambient=0.0)
    # Pixel (16, 16) of 33 sits exactly at the centre: normal = light, so L = kd/pi * cos 0.
    assert img[16, 16, 0] == img.max()
    assert abs(img[16, 16, 0] - 1.0 / math.pi) < 1e-12
    # Elsewhere L = cos(angle to the light)/pi = n.z/pi, with n.z = sqrt(1 - x^2 - y^2).
    x = (np.arange(33) + 0.5) / 33 * 2 - 1
    assert abs(img[16, 24, 1] - math.sqrt(1 - x[24] ** 2) / math.pi) < 1e-12
    assert img[0, 0].sum() == 0.0  # off the sphere
    assert to_srgb8(img).dtype == np.uint8


def test_disk_helpers():
    t, p = direction_from_disk(0.5, 0.0)
    assert abs(t - 30.0) < 1e-9 and p == 0.0
    assert abs(direction_from_disk(0.0, -0.5)[1] - 270.0) < 1e-9
    x, y, z = light_from_disk(3.0, 4.0)
    assert abs(x - 0.6) < 1e-12 and abs(y - 0.8) < 1e-12 and z == 0.0


def test_grid_normals_of_a_sphere_point_outwards_and_quads_cover_the_grid():
    dirs = hemisphere_grid(40, 80)
    # a sphere of radius 2 around the origin: the normal is the direction (central differences: ~2 % off)
    n = grid_normals(2.0 * dirs, dirs)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)
    assert np.min(np.sum(n * dirs, axis=-1)) > 0.999
    # Lambert's lobe is a sphere of centre c tangent at the origin: the normal is (p - c) / |p - c|
    brdf = get_model("lambert").bind(kd=0.6)
    points, _ = lobe(brdf, np.array([0.0, 0.0, 1.0]), dirs)
    centre = np.array([0.0, 0.0, 0.3 / math.pi])
    expect = (points - centre) / np.linalg.norm(points - centre, axis=-1, keepdims=True)
    n = grid_normals(points, dirs)
    assert np.min(np.sum(n[1:-1] * expect[1:-1], axis=-1)) > 0.99
    quads = grid_quads(40, 81).reshape(-1, 5)
    assert len(quads) == 39 * 80 and np.all(quads[:, 0] == 4)
    assert set(np.unique(quads[:, 1:])) == set(range(40 * 81))
    # winding: (b - a) x (d - a) points outwards on the unit hemisphere (the pole row's quads are triangles
    # whose a = d: use c there)
    flat = dirs.reshape(-1, 3)
    a, b, c, d = (flat[quads[80:, k]] for k in (1, 2, 3, 4))
    mid = flat[quads[80:, 1:]].mean(axis=1)
    assert np.all(np.sum(np.cross(b - a, d - a) * mid, axis=-1) > 0)
    a, b, c = (flat[quads[:80, k]] for k in (1, 2, 3))
    assert np.all(np.sum(np.cross(b - a, c - a) * (a + b + c), axis=-1) > 0)


# ---- the sampler view's data -------------------------------------------------------------------------
WARD = ("ward", {"sx": 0.05, "sy": 0.25, "kd": (0.0, 0.0, 0.0)})  # anisotropic, f ~0 away from its lobe
CASES = [("lambert", {"kd": 0.5}), ("phong", {"n": 40.0}), ("ggx", {}), WARD]


def _wo(theta_deg: float, phi_deg: float) -> np.ndarray:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


@pytest.fixture(scope="module")
def snapshots():
    """Snapshots of both modes for every case, at directions in all four quadrants."""
    from core.brdf import make_brdf

    out = {}
    for name, params in CASES:
        brdf = make_brdf(name, params)
        for phi in (30.0, 150.0, 210.0, 330.0):
            for mode in ("exact", "warp"):
                out[name, phi, mode] = (brdf, sampling_snapshot(brdf, 50.0, phi, mode=mode, n_samples=400))
    return out


def test_the_leaves_tile_the_square(snapshots):
    """Every tree's leaves are dyadic squares in [0, 1]^2 whose areas sum to 1 and that do not overlap."""
    projections = set()
    for _brdf, snap in snapshots.values():
        boxes = snap.tree.boxes
        projections.add(snap.tree.projection)
        side = boxes[:, 2] - boxes[:, 0]
        assert np.array_equal(side, boxes[:, 3] - boxes[:, 1])
        level = np.rint(-np.log2(side))
        assert np.array_equal(side, 2.0**-level)
        assert np.array_equal(boxes[:, :2] / side[:, None], np.rint(boxes[:, :2] / side[:, None]))
        assert boxes.min() >= 0.0 and boxes.max() <= 1.0
        assert np.sum(side * side) == pytest.approx(1.0, abs=1e-12)
        w = np.minimum(boxes[:, None, 2], boxes[None, :, 2]) - np.maximum(
            boxes[:, None, 0], boxes[None, :, 0]
        )
        h = np.minimum(boxes[:, None, 3], boxes[None, :, 3]) - np.maximum(
            boxes[:, None, 1], boxes[None, :, 1]
        )
        overlap = np.maximum(w, 0.0) * np.maximum(h, 0.0)
        np.fill_diagonal(overlap, 0.0)
        assert not overlap.any()
        assert len(snap.tree.density) == len(snap.tree.bound) == len(boxes)
    assert {"equal_area", "half_vector"} <= projections  # the cases cover the disks of wi and of h


def test_samples_lie_on_the_disk_in_leaves_their_mode_can_draw(snapshots):
    """The samples shown are points of the unit disk, each in a leaf where the mode's proposal density is
    positive (the leaf it was drawn from): tree, frame and disk agree, in every quadrant of wo, for both
    modes and all three disks."""
    for (name, phi, mode), (_brdf, snap) in snapshots.items():
        pts = snap.samples
        assert len(pts) == 400 or (mode == "warp" and snap.tree.projection == "half_vector"), (name, phi)
        assert np.all(np.hypot(pts[:, 0], pts[:, 1]) <= 1.0 + 1e-12)
        leaf = leaf_lookup(snap.tree.boxes, *disk_to_square(pts[:, 0], pts[:, 1]))
        density = snap.leaf_density()
        assert np.all(density[leaf] > 0.0), f"{name} phi={phi} {mode}: {np.sum(density[leaf] <= 0)} samples"
        assert np.sum(density * np.prod(snap.tree.boxes[:, 2:] - snap.tree.boxes[:, :2], axis=1)) == (
            pytest.approx(1.0, rel=1e-5)
        )


def test_tree_disk_points_map_back_to_their_directions(snapshots):
    """``from_tree_disk`` inverts ``to_tree_disk`` (wi disks and the half-vector disk), and the frames put
    the specular direction where they say: on the -x axis of a turned wi disk, at the centre of an h disk."""
    from app.sampling_data import adaptive_sampler

    for name, _params in CASES:
        brdf = snapshots[name, 30.0, "exact"][0]
        sampler = adaptive_sampler(brdf)
        for phi in (30.0, 150.0, 210.0, 330.0):
            wo = _wo(50.0, phi)
            wi = sampler.sample(wo, 300, 5).wi
            wi = wi[wi[:, 2] > 1e-6]
            back = from_tree_disk(sampler, wo, to_tree_disk(sampler, wo, wi))
            np.testing.assert_allclose(back, wi, atol=1e-12)
            mirror = np.array([-wo[0], -wo[1], wo[2]])
            x, y = to_tree_disk(sampler, wo, mirror)[0]
            snap = snapshots[name, phi, "exact"][1]
            if snap.tree.projection == "half_vector":
                assert abs(x) < 1e-12 and abs(y) < 1e-12
                assert snap.wo_disk is None
            else:
                assert snap.tree.follow and x < 0.0 and abs(y) < 1e-12
                assert snap.wo_disk[0] > 0.0 and abs(snap.wo_disk[1]) < 1e-12
        assert np.all(np.isnan(from_tree_disk(sampler, _wo(50.0, 0.0), np.array([[0.8, 0.8]]))))


def test_ratio_map_of_the_exact_mode_is_one_wherever_f_is_positive(snapshots):
    """The exact mode's pdf is f cos / I(wo), so its ratio map is 1 wherever f > 0 (and undefined where
    both densities are 0), on every disk; its weight f cos / pdf is the same for every sample."""
    for (name, phi, mode), (_brdf, snap) in snapshots.items():
        if mode != "exact":
            continue
        r = snap.ratio
        assert r.shape == (96, 96)
        assert np.isfinite(r).sum() > 500, (name, phi)
        assert np.nanmax(np.abs(r - 1.0)) < 1e-9, (name, phi)
        assert snap.weight_rel_std < 1e-9
        assert snap.acceptance >= 1.0 / snap.n_max
        assert 1.0 <= snap.mean_trials < 2.0 * snap.n_max


def test_ratio_map_of_other_strategies_on_the_tree_disk():
    """Lambert: the uniform density 1/(2 pi) against the ideal cos / pi is 1 / (2 cos theta_i) at each
    pixel's direction; the warp mode's density is exact for Lambert on its disk; Phong's warp density is
    close to the ideal where the lobe is."""
    from app.sampling_data import adaptive_sampler
    from core.brdf import make_brdf

    lam = make_brdf("lambert", {"kd": 0.5})
    snap = sampling_snapshot(lam, 35.0, 10.0, ratio_sampler="uniform", grid=32)
    c = (np.arange(32) + 0.5) / 32 * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    wi = from_tree_disk(adaptive_sampler(lam), _wo(35.0, 10.0), np.stack([x.ravel(), y.ravel()], axis=1))
    expected = (0.5 / wi[:, 2]).reshape(32, 32)
    assert np.array_equal(np.isnan(expected), np.isnan(snap.ratio))
    np.testing.assert_allclose(snap.ratio, expected, rtol=1e-9)
    assert snap.weight_rel_std > 0.1
    warp = sampling_snapshot(lam, 35.0, 10.0, ratio_sampler="adaptive_warp", grid=32)
    assert np.nanmax(np.abs(warp.ratio - 1.0)) < 1e-6
    phong = sampling_snapshot(make_brdf("phong", {"n": 40.0}), 35.0, 10.0, ratio_sampler="adaptive_warp")
    assert 0.8 < np.nanmedian(phong.ratio) < 1.25


def test_beyond_the_last_node_the_exact_mode_draws_the_cosine_density():
    from core.brdf import make_brdf

    snap = sampling_snapshot(make_brdf("lambert", {"kd": 0.5}), 89.95, 0.0)
    assert snap.cosine_fallback and snap.tree.normalizer == 0.0
    # the cosine density is Lambert's ideal; I comes from a quadrature of the disk
    assert np.nanmax(np.abs(snap.ratio - 1.0)) < 3e-3


def test_leaf_image_paints_each_pixel_with_the_leaf_holding_its_centre(snapshots):
    """A hand-made tiling (three quarters, one quarter split in four, one of those split again) and real
    trees: each pixel inside the disk holds the value of the leaf whose square holds its centre's point,
    found by brute force; pixels outside the disk are NaN."""
    quads = [(0.0, 0.0, 0.5, 0.5), (0.5, 0.0, 1.0, 0.5), (0.0, 0.5, 0.5, 1.0)]
    quads += [(0.5, 0.5, 0.75, 0.75), (0.75, 0.5, 1.0, 0.75), (0.5, 0.75, 0.75, 1.0)]
    quads += [
        (0.75 + i * 0.125, 0.75 + j * 0.125, 0.875 + i * 0.125, 0.875 + j * 0.125)
        for j in (0, 1)
        for i in (0, 1)
    ]
    hand = TreeView("equal_area", True, 0, (0.0, 0.0), (0.0, 1.0, 0.0, 360.0), np.array(quads), np.ones(10),
                    np.ones(10), 1.0, 1.0, (1.0, 1.0))  # fmt: skip
    views = [hand] + [snapshots[name, 150.0, "exact"][1].tree for name, _ in CASES]
    size = 40
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    inside = x * x + y * y < 1.0
    a, b = disk_to_square(x[inside], y[inside])
    for view in views:
        values = np.arange(len(view.boxes), dtype=np.float64)
        img = leaf_image(view, values, size)
        assert np.all(np.isnan(img[~inside]))
        bx = view.boxes
        holds = (a[:, None] >= bx[None, :, 0]) & (a[:, None] < bx[None, :, 2])
        holds &= (b[:, None] >= bx[None, :, 1]) & (b[:, None] < bx[None, :, 3])
        assert np.all(holds.sum(axis=1) == 1)
        assert np.array_equal(img[inside], values[np.argmax(holds, axis=1)])
    assert np.all(np.isnan(leaf_image(hand._replace(boxes=np.zeros((0, 4))), np.zeros(0), 8)))


def test_leaf_outlines_follow_the_concentric_map(snapshots):
    from core.sampling.adaptive import maps

    view = snapshots["phong", 30.0, "exact"][1].tree
    m = 4
    out = leaf_outlines(view, m)
    assert out.shape == (len(view.boxes), 4 * m + 1, 2)
    np.testing.assert_array_equal(out[:, 0], out[:, -1])  # closed
    a0, b0, a1, b1 = view.boxes.T
    for k, (a, b) in enumerate(((a0, b0), (a1, b0), (a1, b1), (a0, b1))):
        expected = np.array([maps.square_to_disk(u, v) for u, v in zip(a, b, strict=True)])
        np.testing.assert_allclose(out[:, k * m], expected, atol=1e-12)
    assert np.all(np.hypot(out[..., 0], out[..., 1]) <= 1.0 + 1e-12)
    # the vectorized map is the compiled one
    rng = np.random.default_rng(4)
    u, v = rng.random(200), rng.random(200)
    expected = np.array([maps.square_to_disk(p, q) for p, q in zip(u, v, strict=True)])
    np.testing.assert_allclose(np.stack(square_to_disk(u, v), axis=1), expected, atol=1e-15)


def test_snapshot_colours_are_made_with_it(snapshots):
    """The pictures the view shows come coloured from the snapshot process: the leaves by the mode's density
    (the densest leaf the scale's top colour, nothing outside the disk), the ratio map by log2 of the ratio
    (1 the middle colour, NaN transparent, 0 and infinity the scale's ends)."""
    from matplotlib import colormaps

    _, snap = snapshots["phong", 30.0, "warp"]
    rgba, lo, hi = leaf_colours(snap.tree, snap.leaf_density())
    np.testing.assert_array_equal(snap.leaf_rgba, rgba)
    np.testing.assert_array_equal(snap.edges, leaf_edges(snap.tree))
    assert snap.density_range == (lo, hi) and 0 < lo < hi
    n = rgba.shape[0]
    c = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    outside = np.add.outer(c * c, c * c) > 1.0
    assert not rgba[outside, 3].any() and rgba[~outside, 3].any()
    top = np.asarray(colormaps["magma"](1.0, bytes=True))
    assert (rgba.reshape(-1, 4) == top).all(axis=1).any()
    ratio = np.array([[1.0, np.nan], [0.0, np.inf]])
    got = ratio_colours(ratio)
    cmap = colormaps["coolwarm"]
    np.testing.assert_array_equal(got[0, 0], cmap(0.5, bytes=True))
    assert got[0, 1, 3] == 0
    np.testing.assert_array_equal(got[1, 0], cmap(0.0, bytes=True))
    np.testing.assert_array_equal(got[1, 1], cmap(1.0, bytes=True))
    assert snap.ratio_rgba is not None and snap.ratio_rgba.shape == (*snap.ratio.shape, 4)


def test_a_progressive_snapshot_shows_a_first_fit_until_the_full_table_is_made(monkeypatch, tmp_path):
    """The sampler view's first picture of a new material (exact mode) comes from the rejection-free mode's
    coarse table (no bounds, no normalizer: the fastest tree of the new value), marked as interim, with the
    exact table on its way; asking again, waiting for it, gives the full exact table's (whose ratio map is 1
    wherever f > 0). When the exact mode's coarse table is made already (a render made it), that is shown
    first instead (exact all the same)."""
    from app.sampling_data import INTERIM_WARP_TOL
    from core.brdf import make_brdf
    from core.sampling import make_sampler
    from core.sampling.adaptive import TableOptions

    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "tables"))
    brdf = make_brdf("ggx", {"alpha": 0.0911})
    first = sampling_snapshot(brdf, 40.0, 0.0, n_samples=300, grid=32, progressive=True)
    assert first.table["interim"] and not first.table["complete"] and first.table["full_pending"]
    assert first.mode == "warp" and first.ratio_sampler == "adaptive_warp" and len(first.samples) > 0
    assert first.table["theta_nodes"] == 7  # the initial layout: the coarse table
    assert first.table["options"]["warp_tol"] == INTERIM_WARP_TOL > TableOptions().warp_tol  # a coarser fit
    later = sampling_snapshot(brdf, 40.0, 0.0, n_samples=300, grid=32, progressive=True, settle=120.0)
    assert later.table["complete"] and not later.table["full_pending"] and not later.table["interim"]
    assert later.mode == "exact" and later.ratio_sampler == "adaptive_exact"
    finite = np.isfinite(later.ratio)
    np.testing.assert_allclose(later.ratio[finite & (later.ratio > 0)], 1.0, rtol=1e-6)

    other = make_brdf("ggx", {"alpha": 0.1213})
    make_sampler("adaptive_exact", other, progressive=True).preload()  # its coarse table, as a render's
    coarse = sampling_snapshot(other, 40.0, 0.0, n_samples=300, grid=32, progressive=True)
    assert not coarse.table["interim"] and not coarse.table["complete"] and coarse.mode == "exact"
    finite = np.isfinite(coarse.ratio)
    np.testing.assert_allclose(coarse.ratio[finite & (coarse.ratio > 0)], 1.0, rtol=1e-6)
    full = sampling_snapshot(other, 40.0, 0.0, n_samples=300, grid=32, progressive=True, settle=120.0)
    assert full.table["complete"] and full.table["theta_nodes"] > coarse.table["theta_nodes"]
