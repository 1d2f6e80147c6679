"""Disney's principled BRDF (Burley 2012): reference values from Burley's formulas written here in numpy
(angles of the half vector, Heitz's Lambda form of Smith's masking), the hard cases (roughness 0 and 1,
anisotropic 1, 89.99 and 90 degrees, black base colour), the traits, and the three-lobe analytic sampler
(chi-square at significance 0.01 with 1e6 samples per case: one case per setting and per angle in the
default run, the full settings x angles sweep with ``-m slow``). The comparison with the translation of a
``.brdf`` shader of the same model is the last test."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir, spherical_to_dir
from core.models import disney
from core.sampling import make_sampler
from core.sampling.adaptive.layout import ISOTROPIC, MIRROR
from core.sampling.adaptive.survey import symmetry_of
from tests.conftest import all_pairs, direction_grid
from tests.core.models._checks import (
    albedo_estimate,
    assert_albedo_estimate_matches,
    assert_pdf_integrates_to_one,
    assert_sample_matches_pdf,
    assert_sampler_exact,
    hard_case_grid_is_finite,
    sampler_sweep,
)

DISNEY = get_model("disney")
FIXTURE = Path(__file__).resolve().parents[1] / "glsl" / "fixtures" / "principled.brdf"

# ----------------------------------------------------------------------------------------------------------
# Reference
# ----------------------------------------------------------------------------------------------------------


def _lerp(a, b, t):
    return a * (1.0 - t) + b * t


def _smith_g1(v: np.ndarray, ax: float, ay: float) -> np.ndarray:
    """Heitz 2014 (JCGT 3(2)), eqs. 72 and 86: ``G1 = 1 / (1 + Lambda)``, ``Lambda = (-1 + sqrt(1 + a_v^2
    tan^2(theta_v))) / 2`` with the roughness in the azimuth of ``v``, ``a_v^2 = ax^2 cos^2(phi_v) + ay^2
    sin^2(phi_v)``."""
    phi = np.arctan2(v[:, 1], v[:, 0])
    tan2 = (v[:, 0] ** 2 + v[:, 1] ** 2) / v[:, 2] ** 2
    a2 = ax**2 * np.cos(phi) ** 2 + ay**2 * np.sin(phi) ** 2
    return 1.0 / (1.0 + 0.5 * (-1.0 + np.sqrt(1.0 + a2 * tan2)))


def burley_reference(wi: np.ndarray, wo: np.ndarray, values: dict) -> np.ndarray:
    """``f_r (n, 3)`` for pairs above the horizon, from Burley 2012 (sec. 5 and the appendix: the diffuse
    with ``F_D90``, the subsurface flattening, GTR2 anisotropic with ``aspect``, GTR1 for the clearcoat,
    Schlick's Fresnel, the sheen) with BRDF Explorer's constants, ``baseColor`` taken as linear RGB. The
    distributions are written in ``theta_h``, ``phi_h`` as in the notes."""
    v = DISNEY.resolve(values)
    base = np.array(v["baseColor"])
    metallic, roughness = v["metallic"], v["roughness"]
    cos_i, cos_o = wi[:, 2], wo[:, 2]
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    sin2_h = h[:, 0] ** 2 + h[:, 1] ** 2  # sin^2(theta_h), without cancellation near h = n
    cos2_h = h[:, 2] ** 2
    phi_h = np.arctan2(h[:, 1], h[:, 0])
    cos_d = np.sum(wi * h, axis=1)

    lum = 0.3 * base[0] + 0.6 * base[1] + 0.1 * base[2]
    tint = base / lum if lum > 0.0 else np.ones(3)
    spec0 = _lerp(v["specular"] * 0.08 * _lerp(np.ones(3), tint, v["specularTint"]), base, metallic)
    sheen_color = _lerp(np.ones(3), tint, v["sheenTint"])

    def schlick(c):
        return np.clip(1.0 - c, 0.0, 1.0) ** 5

    f_i, f_o, f_h = schlick(cos_i), schlick(cos_o), schlick(cos_d)
    fd90 = 0.5 + 2.0 * cos_d**2 * roughness
    fd = _lerp(1.0, fd90, f_i) * _lerp(1.0, fd90, f_o)
    fss90 = cos_d**2 * roughness
    fss = _lerp(1.0, fss90, f_i) * _lerp(1.0, fss90, f_o)
    ss = 1.25 * (fss * (1.0 / (cos_i + cos_o) - 0.5) + 0.5)

    aspect = math.sqrt(1.0 - 0.9 * v["anisotropic"])
    ax = max(0.001, roughness**2 / aspect)
    ay = max(0.001, roughness**2 * aspect)
    ellipse = sin2_h * (np.cos(phi_h) ** 2 / ax**2 + np.sin(phi_h) ** 2 / ay**2)
    d_s = 1.0 / (math.pi * ax * ay * (ellipse + cos2_h) ** 2)
    g_s = _smith_g1(wi, ax, ay) * _smith_g1(wo, ax, ay)
    f_s = _lerp(spec0[None, :], 1.0, f_h[:, None])
    specular = f_s * (d_s * g_s / (4.0 * cos_i * cos_o))[:, None]

    a = _lerp(0.1, 0.001, v["clearcoatGloss"])
    d_c = (a * a - 1.0) / (math.pi * math.log(a * a) * (a * a * cos2_h + sin2_h))
    g_c = _smith_g1(wi, 0.25, 0.25) * _smith_g1(wo, 0.25, 0.25)
    coat = 0.25 * v["clearcoat"] * _lerp(0.04, 1.0, f_h) * d_c * g_c / (4.0 * cos_i * cos_o)

    diffuse = _lerp(fd, ss, v["subsurface"])[:, None] * base[None, :] / math.pi
    sheen = (f_h * v["sheen"])[:, None] * sheen_color[None, :]
    return (diffuse + sheen) * (1.0 - metallic) + specular + coat[:, None]


# Settings: the defaults, every parameter away from its default, and the corners.
SETTINGS = [
    {},
    {
        "baseColor": (0.9, 0.2, 0.05),
        "metallic": 0.3,
        "subsurface": 0.6,
        "specular": 0.8,
        "roughness": 0.35,
        "specularTint": 0.7,
        "anisotropic": 0.8,
        "sheen": 0.9,
        "sheenTint": 0.3,
        "clearcoat": 0.7,
        "clearcoatGloss": 0.4,
    },
    {"roughness": 0.0, "clearcoat": 1.0},
    {"roughness": 1.0, "anisotropic": 1.0, "subsurface": 1.0, "sheen": 1.0},
    {"baseColor": (0.95, 0.64, 0.54), "metallic": 1.0, "roughness": 0.2, "anisotropic": 0.5},
    {"baseColor": (0.0, 0.0, 0.0), "sheen": 1.0, "clearcoat": 1.0, "clearcoatGloss": 0.0},
]
SETTING_IDS = ["defaults", "all", "smooth-coat", "rough-aniso", "metal", "black"]
GRID_THETAS = (0.0, 0.5, 5.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.9, 89.99)
GRID_PHIS = (0.0, 37.0, 90.0, 135.0, 180.0, 222.0, 270.0, 333.0)


def _grid_pairs() -> tuple[np.ndarray, np.ndarray]:
    """Every ordered pair ``(wo, wi)`` of directions over the polar angles above (grazing included, 90
    excluded: the reference divides by the cosines there), plus 2000 random pairs."""
    t, p = np.meshgrid(np.radians(GRID_THETAS), np.radians(GRID_PHIS), indexing="ij")
    wo, wi = all_pairs(spherical_to_dir(t.ravel(), p.ravel()))
    rng = np.random.default_rng(5)
    random = spherical_to_dir(np.arccos(rng.random((2, 2000))), rng.uniform(0.0, 2.0 * math.pi, (2, 2000)))
    return np.concatenate([wo, random[0]]), np.concatenate([wi, random[1]])


# ----------------------------------------------------------------------------------------------------------
# Declaration and values
# ----------------------------------------------------------------------------------------------------------


def test_declaration_follows_brdf_explorer():
    names = [p.name for p in DISNEY.params]
    assert names == [
        "baseColor",
        "metallic",
        "subsurface",
        "specular",
        "roughness",
        "specularTint",
        "anisotropic",
        "sheen",
        "sheenTint",
        "clearcoat",
        "clearcoatGloss",
    ]
    assert DISNEY.defaults() == {
        "baseColor": (0.82, 0.67, 0.16),
        "metallic": 0.0,
        "subsurface": 0.0,
        "specular": 0.5,
        "roughness": 0.5,
        "specularTint": 0.0,
        "anisotropic": 0.0,
        "sheen": 0.0,
        "sheenTint": 0.5,
        "clearcoat": 0.0,
        "clearcoatGloss": 1.0,
    }
    assert all((p.lo, p.hi) == (0.0, 1.0) for p in DISNEY.params)
    assert DISNEY.label == "Disney principled (Burley 2012)" and "Burley" in DISNEY.citation
    assert len(DISNEY.kernel_params()) == disney.KERNEL_SIZE
    # the slot constants name the user vector in declaration order
    assert [disney.METALLIC, disney.CLEARCOAT_GLOSS, disney.DIFFUSE_COLOR] == [3, 12, 13]


def test_traits():
    assert DISNEY.reciprocal and DISNEY.mirror_symmetric
    assert not DISNEY.isotropic and not DISNEY.energy_conserving


def test_normal_incidence_defaults_in_closed_form():
    # wi = wo = n: h = n, c_d = 1, every Schlick weight 0: F_d = 1, D_s = 1 / (pi ax ay) with ax = ay = 0.25,
    # G1 = 1: f = baseColor / pi + C_spec0 / (4 pi 0.0625), C_spec0 = 0.08 * 0.5.
    n = np.array([0.0, 0.0, 1.0])
    expected = np.array([0.82, 0.67, 0.16]) / math.pi + 0.04 / (4.0 * math.pi * 0.0625)
    np.testing.assert_allclose(DISNEY.bind().eval(n, n)[0], expected, rtol=1e-14)


@pytest.mark.parametrize("values", SETTINGS, ids=SETTING_IDS)
def test_matches_burley_reference(values):
    wo, wi = _grid_pairs()
    got = DISNEY.bind(values).eval(wo, wi)
    np.testing.assert_allclose(got, burley_reference(wi, wo, values), rtol=1e-12, atol=0.0)


def test_base_color_is_linear():
    # Without the tints (specularTint = sheen = 0) the base colour enters linearly: no 2.2 power.
    wo, wi = _grid_pairs()
    f = [DISNEY.bind(baseColor=c, subsurface=0.3).eval(wo, wi) for c in (0.0, 0.5, 1.0)]
    np.testing.assert_allclose(f[1] - f[0], 0.5 * (f[2] - f[0]), rtol=1e-9, atol=1e-12)


def test_zero_at_and_below_the_horizon():
    w = direction_grid()
    rim = w[w[:, 2] == 0.0]
    below = w * np.array([1.0, 1.0, -1.0])
    below = below[below[:, 2] < 0.0]
    for values in SETTINGS:
        brdf = DISNEY.bind(values)
        for edge in (rim, below):
            wo, wi = np.repeat(edge, len(w), axis=0), np.tile(w, (len(edge), 1))
            assert np.all(brdf.eval(wo, wi) == 0.0) and np.all(brdf.eval(wi, wo) == 0.0)


@pytest.mark.parametrize("values", SETTINGS, ids=SETTING_IDS)
def test_reciprocal_and_mirror_symmetric(values):
    wo, wi = _grid_pairs()
    brdf = DISNEY.bind(values)
    f = brdf.eval(wo, wi)
    np.testing.assert_allclose(brdf.eval(wi, wo), f, rtol=1e-12, atol=0.0)
    for sign in ((-1.0, 1.0, 1.0), (1.0, -1.0, 1.0)):
        np.testing.assert_allclose(brdf.eval(wo * sign, wi * sign), f, rtol=1e-12, atol=0.0)


def test_isotropic_exactly_when_anisotropic_is_zero():
    # The adaptive sampler measures it (trees over theta only) rather than reading a trait.
    assert symmetry_of(DISNEY.bind(anisotropic=0.0, roughness=0.3)) == ISOTROPIC
    assert symmetry_of(DISNEY.bind(anisotropic=0.8, roughness=0.3)) == MIRROR
    # anisotropic > 0 widens the lobe along x: a half vector tilted 20 degrees towards x sees a larger D than
    # the same pair turned a quarter (tilted towards y)
    wo, wi = degrees_to_dir(10.0, 180.0), degrees_to_dir(50.0, 0.0)
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    brdf = DISNEY.bind(anisotropic=0.8, roughness=0.3, metallic=1.0)
    assert brdf.eval(wo, wi)[0, 0] > 2.0 * brdf.eval(rot @ wo, rot @ wi)[0, 0]


HARD = [
    {"roughness": 0.0},
    {"roughness": 0.0, "anisotropic": 1.0, "clearcoat": 1.0},
    {"roughness": 1.0, "anisotropic": 1.0, "subsurface": 1.0, "sheen": 1.0, "clearcoat": 1.0},
    {"baseColor": (0.0, 0.0, 0.0), "specular": 0.0, "metallic": 1.0},
    {"baseColor": (0.0, 0.0, 0.0), "specular": 0.0, "sheen": 1.0, "specularTint": 1.0, "sheenTint": 1.0},
    {
        "baseColor": (1.0, 1.0, 1.0),
        "metallic": 1.0,
        "roughness": 0.0,
        "clearcoat": 1.0,
        "clearcoatGloss": 0.0,
    },
]


@pytest.mark.parametrize("values", HARD, ids=[f"hard{i}" for i in range(len(HARD))])
def test_hard_cases_finite_and_non_negative(values):
    brdf = DISNEY.bind(values)
    hard_case_grid_is_finite(brdf)
    grazing = np.stack([degrees_to_dir(89.99, phi) for phi in (0.0, 90.0, 180.0, 250.0)])
    wo, wi = all_pairs(np.concatenate([grazing, direction_grid()]))
    f = brdf.eval(wo, wi)
    assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    assert_sample_matches_pdf(brdf, thetas=(0.0, 45.0, 89.99, 90.0), n=5000)


# ----------------------------------------------------------------------------------------------------------
# Sampler
# ----------------------------------------------------------------------------------------------------------


def _probabilities(values: dict) -> tuple[float, float, float]:
    """(specular, clearcoat, cosine) probabilities of the mixture."""
    p = DISNEY.kernel_params(values)
    spec, spec_or_coat = p[disney.P_SPECULAR], p[disney.P_SPECULAR_OR_COAT]
    return spec, spec_or_coat - spec, 1.0 - spec_or_coat


def test_mixture_probabilities_follow_the_albedo_estimates():
    y = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]  # noqa: E731
    spec, coat, cosine = _probabilities({})
    w_spec = 0.04 + 0.96 / 21.0  # C_spec0 = 0.04 grey
    w_cosine = y((0.82, 0.67, 0.16))
    assert coat == 0.0
    assert spec == pytest.approx(w_spec / (w_spec + w_cosine), rel=1e-12)
    assert cosine == pytest.approx(w_cosine / (w_spec + w_cosine), rel=1e-12)
    spec, coat, cosine = _probabilities({"clearcoat": 1.0})
    w_coat = 0.25 * (0.04 + 0.96 / 21.0)
    assert coat == pytest.approx(w_coat / (w_spec + w_coat + w_cosine), rel=1e-12)
    assert _probabilities({"metallic": 1.0}) == (1.0, 0.0, 0.0)  # no cosine lobe: none drawn
    spec, coat, cosine = _probabilities({"baseColor": 0.0, "sheen": 1.0})  # the sheen alone is diffuse-like
    assert cosine > 0.0 and spec + coat + cosine == pytest.approx(1.0, abs=1e-15)


def test_specular_only_weight_is_the_masking_of_wi():
    # metallic = 1 with a white base: F = 1 and only the visible normals are drawn, so f cos / pdf = G1(wi)
    # (D and G1(wo) cancel). Checked against Heitz's Lambda form of G1.
    values = {"baseColor": 1.0, "metallic": 1.0, "roughness": 0.6, "anisotropic": 0.8}
    brdf = DISNEY.bind(values)
    sampler = make_sampler("analytic", brdf)
    wo = degrees_to_dir(70.0, 30.0)
    drawn = sampler.sample(wo, 2000, 11)
    up = drawn.wi[:, 2] > 0.0
    weights = drawn.f[up, 0] * drawn.wi[up, 2] / drawn.pdf[up]
    ax, ay = 0.36 / math.sqrt(1.0 - 0.72), 0.36 * math.sqrt(1.0 - 0.72)
    np.testing.assert_allclose(weights, _smith_g1(drawn.wi[up], ax, ay), rtol=1e-9)


PDF_SETTINGS = [
    {"anisotropic": 0.8, "roughness": 0.3, "clearcoat": 1.0, "clearcoatGloss": 0.5, "sheen": 1.0},
    # roughness 0.5 at most with anisotropic 1 (ax = 0.79): rougher lobes put much of their mass below the
    # horizon, up to a jump of the density on the circle wi.z = -wo.z that the quadrature in theta does not
    # resolve to 1e-3 (the chi-square test's self-refining cell integrals do: the last sampler setting)
    {"baseColor": (0.95, 0.64, 0.54), "metallic": 1.0, "roughness": 0.5, "anisotropic": 1.0},
]


@pytest.mark.parametrize("values", PDF_SETTINGS, ids=["aniso-coat", "metal"])
def test_pdf_integrates_to_one_and_albedo_matches(values):
    brdf = DISNEY.bind(values)
    assert_sample_matches_pdf(brdf)
    assert_pdf_integrates_to_one(brdf, thetas=(0.0, 60.0, 85.0))
    assert_albedo_estimate_matches(brdf, thetas=(30.0, 85.0))


def test_metal_albedo_at_most_one():
    # The white furnace for the specular lobe alone (F = 1): single scattering loses energy, never gains it.
    for roughness in (0.05, 0.5, 1.0):
        for anisotropic in (0.0, 0.9):
            brdf = DISNEY.bind(baseColor=1.0, metallic=1.0, roughness=roughness, anisotropic=anisotropic)
            for theta in (0.0, 60.0, 89.0):
                albedo, err = albedo_estimate(brdf, degrees_to_dir(theta, 30.0), n=50_000)
                assert np.all(albedo <= 1.0 + 4.0 * err), (roughness, anisotropic, theta, albedo, err)


def test_retro_reflection_exceeds_albedo_one_so_no_energy_claim():
    # Why DISNEY does not declare ENERGY_CONSERVING: a white, rough dielectric with a clearcoat reflects more
    # than it receives at grazing incidence (F_D90 = 2.5 at c_d = 1; 4 standard errors of margin).
    brdf = DISNEY.bind(baseColor=1.0, roughness=1.0, clearcoat=1.0, sheen=1.0)
    albedo, err = albedo_estimate(brdf, degrees_to_dir(80.0, 0.0))
    assert np.all(albedo - 4.0 * err > 1.0), (albedo, err)


SAMPLER_SETTINGS = [
    {},
    {"anisotropic": 0.8, "roughness": 0.3, "metallic": 0.5},
    {"clearcoat": 1.0, "roughness": 0.6},
    {
        "anisotropic": 0.8,
        "clearcoat": 1.0,
        "clearcoatGloss": 0.5,
        "roughness": 0.15,
        "metallic": 1.0,
        "baseColor": (0.95, 0.64, 0.54),
    },
    {"roughness": 1.0, "anisotropic": 1.0, "metallic": 1.0},  # ax = 3.2: half the draws below the horizon
]


@pytest.mark.parametrize(
    ("values", "theta"),
    sampler_sweep(
        SAMPLER_SETTINGS, [0.0, 50.0, 85.0], fast={(0, 50.0), (1, 85.0), (2, 0.0), (3, 50.0), (4, 85.0)}
    ),
)
def test_sampler_is_exact(values, theta):
    # At normal incidence the clearcoat's peak (a = 0.001: a third of its mass within 0.6 degrees of the
    # pole) needs the cell integrals' nodes even in theta.
    assert_sampler_exact(DISNEY.bind(values), theta, variable="theta" if theta == 0.0 else "cos")


def test_sampler_below_the_horizon_falls_back_to_the_cosine_hemisphere():
    sampler = make_sampler("analytic", DISNEY.bind(clearcoat=1.0))
    wo = np.array([0.6, 0.0, -0.8])
    drawn = sampler.sample(wo, 1000, 2)
    assert np.all(drawn.wi[:, 2] >= 0.0)
    np.testing.assert_allclose(drawn.pdf, drawn.wi[:, 2] / math.pi, rtol=1e-12)
    np.testing.assert_allclose(drawn.pdf, sampler.pdf(wo, drawn.wi), rtol=1e-12)


# ----------------------------------------------------------------------------------------------------------
# The same model as a translated .brdf shader
# ----------------------------------------------------------------------------------------------------------


def test_disney_matches_principled_fixture():
    """The built-in model against the translation (``core.glsl``) of ``tests/core/glsl/fixtures/
    principled.brdf``, a shader of the same model with ``baseColor`` linear (1e-9 relative, above the
    horizon: the shader divides by the cosines at 90 degrees)."""
    if importlib.util.find_spec("core.glsl") is None:
        pytest.skip("core.glsl (the .brdf shader translator) is not in the tree yet")
    if not FIXTURE.exists():
        pytest.skip(f"the fixture {FIXTURE.name} is not in the tree yet")
    from core.glsl import compile_brdf, read_brdf_file

    shader = read_brdf_file(FIXTURE)
    assert [p.name for p in shader.params] == [p.name for p in DISNEY.params]
    assert shader.default_parameters().tolist() == DISNEY.user_vector(DISNEY.defaults()).tolist()
    compiled = compile_brdf(shader)
    wo, wi = _grid_pairs()
    for values in SETTINGS:
        p = DISNEY.user_vector(DISNEY.resolve(values))  # the file's layout: its declaration order
        expected = DISNEY.bind(values).eval(wo, wi)
        got = np.asarray(compiled.evaluate(wi, wo, p))
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=0.0, err_msg=str(values))
