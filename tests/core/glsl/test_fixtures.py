"""The fixtures: every good one compiles and agrees with a numpy transcription of its formula written here,
on every pair of the shared direction grid; every bad one fails with the error its ``# error:`` line names."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from core.glsl import ShaderError, compile_brdf, read_brdf_file
from tests.core.glsl._shaders import BAD_FIXTURES, FIXTURES, GOOD_FIXTURES, grid_pairs

PI = 3.14159265358979323846


# ---- numpy spellings of the GLSL the fixtures use (GLSL's own definitions, evaluated in the same order)


def gpow(x: np.ndarray, y: float) -> np.ndarray:
    """GLSL's pow as GPUs compute it (and core.glsl does): NaN for a negative base (but for a constant
    exponent of 1, 2 or 4, which becomes multiplications)."""
    with np.errstate(invalid="ignore"):
        return np.where(x < 0.0, np.nan, np.abs(x) ** y)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def normalize(a: np.ndarray) -> np.ndarray:
    return a / np.sqrt(dot(a, a))[..., None]


def mix(x, y, a):
    return x * (1.0 - a) + y * a


def glsl_max(x, y):
    return np.where(x < y, y, x)


def glsl_min(x, y):
    return np.where(y < x, y, x)


def vec3(value: np.ndarray) -> np.ndarray:
    return np.repeat(np.asarray(value, dtype=float)[..., None], 3, axis=-1)


# ---- the references, one per fixture: f(L, V, p) with p the parameter vector


def principled(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Burley 2012 as BRDF Explorer writes it, baseColor linear."""
    base = p[0:3]
    (
        metallic,
        subsurface,
        specular,
        roughness,
        specular_tint,
        anisotropic,
        sheen,
        sheen_tint,
        clearcoat,
        gloss,
    ) = p[3:]
    n_l, n_v = L[:, 2], V[:, 2]
    H = normalize(L + V)
    n_h, l_h = H[:, 2], dot(L, H)

    luminance = 0.3 * base[0] + 0.6 * base[1] + 0.1 * base[2]
    tint = base / luminance if luminance > 0 else np.ones(3)
    specular_color = mix(specular * 0.08 * mix(np.ones(3), tint, specular_tint), base, metallic)
    sheen_color = mix(np.ones(3), tint, sheen_tint)

    def schlick(u):
        return np.clip(1.0 - u, 0.0, 1.0) ** 5

    f_l, f_v = schlick(n_l), schlick(n_v)
    fd90 = 0.5 + 2.0 * l_h * l_h * roughness
    fd = mix(1.0, fd90, f_l) * mix(1.0, fd90, f_v)
    fss90 = l_h * l_h * roughness
    fss = mix(1.0, fss90, f_l) * mix(1.0, fss90, f_v)
    ss = 1.25 * (fss * (1.0 / (n_l + n_v) - 0.5) + 0.5)

    aspect = np.sqrt(1.0 - 0.9 * anisotropic)
    ax = max(0.001, roughness**2 / aspect)
    ay = max(0.001, roughness**2 * aspect)
    d_s = 1.0 / (PI * ax * ay * ((H[:, 0] / ax) ** 2 + (H[:, 1] / ay) ** 2 + n_h**2) ** 2)
    f_h = schlick(l_h)
    f_s = mix(specular_color, np.ones(3), f_h[:, None])

    def smith_anisotropic(w):
        return 1.0 / (w[:, 2] + np.sqrt((w[:, 0] * ax) ** 2 + (w[:, 1] * ay) ** 2 + w[:, 2] ** 2))

    g_s = smith_anisotropic(L) * smith_anisotropic(V)
    f_sheen = (f_h * sheen)[:, None] * sheen_color

    alpha = mix(0.1, 0.001, gloss)
    a2 = alpha * alpha  # 1 + (a2 - 1) n_h n_h cancels near the peak: evaluated in the shader's order
    d_r = 1.0 / PI if alpha >= 1 else (a2 - 1) / (PI * np.log(a2) * (1 + (a2 - 1) * n_h * n_h))
    f_r = mix(0.04, 1.0, f_h)

    def smith(c, a):
        return 1.0 / (c + np.sqrt(a * a + c * c - a * a * c * c))

    g_r = smith(n_l, 0.25) * smith(n_v, 0.25)
    diffuse = (mix(fd, ss, subsurface) / PI)[:, None] * base + f_sheen
    value = (
        diffuse * (1 - metallic) + (g_s * d_s)[:, None] * f_s + (0.25 * clearcoat * g_r * f_r * d_r)[:, None]
    )
    value[(n_l < 0) | (n_v < 0)] = 0.0
    return value


def microfacet_toggles(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    kd, ks, alpha, ior, f0 = p[:5]
    tint = p[5:8]
    use_beckmann, use_blinn, exact_fresnel, use_smith, divide = (p[8:] != 0).tolist()
    n_l, n_v = L[:, 2], V[:, 2]
    H = normalize(L + V)
    n_h, v_h = H[:, 2], dot(V, H)
    if use_beckmann:
        t2, m2 = n_h * n_h, alpha * alpha
        d = np.exp((t2 - 1) / (m2 * t2)) / (PI * m2 * t2 * t2)
    elif use_blinn:
        e = 2 / alpha**2
        d = (e + 2) / (2 * PI) * glsl_max(0.0, n_h) ** (e - 2)
    else:
        a2 = alpha * alpha
        d = a2 / (PI * (n_h * n_h * (a2 - 1) + 1) ** 2)
    if exact_fresnel:
        c = v_h
        g = np.sqrt(ior * ior + c * c - 1)
        # pow(x, 2) with a constant 2 is x x, as GPU compilers make it: defined for a negative base
        f = 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1 + (c * (g + c) - 1) ** 2 / (c * (g - c) + 1) ** 2)
    else:
        f = f0 + (1 - f0) * gpow(1 - v_h, 5)
    if use_smith:

        def g1(c):
            return 2 / (1 + np.sqrt(1 + alpha * alpha * (1 - c * c) / (c * c)))

        g = g1(n_l) * g1(n_v)
    else:
        g = glsl_min(1.0, 2 * (n_h / v_h) * glsl_min(n_l, n_v))
    spec = d * f * g
    if divide:
        spec = spec * (1 / (4 * n_l * n_v))
    spec = np.where(n_h < 0, 0.0, spec)
    value = ks * spec[:, None] * tint + np.array([kd, 0, 0]) / PI
    value[(n_l < 0) | (n_v < 0)] = 0.0
    return value


def tangent_lobes(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    exponent, falloff = p[:2]
    orient, mirror, fade = (p[2:] != 0).tolist()
    axis = 0 if orient else 1  # T = X or Y
    cos_lt, cos_vt = L[:, axis], V[:, axis]
    sin_lt = np.sqrt(1 - cos_lt * cos_lt)
    value = np.abs(sin_lt * np.sqrt(1 - cos_vt * cos_vt) - cos_lt * cos_vt) ** exponent
    if mirror:  # the file's own reflect: 2 (I.N) N - I
        R = 2 * L[:, 2:3] * np.array([0.0, 0.0, 1.0]) - L
        value = glsl_max(0.0, dot(R, V)) ** exponent
    if fade:  # the file's own smoothstep(0, b, x), b >= 0
        b = falloff * 0.5 * PI
        x = 0.5 * PI - np.arccos(L[:, 2])
        if b > 0:
            t = (x - 0.0) / (b - 0.0)
            step = np.where(x < 0.0, 0.0, np.where(x >= b, 1.0, t * t * (3 - 2 * t)))
        else:
            step = np.where(x < 0.0, 0.0, 1.0)
        value = value * step
    return vec3(value)


def globals_and_shadowing(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    m, n, radius, scale_by_count = p

    def g(v):
        k = np.sqrt(2 * m * m / PI)
        return np.where(v > 0, v / (v - k * v + k), 0.0)

    shadowing = g(L[:, 2]) * g(V[:, 2])
    if scale_by_count:
        shadowing = shadowing * 2.0  # G() ran twice in this evaluation
    H = normalize(L + V)
    h = H - H[:, 2:3] * np.array([0.0, 0.0, 1.0])
    r, e = 2.0 * radius, n * 0.5
    lump = (e + 1) / (PI * r * r) * gpow(1 - dot(h, h) / (r * r), e)
    return np.stack([shadowing + lump, shadowing, shadowing], axis=1)


def vectors(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    albedo, gain = p[:3], p[3]
    H = normalize(L + V)
    lv = np.stack([L[:, 2], V[:, 2]], axis=1)
    c = H.copy()
    c[:, [0, 1]] = c[:, [1, 0]]
    c[:, 2] += lv[:, 0] * lv[:, 1]
    w = np.concatenate([lv, np.sqrt(dot2(lv))[:, None]], axis=1) / 2 + 0.5
    total = np.cos(w[:, 0]) * 1.0 + np.cos(w[:, 1]) * 2.0 + np.cos(w[:, 2]) * 3.0
    reflected = -L - 2 * (-L[:, 2:3]) * np.array([0.0, 0.0, 1.0])
    k = np.cross(L, V) + reflected * np.sqrt(dot(L - V, L - V))[:, None]
    k[:, 2] = -k[:, 2]
    color = (albedo**2.2)[::-1] * gain
    mixed = mix(color, c[:, ::-1], 0.25)
    return (
        mixed * total[:, None]
        + np.stack([k[:, 0], k[:, 1] * 0.5, k[:, 2] * 0.5], axis=1)
        + np.abs(c - w) * 0.125
    )


def dot2(a: np.ndarray) -> np.ndarray:
    return a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1]


def control_flow(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    terms, threshold, early = p
    n_l, n_v = L[:, 2], V[:, 2]
    term, series = np.ones_like(n_l), np.zeros_like(n_l)
    for i in range(int(terms)):
        series = series + term
        term = term * (n_l / float(i + 1))
    counter = 2.0 if early else 0.0  # bump() runs in `early && ...` and in `!early || ...` only when early
    counts = counter + (100.0 if early else 0.0) + 10.0 + np.where((n_l > 0.5) != (n_v > 0.5), 1000.0, 0.0)
    middle = 25.0 + 31.0 + (-3.0) / 100.0 + 1.0 + counts
    above = V > threshold
    first = np.where(above.any(axis=1), np.argmax(above, axis=1), -1).astype(float)
    ratio = np.where(n_v > 0.0, n_l / n_v, n_l / 0.0)
    return np.stack([series, middle, first + ratio], axis=1)


def oren_nayar(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    rho, sigma = p
    N = np.array([0.0, 0.0, 1.0])
    cos_i, cos_o = L[:, 2], V[:, 2]
    theta_i, theta_o = np.arccos(cos_i), np.arccos(cos_o)
    alpha, beta = glsl_max(theta_i, theta_o), glsl_min(theta_i, theta_o)
    s2 = (sigma * (PI / 180.0)) ** 2
    a = 1 - 0.5 * s2 / (s2 + 0.33)
    b = 0.45 * s2 / (s2 + 0.09)
    cos_phi = dot(normalize(V - N * cos_o[:, None]), normalize(L - N * cos_i[:, None]))
    value = rho / PI * (a + b * glsl_max(0.0, cos_phi) * np.sin(alpha) * np.tan(beta))
    return vec3(np.where(alpha > PI / 2, 0.0, value))


# fixture -> its reference and the parameter vectors to try (None: the file's defaults)
REFERENCES: dict[str, tuple[Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray], list]] = {
    "principled": (
        principled,
        [
            None,
            [0.3, 0.6, 0.9, 0.7, 0.4, 0.8, 0.15, 0.6, 0.9, 0.5, 0.25, 0.8, 0.3],
            [0.1, 0.2, 0.05, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0],
            [0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 0.5, 0.0],
        ],
    ),
    "microfacet_toggles": (
        microfacet_toggles,
        [
            None,
            [0.2, 0.7, 0.3, 1.8, 0.1, 1.0, 0.5, 0.25, 1, 0, 1, 0, 1],
            [0.0, 1.0, 0.6, 1.2, 0.5, 0.3, 0.3, 0.3, 0, 1, 0, 1, 0],
        ],
    ),
    "tangent_lobes": (tangent_lobes, [None, [5.0, 0.2, 1, 1, 1], [50.0, 0.0, 1, 0, 1], [2.0, 0.1, 0, 0, 0]]),
    "globals_and_shadowing": (globals_and_shadowing, [None, [0.2, 3.0, 0.8, 1], [1.0, 0.0, 0.5, 0]]),
    "vectors": (vectors, [None, [0.9, 0.1, 0.4, 0.5]]),
    "control_flow": (control_flow, [None, [3.0, 0.9, 1], [20.0, 0.0, 0]]),
    "oren_nayar": (oren_nayar, [None, [0.5, 0.0], [1.0, 90.0]]),
}


def test_every_good_fixture_has_a_reference():
    assert sorted(REFERENCES) == sorted(path.stem for path in GOOD_FIXTURES)


@pytest.fixture(scope="module")
def compiled():
    """Each good fixture compiled once for this module."""
    return {path.stem: compile_brdf(read_brdf_file(path)) for path in GOOD_FIXTURES}


CASES = [(name, index) for name, (_, settings) in REFERENCES.items() for index in range(len(settings))]


@pytest.mark.parametrize(("name", "setting"), CASES, ids=[f"{n}-{i}" for n, i in CASES])
def test_fixture_matches_its_numpy_reference(compiled, name, setting):
    brdf = compiled[name]
    reference, settings = REFERENCES[name]
    params = (
        brdf.source.default_parameters() if settings[setting] is None else np.array(settings[setting], float)
    )
    wi, wo = grid_pairs()
    got = brdf.evaluate(wi, wo, params)
    with np.errstate(all="ignore"):
        expected = reference(wi, wo, params)
    assert got.shape == expected.shape == (len(wi), 3)
    assert np.isfinite(expected).mean() > 0.75  # about numbers, not NaN (90 degrees may give inf or NaN)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-300, equal_nan=True)


def test_principled_defaults_and_horizon(compiled):
    """principled.brdf declares Burley's parameters with BRDF Explorer's ranges and defaults (baseColor
    linear .82 .67 .16), and is zero below the horizon."""
    brdf = compiled["principled"]
    params = {p.name: (p.kind, p.lo, p.hi, p.default) for p in brdf.source.params}
    assert list(params) == [
        "baseColor", "metallic", "subsurface", "specular", "roughness", "specularTint", "anisotropic",
        "sheen", "sheenTint", "clearcoat", "clearcoatGloss",
    ]  # fmt: skip
    assert params["baseColor"] == ("color", 0.0, 1.0, (0.82, 0.67, 0.16))
    assert params["specular"] == ("float", 0.0, 1.0, 0.5)
    assert params["roughness"] == ("float", 0.0, 1.0, 0.5)
    assert params["sheenTint"] == ("float", 0.0, 1.0, 0.5)
    assert params["clearcoatGloss"] == ("float", 0.0, 1.0, 1.0)
    assert brdf.uses_tangents
    below = np.array([[0.0, 0.6, -0.8]])
    above = np.array([[0.0, 0.0, 1.0]])
    assert np.all(brdf.evaluate(below, above) == 0.0)
    assert np.all(brdf.evaluate(above, below) == 0.0)


def _expected_error(path: Path) -> tuple[int, str]:
    match = re.search(r"^# error: (\d+): (.+)$", path.read_text(), flags=re.MULTILINE)
    assert match, f"{path.name} has no '# error: LINE: message' line"
    return int(match.group(1)), match.group(2)


@pytest.mark.parametrize("path", BAD_FIXTURES, ids=[p.stem for p in BAD_FIXTURES])
def test_bad_fixture_reports_line_and_message(path):
    line, message = _expected_error(path)
    with pytest.raises(ShaderError) as caught:
        compile_brdf(read_brdf_file(path))
    error = caught.value
    assert (error.path, error.line) == (str(path), line)
    assert message in error.message
    assert str(error).startswith(f"{path}:{line}:{error.column}: ")
    assert "\n" not in str(error)


def test_fixture_folder_is_ours():
    """The fixtures are written for these tests: none carries Disney's license text."""
    for path in FIXTURES.rglob("*.brdf"):
        assert "Disney Enterprises" not in path.read_text()
