"""The arrays the views draw, checked against direct evaluation (no Qt)."""

from __future__ import annotations

import math

import numpy as np

from app.view_data import (
    direction_from_disk,
    grid_normals,
    grid_quads,
    hemisphere_grid,
    incidence_plane,
    leaf_raster,
    light_from_disk,
    lit_sphere,
    lobe,
    to_srgb8,
)
from core.model import get_model


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


def test_an_anisotropic_tree_is_shown_where_its_samples_fall_in_every_quadrant(tmp_path, monkeypatch):
    """Mirror-symmetric anisotropic BRDFs keep trees for the first quadrant of phi_o; the sampler view shows
    the tree mirrored to the direction's quadrant, so every drawn sample lies in a drawn leaf of the lobe
    (a tree left unmirrored would put the other quadrants' samples in leaves where ``f`` is ~0)."""
    from app.view_data import sampling_snapshot
    from core.model import make_brdf

    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path))
    brdf = make_brdf("ward", {"sx": 0.05, "sy": 0.25, "kd": (0.0, 0.0, 0.0)})  # f is ~0 away from the lobe
    for phi in (30.0, 150.0, 210.0, 330.0):
        snap = sampling_snapshot(brdf, 50.0, phi, n_samples=400)
        leaves, pts = snap["tree"]["leaves"], snap["samples"]
        assert len(pts) == 400
        inside = (
            (pts[:, None, 0] >= leaves[None, :, 1])
            & (pts[:, None, 0] <= leaves[None, :, 3])
            & (pts[:, None, 1] >= leaves[None, :, 2])
            & (pts[:, None, 1] <= leaves[None, :, 4])
            & (leaves[None, :, 0] > 1e-3 * leaves[:, 0].max())
        )
        assert inside.any(axis=1).all(), (
            f"phi={phi}: {np.sum(~inside.any(axis=1))} samples outside the leaves"
        )
        # the lobe sits on the mirror side of the normal: opposite quadrant to wo
        c = math.radians(phi)
        assert np.mean(pts @ np.array([math.cos(c), math.sin(c)])) < 0.0


def test_leaf_raster_paints_each_pixel_with_the_leaf_holding_its_centre():
    """A quadtree of the square [-1, 1]^2 (4 quadrants, one of them split in 4, and a leaf smaller than a
    pixel): each pixel whose centre lies inside a leaf holds that leaf's M; the tiny leaf covers one pixel."""
    leaves = np.array(
        [
            [1.0, -1.0, -1.0, 0.0, 0.0],
            [2.0, 0.0, -1.0, 1.0, 0.0],
            [3.0, -1.0, 0.0, 0.0, 1.0],
            [4.0, 0.0, 0.0, 0.5, 0.5],
            [5.0, 0.5, 0.0, 1.0, 0.5],
            [6.0, 0.0, 0.5, 0.5, 1.0],
            [7.0, 0.5, 0.5, 1.0, 1.0],
            [0.0, 0.5, 0.5, 0.5, 0.5],  # empty (mass 0, no area): ignored
        ]
    )
    size = 16
    img = leaf_raster(leaves, size)
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    for i, y in enumerate(c):
        for j, x in enumerate(c):
            holder = [m for m, x0, y0, x1, y1 in leaves if x0 < x < x1 and y0 < y < y1]
            assert img[i, j] == holder[0]
    tiny = leaf_raster(np.array([[9.0, 0.01, 0.01, 0.02, 0.02]]), size)
    assert np.count_nonzero(tiny) == 1 and tiny.max() == 9.0
    assert not leaf_raster(np.zeros((0, 5)), size).any()
