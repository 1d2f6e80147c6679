"""The adaptive sampler (core/sampling/adaptive): both modes draw what their pdf says, the exact mode's
density is exactly f cos / I (zero-variance weight, bounds that hold, acceptance >= 1/n_max), over whole
cells of outgoing directions and every azimuth, on hard cases, with clear errors for bad options.

Statistical tests use fixed seeds; chi^2 tests are at significance 0.01 with the Sidak correction over the
cases of their parametrization (core.chi2). The slow sweep (``-m slow``) covers every model."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from core.analysis import albedo
from core.brdf import LUMINANCE, all_models, make_brdf
from core.chi2 import chi2_test, sampler_functions, sidak_alpha
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.sampling import make_sampler
from core.sampling.adaptive import AdaptiveSampler
from core.sampling.adaptive.inspect import disk_to_square
from core.sampling.adaptive.layout import ISOTROPIC, MIRROR
from core.sampling.adaptive.maps import (
    EQUAL_AREA,
    HALF_VECTOR,
    ORTHOGRAPHIC,
    RIM,
    direction_to_square,
    square_to_direction,
    square_to_disk,
)
from core.sampling.adaptive.survey import symmetry_of

pytestmark = pytest.mark.usefixtures("private_tables")

CHI2_CASES = [
    ("lambert", {}, 30.0, 0.0, "exact"),
    ("phong", {}, 60.0, 0.0, "exact"),
    ("ggx", {"alpha": 0.08}, 85.0, 0.0, "exact"),
    ("cook_torrance", {"m": 0.2}, 30.0, 0.0, "exact"),
    ("minnaert", {}, 89.0, 0.0, "exact"),
    ("ward", {"sx": 0.05, "sy": 0.25}, 70.0, 100.0, "exact"),
    ("ashikhmin_shirley", {"nu": 10.0, "nv": 200.0}, 89.0, 17.0, "exact"),
    ("phong", {}, 10.0, 0.0, "warp"),
    ("ward", {"sx": 0.05, "sy": 0.25}, 30.0, 17.0, "warp"),
]
"""The fast suite's chi^2 cases. The rejection-free density is piecewise (discontinuous at the leaves'
edges), which makes the expected counts slow to integrate (~15 s a case): two cases here, every model in
the slow sweep."""
ALPHA = sidak_alpha(0.01, len(CHI2_CASES))


VIOLATION_RATE = 3e-5
"""Bound violations per trial allowed to an anisotropic material's exact mode (and to every material in the slow sweep). Its bounds are checked at nine
views of each cell, along the lobe's ridge and by probes, not proven: between the views a lobe that turns
with ``wo`` can rise above them, at grazing angles mostly (measured: Ward sx=0.05 sy=0.25, Ashikhmin-Shirley
nu=10 nv=200 and Poulin-Fournier, 2e6 draws each at 400 random ``wo``: 3, 4 and 3 violations in ~3.4e6
trials, ~1e-6 a trial; 6 in 5.3e5 at 89 degrees). An isotropic material's bounds are checked the same way
and hold in every fast test (they allow none), but not everywhere: the slow sweep's 1e6 draws at 89 degrees
find 2 trials above Lewis's bound, and a 64-angle sweep of Cook-Torrance m=0.005 finds 3e-5 of trials above
it (the construction before the bounds on g/c: 6e-5). The slow sweep allows this rate to every material; see
docs/adaptive.md, "Bounds"."""


def _allowed_violations(sampler: AdaptiveSampler) -> float:
    if symmetry_of(sampler.brdf) == ISOTROPIC:
        return 0.0
    return VIOLATION_RATE * sampler.trials


def _wo(theta: float, phi: float = 0.0) -> np.ndarray:
    return degrees_to_dir(theta, phi)


def _lum_albedo(brdf, theta: float, phi: float = 0.0) -> float:
    return float(albedo(brdf, theta, phi_deg=phi, rtol=1e-7).value @ LUMINANCE)


# ------------------------------------------------------------------------------------------ the maps
@pytest.mark.parametrize("projection", [ORTHOGRAPHIC, EQUAL_AREA, HALF_VECTOR, RIM])
def test_the_maps_invert_each_other_and_keep_their_stated_jacobian(projection, rng):
    a, b = rng.random(2000), rng.random(2000)
    for x, y in zip(a, b, strict=True):
        wx, wy, wz, jac = square_to_direction(x, y, projection)
        assert abs(wx * wx + wy * wy + wz * wz - 1.0) < 1e-12
        x2, y2, jac2 = direction_to_square(wx, wy, wz, projection)
        assert abs(x2 - x) < 1e-9 and abs(y2 - y) < 1e-9
        assert abs(jac - jac2) < 1e-9
    # area: the concentric map has Jacobian pi, the projection dA/d(omega) = jac, so the square's area
    # element is (1 / (pi jac)) d(omega): finite differences over small squares
    h = 1e-4
    for x, y in zip(a[:200] * 0.98 + 0.01, b[:200] * 0.98 + 0.01, strict=True):
        p = [
            np.array(square_to_direction(x + dx, y + dy, projection)[:3])
            for dx, dy in ((0, 0), (h, 0), (0, h))
        ]
        solid = np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0]))
        jac = square_to_direction(x + h / 3, y + h / 3, projection)[3]
        if jac > 1e-3:
            assert solid == pytest.approx(h * h * math.pi / jac, rel=2e-3)


def test_the_compiled_inverse_of_the_concentric_map_holds_on_its_seams():
    """The compiled ``disk_to_square`` (an arc tangent's polynomial and selects) inverts the map on the seams
    where its cases meet: the axes, the diagonals, the rim, the corners and the centre, and agrees with the
    numpy one there."""
    from core.sampling.adaptive.maps import disk_to_square as compiled

    ticks = [0.0, 1e-300, 1e-9, 0.25, 0.5 - 1e-16, 0.5, 0.5 + 1e-16, 0.75, 1.0 - 1e-16, 1.0]
    for a in ticks:
        for b in ticks + [a, 1.0 - a]:  # the diagonals too
            x, y = square_to_disk(a, b)
            a2, b2 = compiled(x, y)
            assert abs(a2 - a) < 4e-16 and abs(b2 - b) < 4e-16, (a, b, a2, b2)
            n2 = disk_to_square(np.array([x]), np.array([y]))
            assert abs(n2[0][0] - a2) < 1e-15 and abs(n2[1][0] - b2) < 1e-15
    for x, y in ((0.0, -0.0), (-0.0, 0.0), (-0.0, -0.0)):
        assert compiled(x, y) == (0.5, 0.5)


def test_the_concentric_map_is_inverted_in_numpy_too(rng):
    a, b = rng.random(500), rng.random(500)
    disk = np.array([square_to_disk(x, y) for x, y in zip(a, b, strict=True)])
    a2, b2 = disk_to_square(disk[:, 0], disk[:, 1])
    assert np.max(np.abs(a2 - a)) < 1e-12 and np.max(np.abs(b2 - b)) < 1e-12


# ------------------------------------------------------------------------------------------ chi^2
@pytest.mark.parametrize(("name", "params", "theta", "phi", "mode"), CHI2_CASES)
def test_draws_follow_the_reported_density(name, params, theta, phi, mode):
    brdf = make_brdf(name, params)
    sampler = AdaptiveSampler(brdf, mode=mode)
    sample, pdf = sampler_functions(sampler, _wo(theta, phi))
    result = chi2_test(sample, pdf, n_samples=300_000, seed=11, alpha=ALPHA, cell_tol=1e-2 / 300_000)
    assert result.passed, result.summary()
    assert sampler.bound_violations <= _allowed_violations(sampler)


# ------------------------------------------------------------------------------------------ the exact mode
@pytest.mark.parametrize(
    ("name", "params", "theta", "phi"),
    [("phong", {}, 30.0, 0.0), ("ggx", {}, 75.0, 0.0), ("ward", {"sx": 0.05, "sy": 0.25}, 60.0, 33.0),
     ("lambert", {}, 89.5, 0.0)],
)  # fmt: skip
def test_the_exact_modes_weight_is_the_albedo_for_every_sample(name, params, theta, phi):
    brdf = make_brdf(name, params)
    sampler = make_sampler("adaptive_exact", brdf)
    wo = _wo(theta, phi)
    drawn = sampler.sample(wo, 20_000, seed=3)
    weight = (drawn.f @ LUMINANCE) * drawn.wi[:, 2] / drawn.pdf
    assert np.std(weight) / np.mean(weight) < 1e-3  # measured ~1e-16: f cos / pdf = I(wo) exactly
    assert np.mean(weight) == pytest.approx(_lum_albedo(brdf, theta, phi), rel=3e-4)
    assert sampler.bound_violations <= _allowed_violations(sampler)


@pytest.mark.parametrize(
    ("name", "params", "n_max"),
    [("phong", {}, 1.3), ("cook_torrance", {}, 2.0), ("minnaert", {}, 2.0), ("minnaert", {}, 3.0),
     ("ashikhmin_shirley", {"nu": 10.0, "nv": 200.0}, 2.0), ("ggx", {}, 1.3)],
)  # fmt: skip
def test_bounds_hold_and_acceptance_meets_n_max_over_whole_cells(name, params, n_max, rng):
    """Random outgoing directions over the whole hemisphere (so every cell, its edges included, and every
    azimuth): no trial finds f above its bound (anisotropic: see VIOLATION_RATE), and the
    acceptance is at least 1 / n_max; for an anisotropic material, at least 0.9 / n_max within 5 degrees of
    the horizon (those trees fill their capacity before the envelope reaches n_max: measured 0.47 at
    89.9 degrees for n_max = 2)."""
    brdf = make_brdf(name, params)
    sampler = make_sampler("adaptive_exact", brdf, n_max=n_max)
    u = rng.random(4000)
    phi = rng.random(4000) * 2.0 * np.pi
    cos_t = 1.0 - u * (1.0 - math.cos(math.radians(89.8)))
    sin_t = np.sqrt(1.0 - cos_t * cos_t)
    wo = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)
    batch, trials = sampler.sample_with_trials(np.repeat(wo, 25, axis=0), seed=5)
    assert sampler.bound_violations <= _allowed_violations(sampler)
    acceptance = sampler.acceptance(wo)
    if symmetry_of(brdf) == ISOTROPIC:
        assert np.all(acceptance >= 1.0 / n_max)
    else:
        grazing = cos_t < math.cos(math.radians(85.0))
        assert np.all(acceptance[~grazing] >= 1.0 / n_max)
        assert np.all(acceptance[grazing] >= 0.9 / n_max)
    assert np.mean(trials) <= n_max
    assert np.all(np.isfinite(batch.pdf)) and np.all(batch.pdf > 0)


def test_the_normalizer_is_interpolated_to_within_3e_4_between_nodes(rng):
    brdf = make_brdf("cook_torrance")
    sampler = make_sampler("adaptive_exact", brdf)
    for theta in rng.uniform(0.0, 89.5, 6):
        wo = _wo(theta)
        assert sampler.normalizer(wo)[0] == pytest.approx(_lum_albedo(brdf, theta), rel=3e-4)


def test_the_measured_materials_normalizer_is_within_1_5e_4_up_to_the_horizon(bundled_merl_brdf):
    """Its table's kinks made the half-vector quadrature read its error low (2.8e-4 off at nodes) and 48
    angles left its ``I``, which peaks at 89.3 degrees, unresolved near the horizon: 3.9e-3 off at 89.85.
    The reference is ``core.analysis.albedo``'s cubature at ``rtol = 1e-6`` (within 8e-7 of a level-16
    quadrature of one view at 89.85 degrees; ~6 s for the six angles)."""
    thetas = [30.0, 78.0, 85.0, 89.0, 89.7, 89.85]
    sampler = AdaptiveSampler(bundled_merl_brdf, mode="exact")
    got = sampler.normalizer(np.array([_wo(t) for t in thetas]))
    want = [float(albedo(bundled_merl_brdf, t, rtol=1e-6).value @ LUMINANCE) for t in thetas]
    np.testing.assert_allclose(got, want, rtol=1.5e-4)


def test_the_issues_failing_check_passes_at_every_azimuth():
    """``check --model ashikhmin_shirley --sampler adaptive_exact --theta 89`` printed FAIL at its default
    phi_o = 17 degrees (acceptance 0.327 < 1/n_max)."""
    brdf = make_brdf("ashikhmin_shirley")
    sampler = make_sampler("adaptive_exact", brdf)
    wo = np.array([_wo(89.0, phi) for phi in (0.0, 17.0, 45.0, 90.0, 163.0, 250.0, 333.0)])
    assert np.all(sampler.acceptance(wo) >= 0.5)


# ------------------------------------------------------------------------------------------ both modes
@pytest.mark.parametrize("mode", ["exact", "warp"])
def test_a_draw_returns_f_and_the_pdf_that_pdf_reports(mode, rng):
    brdf = make_brdf("ward", {"sx": 0.08, "sy": 0.3})
    sampler = AdaptiveSampler(brdf, mode=mode)
    wo = np.stack([_wo(t, p) for t, p in zip(rng.uniform(0, 89, 300), rng.uniform(0, 360, 300), strict=True)])
    drawn = sampler.sample_each(np.repeat(wo, 10, axis=0), seed=2)
    wo_rows = np.repeat(wo, 10, axis=0)
    np.testing.assert_allclose(drawn.f, brdf.eval(wo_rows, drawn.wi), rtol=0, atol=0)
    np.testing.assert_allclose(sampler.pdf(wo_rows, drawn.wi), drawn.pdf, rtol=1e-6)
    f, pdf = sampler.eval_pdf(wo_rows, drawn.wi)
    np.testing.assert_array_equal(f, drawn.f)


def test_draws_on_threads_are_the_draws_of_one_thread():
    brdf = make_brdf("phong")
    wo = np.repeat(_wo(40.0, 20.0)[None, :], 40_000, axis=0)
    one = make_sampler("adaptive_exact", brdf).sample_each(wo, seed=9)
    many = make_sampler("adaptive_exact", brdf, threads=True).sample_each(wo, seed=9)
    np.testing.assert_array_equal(one.wi, many.wi)
    np.testing.assert_array_equal(one.pdf, many.pdf)


def test_mirrored_outgoing_directions_draw_mirrored_samples():
    brdf = make_brdf("ward", {"sx": 0.05, "sy": 0.25})
    sampler = make_sampler("adaptive_warp", brdf)
    assert sampler.table.symmetry == MIRROR
    wo = _wo(50.0, 30.0)
    mirror = wo * np.array([-1.0, 1.0, 1.0])
    a = sampler.sample(wo, 1000, seed=4)
    b = sampler.sample(mirror, 1000, seed=4)
    np.testing.assert_allclose(b.wi, a.wi * np.array([-1.0, 1.0, 1.0]), atol=1e-12)
    np.testing.assert_allclose(b.pdf, a.pdf, rtol=1e-12)


def test_an_anisotropic_model_at_isotropic_parameters_is_laid_out_as_isotropic():
    assert symmetry_of(make_brdf("ward", {"sx": 0.1, "sy": 0.1})) == ISOTROPIC
    assert symmetry_of(make_brdf("ward", {"sx": 0.1, "sy": 0.2})) == MIRROR


def test_the_exact_mode_does_not_choose_a_disk_whose_azimuth_cells_cannot_reach_the_acceptance():
    """Poulin-Fournier's half-vector lobe turns with the azimuth in the local frame: across an azimuth cell
    its envelope cannot fall below ``1 + TV`` of the cell's edge views, above what ``n_max = 1.3`` allows
    (polar halvings do not narrow azimuth cells), so the exact mode takes the wi disk there; at ``n_max = 2``,
    and in the rejection-free mode, the disk that moves less."""
    from core.sampling.adaptive.layout import cell_edges, phi_nodes
    from core.sampling.adaptive.survey import azimuth_floor, choose_projection
    from core.sampling.adaptive.tree import ACCEPT_MARGIN

    brdf = make_brdf("poulin_fournier")
    edges = cell_edges(phi_nodes(MIRROR, 4), 0.0, 0.5 * math.pi)
    aim = 1.3 / (1.0 + ACCEPT_MARGIN)
    assert azimuth_floor(brdf, EQUAL_AREA, 1, edges) <= aim < azimuth_floor(brdf, HALF_VECTOR, 0, edges)
    assert choose_projection(brdf, MIRROR, "auto", 1.3, edges) == (EQUAL_AREA, 1)
    assert choose_projection(brdf, MIRROR, "auto", 2.0, edges) == (HALF_VECTOR, 0)
    assert choose_projection(brdf, MIRROR, "auto", 0.0, edges) == (HALF_VECTOR, 0)


def test_the_exact_mode_narrows_the_azimuth_cells_where_their_floor_takes_most_of_the_slack():
    """Ashikhmin-Shirley nu=10 nv=200's wi lobe changes across a 30-degree azimuth cell at grazing angles
    (floor above half of n_max = 2's slack): its exact table gets 6 azimuth nodes, and the floor over them is
    within that share; Ward sx=0.05 sy=0.25 keeps 4, and so does every rejection-free table."""
    from core.sampling.adaptive.layout import phi_nodes
    from core.sampling.adaptive.records import TableOptions
    from core.sampling.adaptive.survey import (
        AZIMUTH_FLOOR_GRAZING_DEG,
        AZIMUTH_FLOOR_THETAS_DEG,
        AZIMUTH_SHARE,
        azimuth_count,
        azimuth_edges,
        azimuth_floor,
    )
    from core.sampling.adaptive.tree import ACCEPT_MARGIN

    exact, warp = TableOptions(n_max=2.0), TableOptions(n_max=2.0, bounds=False)
    slack = AZIMUTH_SHARE * (2.0 / (1.0 + ACCEPT_MARGIN) - 1.0)
    thetas = AZIMUTH_FLOOR_THETAS_DEG + AZIMUTH_FLOOR_GRAZING_DEG
    brdf = make_brdf("ashikhmin_shirley", {"nu": 10.0, "nv": 200.0})
    assert azimuth_count(brdf, MIRROR, EQUAL_AREA, 1, exact) == 6
    assert azimuth_count(brdf, MIRROR, EQUAL_AREA, 1, warp) == 4
    for count, above in ((4, True), (6, False)):
        floor = azimuth_floor(brdf, EQUAL_AREA, 1, azimuth_edges(MIRROR, phi_nodes(MIRROR, count)), thetas)
        assert (floor - 1.0 > slack) == above
    ward = make_brdf("ward", {"sx": 0.05, "sy": 0.25})
    assert azimuth_count(ward, MIRROR, HALF_VECTOR, 0, exact) == 4


def test_a_lambertian_material_keeps_the_initial_layout_and_a_glossy_one_asks_for_more():
    from core.sampling.adaptive.layout import INITIAL_THETAS_DEG
    from core.sampling.adaptive.maps import ORTHOGRAPHIC as ORTHO

    flat = make_sampler("adaptive_exact", make_brdf("lambert")).table
    assert len(flat.thetas) == len(INITIAL_THETAS_DEG)
    assert np.all(flat.projection == ORTHO)  # pi f is flat on the seed's disk: one level of leaves
    glossy = make_sampler("adaptive_exact", make_brdf("ggx", {"alpha": 0.1})).table
    assert len(glossy.thetas) > len(INITIAL_THETAS_DEG)
    assert np.all(glossy.projection != ORTHO)


def test_a_coloured_lambertian_material_has_a_flat_table_drawn_as_the_cosine_density():
    """Flatness is per channel (the channels of a coloured albedo differ, the directions do not): both modes
    then draw the cosine density, and say so to a renderer; a glossy material has no such equivalent."""
    brdf = make_brdf("lambert", {"kd": [0.55, 0.55, 0.2]})
    for mode in ("exact", "warp"):
        sampler = make_sampler(f"adaptive_{mode}", brdf, cache=False)
        assert sampler.table.flat == 1
        assert sampler.compiled_equivalent() == "cosine"
        wo = np.tile(degrees_to_dir(40.0, 10.0), (2000, 1))
        drawn = sampler.sample_each(wo, seed=3)
        np.testing.assert_allclose(drawn.pdf, drawn.wi[:, 2] / math.pi, rtol=1e-12)
        np.testing.assert_allclose(drawn.f, np.tile([0.55, 0.55, 0.2], (2000, 1)) / math.pi, rtol=1e-12)
    assert make_sampler("adaptive_exact", make_brdf("phong"), cache=False).compiled_equivalent() is None


@pytest.mark.parametrize("mode", ["exact", "warp"])
def test_in_place_draws_and_masked_densities_equal_the_batch_interface(mode):
    """``sample_into`` writes ``sample_each``'s draws into views of a caller's buffers, and ``eval_pdf_where``
    writes ``eval_pdf`` at the masked rows only, leaving the others untouched."""
    sampler = make_sampler(f"adaptive_{mode}", make_brdf("ggx", {"alpha": 0.2}))
    rng = np.random.default_rng(5)
    n = 3000
    wo = rng.normal(size=(n, 3))
    wo[:, 2] = np.abs(wo[:, 2])
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    ref = sampler.sample_each(wo[100:2100], seed=9)
    wi, pdf, f = np.full((n, 3), -7.0), np.full(n, -7.0), np.full((n, 3), -7.0)
    sampler.sample_into(wo[100:2100], 9, wi[100:2100], pdf[100:2100], f[100:2100])
    np.testing.assert_array_equal(wi[100:2100], ref.wi)
    np.testing.assert_array_equal(pdf[100:2100], ref.pdf)
    np.testing.assert_array_equal(f[100:2100], ref.f)
    assert np.all(pdf[:100] == -7.0) and np.all(pdf[2100:] == -7.0)
    mask = rng.random(n) < 0.5
    wi = sampler.sample_each(wo, seed=1).wi
    f_at, pdf_at = np.full((n, 3), -7.0), np.full(n, -7.0)
    sampler.eval_pdf_where(wo, wi, mask, f_at, pdf_at)
    f_ref, pdf_ref = sampler.eval_pdf(wo[mask], wi[mask])
    np.testing.assert_array_equal(pdf_at[mask], pdf_ref)
    np.testing.assert_array_equal(f_at[mask], f_ref)
    assert np.all(pdf_at[~mask] == -7.0) and np.all(f_at[~mask] == -7.0)


def test_a_progressive_sampler_starts_coarse_and_swaps_in_the_full_table_when_asked():
    """A coarse table at once, exact all the same; the full one built in the background once a refresh asks
    for it, and swapped in by a refresh."""
    from core.sampling.adaptive.layout import INITIAL_THETAS_DEG

    brdf = make_brdf("ggx", {"alpha": 0.1})
    sampler = make_sampler("adaptive_exact", brdf, progressive=True)
    wo = np.repeat(_wo(50.0)[None, :], 2000, axis=0)
    assert len(sampler.table.thetas) == len(INITIAL_THETAS_DEG)
    coarse = sampler.sample_each(wo, seed=1)
    np.testing.assert_allclose(sampler.pdf(wo, coarse.wi), coarse.pdf, rtol=1e-9)
    # the full build is queued by the first refresh (a renderer's first pass does not share the cores with it)
    from core.sampling.adaptive import sampler as module

    assert sampler.key not in module._BUILDING and not sampler.complete
    assert sampler.refresh(wait=True)
    assert sampler.complete and len(sampler.table.thetas) > len(INITIAL_THETAS_DEG)
    assert not sampler.refresh()
    full = sampler.sample_each(wo, seed=1)
    np.testing.assert_allclose(sampler.pdf(wo, full.wi), full.pdf, rtol=1e-9)
    weight = (full.f @ LUMINANCE) * full.wi[:, 2] / full.pdf
    assert np.std(weight) / np.mean(weight) < 1e-3  # exact with either table
    assert sampler.bound_violations == 0


# ------------------------------------------------------------------------------------------ hard cases
@pytest.mark.parametrize(
    ("name", "params", "mode"),
    [("phong", {"n": 10000.0}, "exact"), ("ggx", {"alpha": 0.001}, "warp"), ("cook_torrance", {"m": 0.005}, "exact"),
     ("lambert", {"kd": 0.0}, "exact"), ("lambert", {"kd": 0.0}, "warp"), ("ward", {"sx": 0.005, "sy": 0.005}, "exact"),
     ("minnaert", {"k": 0.1}, "warp")],
)  # fmt: skip
def test_hard_materials_and_grazing_directions_give_finite_densities(name, params, mode):
    brdf = make_brdf(name, params)
    sampler = AdaptiveSampler(brdf, mode=mode)
    wo = np.array([_wo(t) for t in (0.0, 45.0, 89.0, 89.9, 89.99, 90.0)] + [[0.6, 0.0, -0.8]])
    drawn = sampler.sample_each(np.repeat(wo, 200, axis=0), seed=8)
    assert np.all(np.isfinite(drawn.wi)) and np.all(np.isfinite(drawn.pdf)) and np.all(np.isfinite(drawn.f))
    assert np.all(drawn.pdf >= 0.0) and np.all(drawn.f >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(drawn.wi, axis=1), 1.0, atol=1e-9)
    pdf = sampler.pdf(np.repeat(wo, 200, axis=0), drawn.wi)
    assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
    assert sampler.bound_violations == 0


# ------------------------------------------------------------------------------------------ options, cache
@pytest.mark.parametrize(
    ("options", "needle"),
    [({"n_max": 1.0}, "n_max"), ({"n_max": float("nan")}, "n_max"), ({"phi_count": 2.5}, "phi_count"),
     ({"max_thetas": "x"}, "max_thetas"), ({"warp_tol": -1.0}, "warp_tol"), ({"theta_step": 1.0}, "theta_step"),
     ({"parameterization": "disk"}, "parameterization"), ({"mode": "fast"}, "mode")],
)  # fmt: skip
def test_bad_options_are_refused_with_a_message_naming_them(options, needle):
    with pytest.raises(ParameterError, match=needle):
        AdaptiveSampler(make_brdf("phong"), **options)


def test_a_table_is_stored_and_loaded_again_and_a_torn_file_is_rebuilt(tmp_path):
    from core.sampling.adaptive import clear_memory_cache

    brdf = make_brdf("blinn")
    first = AdaptiveSampler(brdf, cache=tmp_path)
    drawn = first.sample(_wo(30.0), 100, seed=1)
    assert not first.info()["from_cache"]
    clear_memory_cache()
    second = AdaptiveSampler(brdf, cache=tmp_path)
    assert second.info()["from_cache"]
    np.testing.assert_array_equal(second.sample(_wo(30.0), 100, seed=1).wi, drawn.wi)
    for path in tmp_path.rglob("*.npz"):
        path.write_bytes(path.read_bytes()[:100])
    clear_memory_cache()
    third = AdaptiveSampler(brdf, cache=tmp_path)
    assert not third.info()["from_cache"]
    np.testing.assert_array_equal(third.sample(_wo(30.0), 100, seed=1).wi, drawn.wi)


# ------------------------------------------------------------------------------------------ the slow sweep
@pytest.mark.slow
@pytest.mark.parametrize("n_max", [1.3, 2.0, 3.0])
@pytest.mark.parametrize("mode", ["exact", "warp"])
@pytest.mark.parametrize("model", [m.name for m in all_models()])
def test_chi2_full_sweep(model, mode, n_max):
    """Every model at its defaults, theta_o 0, 30, 60, 80 and 89 degrees (anisotropic ones at phi_o 17),
    1e6 samples each."""
    brdf = make_brdf(model)
    sampler = AdaptiveSampler(brdf, mode=mode, n_max=n_max)
    thetas = (0.0, 30.0, 60.0, 80.0, 89.0)
    alpha = sidak_alpha(0.01, len(all_models()) * 2 * 3 * len(thetas))
    for theta in thetas:
        phi = 0.0 if brdf.model.isotropic else 17.0
        sample, pdf = sampler_functions(sampler, _wo(theta, phi))
        result = chi2_test(sample, pdf, n_samples=1_000_000, seed=int(theta) + 1, alpha=alpha)
        assert result.passed, f"{model} {mode} n_max={n_max} theta={theta}: {result.summary()}"
    assert sampler.bound_violations <= VIOLATION_RATE * sampler.trials
    if mode == "exact":
        wo = np.array([_wo(t, 17.0) for t in thetas])
        assert np.all(sampler.acceptance(wo) >= 1.0 / n_max)


def test_the_normalizers_table_is_the_cubic_through_the_nearest_nodes():
    """normalizer_table resamples the nodes' values by Lagrange cubics in s through the four nearest nodes at
    its rows' cos theta: a cubic in s is reproduced exactly (to rounding) at every row a view reads (down to
    cos(THETA_END)), with 1-3 nodes the polynomial of their degree; the rows below continue the line through
    the last node's value, so that cos(THETA_END) itself reads that value."""
    from core.sampling.adaptive.layout import (
        NORM_ROWS,
        THETA_END,
        norm_coordinate,
        normalizer_grid,
        normalizer_table,
    )

    rng = np.random.default_rng(5)
    mu = normalizer_grid()
    read = mu >= np.cos(THETA_END)
    for k in (1, 2, 3, 4, 7, 23):
        thetas = np.sort(np.append(rng.uniform(0.0, THETA_END, k - 1), THETA_END))
        s = norm_coordinate(thetas)
        degree = min(k - 1, 3)
        coef = rng.normal(size=(degree + 1, 3))
        values = np.stack([np.polyval(c, s) for c in coef.T], axis=1)
        table = normalizer_table(thetas, values)
        expect = np.stack([np.polyval(c, -np.log(mu[read])) for c in coef.T], axis=1)
        assert table.shape == (NORM_ROWS, 3)
        np.testing.assert_allclose(table[read], expect, rtol=1e-8, atol=1e-8 * np.abs(expect).max())
        r = int(np.flatnonzero(~read)[-1])
        at_end = table[r] + (np.cos(THETA_END) - mu[r]) / (mu[r + 1] - mu[r]) * (table[r + 1] - table[r])
        np.testing.assert_allclose(at_end, values[-1], rtol=1e-9, atol=1e-9 * np.abs(values).max())


def test_the_normalizer_is_read_linearly_between_its_rows_in_cos_theta():
    """normalizer_at finds a view's rows from the bits of cos theta (octave and step, no logarithm): at a row's
    own cos theta it reads that row, halfway between two rows their mean, for every symmetry; the azimuth
    enters through its unit vector (MIRROR: the series in cos 2 phi = c^2 - s^2; FULL: the periodic cubic at
    phi); out of range (below the table, NaN, above 1) it reads the first or last row, finite."""
    from core.sampling.adaptive.layout import (
        FULL,
        ISOTROPIC,
        MIRROR,
        NORM_ROWS,
        normalizer_at,
        normalizer_grid,
    )

    rng = np.random.default_rng(11)
    mu = normalizer_grid()
    table = rng.uniform(0.5, 2.0, (NORM_ROWS, 3))
    rows = rng.integers(0, NORM_ROWS - 1, 400)
    for r in rows:
        assert normalizer_at(ISOTROPIC, table, 0, mu[r], 1.0, 0.0) == pytest.approx(table[r, 0], rel=1e-14)
        mid = 0.5 * (mu[r] + mu[r + 1])
        assert normalizer_at(ISOTROPIC, table, 0, mid, 1.0, 0.0) == pytest.approx(
            0.5 * (table[r, 0] + table[r + 1, 0]), rel=1e-12
        )
        phi = rng.uniform(0.0, 0.5 * np.pi)
        series = table[r, 0] + table[r, 1] * np.cos(2 * phi) + table[r, 2] * np.cos(4 * phi)
        got = normalizer_at(MIRROR, table, 1, mu[r], np.cos(phi), np.sin(phi))
        assert got == pytest.approx(np.exp(series), rel=1e-12)
        at_node = normalizer_at(FULL, table, 0, mu[r], np.cos(2 * np.pi / 3), np.sin(2 * np.pi / 3))
        assert at_node == pytest.approx(table[r, 1], rel=1e-12)
    assert normalizer_at(ISOTROPIC, table, 0, 1.0, 1.0, 0.0) == pytest.approx(table[-1, 0], rel=1e-14)
    assert normalizer_at(ISOTROPIC, table, 0, 1.0 + 2e-16, 1.0, 0.0) == pytest.approx(table[-1, 0], rel=1e-14)
    for bad in (0.0, 1e-5, -0.5, np.nan):
        assert normalizer_at(ISOTROPIC, table, 0, bad, 1.0, 0.0) == table[0, 0]


def test_background_builds_can_be_dropped_but_the_kept_one():
    """The sampler view during a slider drag wants only its latest material's full table: the running build
    of an earlier value stops (it would hold the cores the next value's coarse table needs) and is not a
    failure, the queued ones are dropped, the kept one is built, and a dropped one is queued again by a later
    refresh."""
    from core.sampling.adaptive import sampler as module

    running = make_sampler("adaptive_exact", make_brdf("ward", {"sx": 0.05, "sy": 0.25}), progressive=True)
    dropped = make_sampler("adaptive_exact", make_brdf("phong", {"n": 31.0}), progressive=True)
    kept = make_sampler("adaptive_exact", make_brdf("phong", {"n": 47.0}), progressive=True)
    running.preload()
    running.refresh()
    stopping = module._BUILDING[running.key]
    while not stopping.running():  # Ward's full table takes seconds: it is being built when dropped
        time.sleep(0.001)
    for s in (dropped, kept):
        s.preload()
        s.refresh()
    assert module.drop_builds(keep=kept.key) == 2
    assert not running.full_pending and not dropped.full_pending and kept.full_pending
    assert stopping.result() is None  # stopped, not failed
    assert running.key not in module._TABLES and running.key not in module._FAILED
    module.wait_for_build(kept.key)  # (the table facts wait so rather than build it a second time)
    assert kept.key in module._TABLES and kept.key not in module._BUILDING
    assert kept.refresh() and kept.complete
    assert not dropped.refresh() and not dropped.complete
    assert dropped.refresh(wait=True) and dropped.complete  # queued again
    assert running.refresh(wait=True) and running.complete


def test_a_cancelled_build_stops_at_once():
    """``build_table`` with its ``cancel`` event set raises ``BuildCancelled`` before any tree (and a build
    whose event is set while it runs stops at its next tree: the test above)."""
    import threading

    from core.sampling.adaptive.records import BuildCancelled, TableOptions
    from core.sampling.adaptive.table import build_table

    cancel = threading.Event()
    cancel.set()
    with pytest.raises(BuildCancelled):
        build_table(make_brdf("phong", {"n": 29.0}), TableOptions(), cancel=cancel)


def test_background_builds_run_at_the_niceness_asked_for(monkeypatch):
    """``lower_build_priority``: the builder thread (and the threads a build starts from it) run at that
    niceness, so that an interactive process's own work gets the cores first."""
    import os
    import threading

    from core.sampling.adaptive import sampler as module

    seen = []

    def recording(brdf, options, *args, **kwargs):
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
        helper = threading.Thread(
            target=lambda: seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
        )
        helper.start()
        helper.join()
        raise module.BuildCancelled  # (no table wanted: nothing is stored)

    before = os.getpriority(os.PRIO_PROCESS, 0)
    sampler = make_sampler("adaptive_exact", make_brdf("phong", {"n": 37.0}), progressive=True)
    sampler.preload()  # the coarse table, on this thread
    monkeypatch.setattr(module, "build_table", recording)
    monkeypatch.setattr(module, "_BUILDER_NICENESS", before + 3)
    sampler.refresh(wait=True)
    assert seen == [before + 3, before + 3]
    assert os.getpriority(os.PRIO_PROCESS, 0) == before  # the caller's own priority is untouched
    try:  # give the shared builder thread its priority back for the other tests (needs the privilege)
        module._BUILDER.submit(os.setpriority, os.PRIO_PROCESS, 0, before).result()
    except PermissionError:
        pass


def test_a_failed_background_build_keeps_the_coarse_table_and_is_not_queued_again(monkeypatch):
    """A full build that fails in the background is reported to a caller that waits for it, leaves the sampler
    on its coarse table (still exact), and is not tried again at every later refresh (a renderer's pass)."""
    from core.sampling.adaptive import sampler as module

    sampler = make_sampler("adaptive_exact", make_brdf("phong", {"n": 53.0}), progressive=True)
    sampler.preload()
    real = module.build_table

    def failing(brdf, options, *args, **kwargs):
        raise MemoryError("out of memory in the full build")

    monkeypatch.setattr(module, "build_table", failing)
    with pytest.raises(MemoryError, match="full build"):
        sampler.refresh(wait=True)
    monkeypatch.setattr(module, "build_table", real)
    assert not sampler.full_pending and not sampler.complete
    assert not sampler.refresh() and sampler.key not in module._BUILDING
    wo = np.repeat(_wo(40.0)[None, :], 500, axis=0)
    batch = sampler.sample_each(wo, seed=3)
    assert np.all(np.isfinite(batch.pdf)) and np.all(batch.pdf > 0)


def test_a_flat_lobes_bounds_do_not_depend_on_its_scale():
    """A Lambertian lobe meets its bounds at every probe to rounding: ties must not raise some leaves' bounds
    and not others (tree.PROBE_TIE), so the exact tables of kd = 0.5 and 0.25 are the same, every leaf
    bound alike."""
    from core.sampling.adaptive.inspect import leaf_probabilities

    a = make_sampler("adaptive_exact", make_brdf("lambert", {"kd": 0.5}), cache=False).table
    b = make_sampler("adaptive_exact", make_brdf("lambert", {"kd": 0.25}), cache=False).table
    np.testing.assert_array_equal(a.total, b.total)
    assert np.ptp(a.total) <= 1e-12 * a.total[0]
    for t in range(len(a.total)):
        np.testing.assert_array_equal(leaf_probabilities(a, t), leaf_probabilities(b, t))
