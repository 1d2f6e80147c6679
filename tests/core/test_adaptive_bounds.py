"""The exact mode's leaf bounds where they once fell short: a lobe squeezed against the horizon in a coarse rim
leaf (Lafortune, Lewis at 89-89.9 degrees) and a front where ``g`` is cut to 0 moving across a half-vector leaf
(a Blinn-Phong lobe divided by ``N.L``, as BRDF Explorer's ``blinnphong.brdf``, at 60 degrees; at 59.3
degrees, the front at its cell's edge view, a bound still falls short: an expected failure).

Two checks per case, fixed seeds: the ratio ``g / (c V p)`` on a dense grid of every leaf of the tree serving
``wo`` is at most 1 (deterministic, and far denser than the draws near a leaf's corner), and the draws
themselves count no violation."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from core.brdf import make_brdf
from core.dispatch import eval_model
from core.geometry import degrees_to_dir
from core.sampling import make_sampler
from core.sampling.adaptive.draw import _bilinear_density, _g_scale, _leaf_box, _leaf_probability
from core.sampling.adaptive.frames import _reflect, _to_local, _tree_frame
from core.sampling.adaptive.layout import normalizer_at
from core.sampling.adaptive.maps import HALF_VECTOR, PI, square_to_direction
from core.sampling.adaptive.target import luminance3

BLINN_PHONG_NDOTL = """analytic
::begin parameters
float n 1 1000 100
::end parameters
::begin shader
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    vec3 H = normalize(L + V);
    return vec3(pow(max(0, dot(N, H)), n) / dot(N, L));
}
::end shader
"""


@njit(cache=False)
def _largest_ratio(table, mid, p, wo, grid):
    """The largest ``g / (c V p)`` (``V p`` the envelope the draws test against) over a ``grid x grid`` lattice
    of every leaf of the tree serving ``wo``, in the draws' own arithmetic."""
    wx, wy, wz = wo[0], wo[1], wo[2]
    t, c, s, sx, sy, cos_o, sin_o = _tree_frame(table.symmetry, table.follow, table.cell_lut, table.cell_mu,
                                                table.phis, table.edge_cos, table.edge_sin, wx, wy, wz)  # fmt: skip
    norm = normalizer_at(table.symmetry, table.norm, table.norm_log, wz, cos_o, sin_o)
    start = table.leaf_base[t]
    proj = table.projection[t]
    best = 0.0
    for leaf in range(start, table.leaf_base[t + 1]):
        prob = _leaf_probability(table.cdf, start, leaf)
        x0, y0, h = _leaf_box(table.leaf_cell, leaf)
        v0 = np.float64(table.corners[leaf, 0])
        v1 = np.float64(table.corners[leaf, 1])
        v2 = np.float64(table.corners[leaf, 2])
        v3 = np.float64(table.corners[leaf, 3])
        for i in range(grid):
            for j in range(grid):
                tx = (i + 0.5) / grid
                ty = (j + 0.5) / grid
                x, y, z, jac = square_to_direction(x0 + tx * h, y0 + ty * h, proj)
                if z <= 0.0:
                    continue
                lx, ly, lz = _to_local(x, y, z, c, s, sx, sy)
                if proj == HALF_VECTOR:
                    lx, ly, lz, d = _reflect(lx, ly, lz, wx, wy, wz)
                    if d <= 0.0 or lz <= 0.0:
                        continue
                    scale = 4.0 * d * lz / jac
                else:
                    scale = _g_scale(proj, z, jac)
                r, g, b = eval_model(mid, (lx, ly, lz), (wx, wy, wz), p)
                lum = luminance3(r, g, b)
                if not lum > 0.0:
                    continue
                bound = table.total[t] * prob * _bilinear_density(v0, v1, v2, v3, tx, ty)
                best = max(best, lum * scale * PI / norm * h * h / bound)
    return best


def _check(brdf, thetas, phi=0.0, grid=64, samples=200_000):
    sampler = make_sampler("adaptive_exact", brdf, n_max=2.0, cache=False)
    for k, theta in enumerate(thetas):
        wo = degrees_to_dir(theta, phi)
        ratio = _largest_ratio(sampler.table, brdf.model.id, brdf.params, wo, grid)
        assert ratio <= 1.0, f"theta {theta}: g reaches {ratio:.4f} of its bound"
        sampler.sample(wo, samples, seed=100 + k)
    assert sampler.bound_violations == 0
    assert sampler.samples / sampler.trials >= 1.0 / 2.0


def test_lafortunes_rim_leaves_bound_its_lobe_at_grazing_angles():
    # was 1.14x its bound at 89 degrees in a level-3 rim leaf; check: 4 violations at 89 degrees
    _check(make_brdf("lafortune"), (88.9, 89.0, 89.9))


def _blinn_phong_ndotl(tmp_path):
    path = tmp_path / "blinnphong_ndotl.brdf"
    path.write_text(BLINN_PHONG_NDOTL)
    return make_brdf(str(path))


def test_a_front_crossing_a_half_vector_leaf_is_bounded_at_60_degrees(tmp_path):
    # was 1.8x its bound at 60 degrees (check: 1 violation in 1e5 samples)
    _check(_blinn_phong_ndotl(tmp_path), (60.0, 61.0))


@pytest.mark.xfail(
    reason="a front at its cell's edge view: a climb stalls on it (docs/adaptive.md, section 4)"
)
def test_a_front_at_a_cells_edge_view_is_bounded(tmp_path):
    # 1.19x its bound at 59.3 degrees on a 64 x 64 grid of a level-6 leaf, the front at the view 59.25
    _check(_blinn_phong_ndotl(tmp_path), (59.3,), samples=1000)


@pytest.mark.slow
@pytest.mark.parametrize("model", ["lafortune", "lewis"])
def test_grazing_bounds_hold_for_1e6_trials_at_each_azimuth(model):
    # bench/bounds.py's matrix at its grazing angles, where these two failed before
    brdf = make_brdf(model)
    sampler = make_sampler("adaptive_exact", brdf, n_max=2.0, cache=False, threads=True)
    for theta in (89.0, 89.9):
        for phi in (0.0, 40.0, 135.0):
            sampler.sample(degrees_to_dir(theta, phi), 800_000, seed=7)
    assert sampler.bound_violations == 0
