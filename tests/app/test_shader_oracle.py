"""The shader oracle (BRDF Explorer shaders run by Mesa's llvmpipe through headless EGL), the float32 agreement
our values are held to, and ``brdf-studio check-models``.

The oracle is checked against numpy values of inline shaders of our own; the command against our fixtures
(``tests/app/fixtures`` and ``core.glsl``'s ``tests/core/glsl/fixtures``).
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.commands.check_models import direction_pairs
from app.float32_agreement import (
    agreement_with_oracle,
    compare,
    float32_inputs,
    float32_propagation_bound,
    parameter_vector,
)
from app.shader_oracle import MesaShaderError, evaluate_glsl, shader_oracle

FIXTURES = Path(__file__).parent / "fixtures"
GLSL_FIXTURES = Path(__file__).parents[1] / "core" / "glsl" / "fixtures"
SIGNATURE = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)"


@pytest.fixture(scope="module")
def pairs() -> tuple[np.ndarray, np.ndarray]:
    """The command's grid of 5 polar angles (0 to 89 degrees) x 8 azimuths, every ordered pair."""
    return direction_pairs(5)


def _cos_r(L: np.ndarray, V: np.ndarray) -> np.ndarray:
    """R.V with R the mirror of L about N = z."""
    R = L * np.array([-1.0, -1.0, 1.0])
    return np.sum(R * V, axis=1)


LAMBERT = f"""
const float PI = 3.14159265358979323846;
{SIGNATURE} {{ return tinted ? albedo / PI : vec3(0.5); }}
"""
PHONG = f"""
vec3 reflect(vec3 I, vec3 N) {{ return 2.0 * dot(I, N) * N - I; }}
{SIGNATURE} {{
    float lobe = pow(max(0.0, dot(reflect(L, N), V)), n) * (n + 2.0) / (2.0 * 3.14159265358979);
    return vec3(lobe, lobe * 0.5, 1.0);
}}
"""
GAUSSIAN_THETA_H = f"""
{SIGNATURE} {{
    float t = acos(dot(N, normalize(L + V))) / width;
    return vec3(exp(-t * t), atan(L.y, L.x), asin(V.x));
}}
"""


def _lambert(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.tile(p[:3] / np.pi if p[3] else np.full(3, 0.5), (len(L), 1))


def _phong(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    lobe = np.maximum(0.0, _cos_r(L, V)) ** p[0] * (p[0] + 2.0) / (2.0 * np.pi)
    return np.stack([lobe, 0.5 * lobe, np.ones_like(lobe)], axis=1)


def _gaussian_theta_h(L: np.ndarray, V: np.ndarray, p: np.ndarray) -> np.ndarray:
    H = L + V
    cos_h = np.clip(H[:, 2] / np.linalg.norm(H, axis=1), -1.0, 1.0)
    t = np.arccos(cos_h) / p[0]
    return np.stack([np.exp(-t * t), np.arctan2(L[:, 1], L[:, 0]), np.arcsin(V[:, 0])], axis=1)


CASES = {
    "lambert, a colour and a bool": (
        LAMBERT,
        [("color", "albedo", (0.8, 0.5, 0.2)), ("bool", "tinted", True)],
        _lambert,
    ),
    "lambert, the bool off": (
        LAMBERT,
        [("color", "albedo", (0.8, 0.5, 0.2)), ("bool", "tinted", False)],
        _lambert,
    ),
    "phong, pow of 1000": (PHONG, [("float", "n", 1000.0)], _phong),
    "acos, atan(y, x), asin": (GAUSSIAN_THETA_H, [("float", "width", 0.1)], _gaussian_theta_h),
}


def test_the_oracle_runs_on_mesas_llvmpipe():
    assert "llvmpipe" in shader_oracle().renderer


@pytest.mark.parametrize("case", CASES)
def test_the_oracle_agrees_with_numpy(case, pairs):
    shader, params, reference = CASES[case]
    L, V = pairs
    agreement = agreement_with_oracle(reference, shader, params, L, V)
    assert agreement.passed, agreement
    assert agreement.nan_both == agreement.nan_by_rounding == 0


def test_without_mesas_egl_the_error_names_the_missing_package(monkeypatch):
    import ctypes.util

    import moderngl

    from app.shader_oracle import OracleUnavailableError, ShaderOracle

    def no_context(**kwargs):
        raise Exception("eglGetDisplay failed")

    real = ctypes.util.find_library
    monkeypatch.setattr(moderngl, "create_standalone_context", no_context)
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: None if name == "EGL_mesa" else real(name))
    with pytest.raises(
        OracleUnavailableError, match=r"libEGL_mesa\.so\.0 is missing \(Debian package libegl-mesa0\)"
    ):
        ShaderOracle()


def test_colour_and_bool_uniforms_reach_the_shader():
    L = np.array([[0.0, 0.0, 1.0]])
    params = [("color", "albedo", (0.8, 0.5, 0.2)), ("bool", "tinted", True)]
    np.testing.assert_allclose(
        evaluate_glsl(LAMBERT, params, L, L)[0], np.array([0.8, 0.5, 0.2]) / np.pi, rtol=1e-6
    )
    params[1] = ("bool", "tinted", False)
    np.testing.assert_array_equal(evaluate_glsl(LAMBERT, params, L, L)[0], np.float32(0.5))


def test_the_result_is_float32_in_input_order(rng):
    L = rng.normal(size=(5000, 3))
    V = rng.normal(size=(5000, 3))
    shader = f"{SIGNATURE} {{ return vec3(L.x, V.y, L.z * V.z); }}"
    out = evaluate_glsl(shader, [], L, V)
    assert out.dtype == np.float32 and out.shape == (5000, 3)
    L32, V32 = L.astype(np.float32), V.astype(np.float32)
    np.testing.assert_array_equal(out, np.stack([L32[:, 0], V32[:, 1], L32[:, 2] * V32[:, 2]], axis=1))


def test_inverse_trig_is_precise_to_a_few_ulps():
    x = np.linspace(-1.0, 1.0, 20001)
    L = np.stack([x, 8.0 * x, np.zeros_like(x)], axis=1)
    shader = f"{SIGNATURE} {{ return vec3(acos(L.x), asin(L.x), atan(L.y)); }}"
    out = evaluate_glsl(shader, [], L, L).astype(np.float64)
    x32 = float32_inputs(x)
    exact = np.stack([np.arccos(x32), np.arcsin(x32), np.arctan(float32_inputs(8.0 * x))], axis=1)
    ulps = np.abs(out - exact) / np.maximum(np.abs(exact), 2.0**-10) / 2.0**-24
    assert ulps.max() < 8.0


def test_a_file_may_redefine_built_ins_as_brdf_explorers_own_files_do():
    shader = f"""
    float smoothstep(float a, float b, float x) {{ return clamp((x - a) / (b - a), 0.0, 1.0); }}
    vec3 reflect(vec3 I, vec3 N) {{ return 2.0 * dot(I, N) * N - I; }}
    {SIGNATURE} {{ return vec3(smoothstep(0.0, 2.0, 1.0), reflect(L, N).xy); }}
    """
    L = np.array([[0.6, 0.0, 0.8]])
    np.testing.assert_allclose(evaluate_glsl(shader, [], L, L)[0], [0.5, -0.6, 0.0], atol=1e-7)


def test_a_syntax_error_is_a_domain_error_with_mesas_message_at_the_file_line():
    shader = f"{SIGNATURE}\n{{\n    return vec3(1.0)\n}}\n"  # the ';' missing on shader line 3
    L = np.array([[0.0, 0.0, 1.0]])
    with pytest.raises(MesaShaderError) as error:
        evaluate_glsl(shader, [], L, L, source_name="broken.brdf", first_line=20)
    assert "broken.brdf:23:" in str(error.value) and "syntax error" in error.value.log


def test_a_parameter_named_like_a_host_uniform_is_refused_as_in_brdf_explorer():
    shader = f"{SIGNATURE} {{ return vec3(colorMask); }}"
    L = np.array([[0.0, 0.0, 1.0]])
    with pytest.raises(MesaShaderError, match="header put before the shader.*colorMask"):
        evaluate_glsl(shader, [("float", "colorMask", 1.0)], L, L, source_name="mask.brdf")


def test_the_agreement_catches_a_value_off_by_1e_4(pairs):
    shader, params, reference = CASES["phong, pow of 1000"]
    L, V = pairs
    agreement = agreement_with_oracle(lambda a, b, p: reference(a, b, p) * (1.0 + 1e-4), shader, params, L, V)
    assert not agreement.passed and agreement.worst_ratio > 1.0


def test_nan_meets_nan_and_a_nan_on_one_side_fails(pairs):
    L, V = pairs
    shader = f"{SIGNATURE} {{ return vec3(sqrt(L.x), 1.0, 1.0); }}"  # NaN where L.x < 0

    def ours(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return np.stack([np.sqrt(a[:, 0]), np.ones(len(a)), np.ones(len(a))], axis=1)

    agreement = agreement_with_oracle(ours, shader, [], L, V)
    assert agreement.passed and agreement.nan_both > 0

    def nan_everywhere(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
        out = ours(a, b, p)
        out[:, 1] = np.nan
        return out

    agreement = agreement_with_oracle(nan_everywhere, shader, [], L, V)
    assert not agreement.passed and agreement.nan_ours_only == len(L)


def test_pairs_below_the_horizon_are_left_out():
    L = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, -0.8]])
    ours = np.array([[1.0, 1.0, 1.0], [5.0, 5.0, 5.0]])
    mesa = np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]], dtype=np.float32)
    agreement = compare(ours, mesa, np.zeros_like(ours), L, L)
    assert agreement.passed and agreement.values == 3


def test_the_rounding_bound_grows_with_the_exponent(pairs):
    L, V = (float32_inputs(w) for w in pairs)
    peaks = np.abs(_cos_r(L, V) - 1.0) < 1e-12
    widths = []
    for n in (10.0, 1000.0):
        p, real = parameter_vector([("float", "n", n)])
        bound = float32_propagation_bound(_phong, L, V, p, real)
        widths.append(np.max(bound[peaks, 0] / _phong(L, V, p)[peaks, 0]))
    assert widths[1] > 50 * widths[0]
    assert 1e-5 < widths[1] < 1e-2  # pow(1 - 2^-24 k, 1000): a few 1e-4, which Mesa's pow reaches


# --- brdf-studio check-models


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["check-models", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def _folder(tmp_path: Path, *files: Path) -> Path:
    folder = tmp_path / "models"
    folder.mkdir()
    for f in files:
        shutil.copy(f, folder / f.name)
    return folder


def test_check_models_passes_on_our_fixtures(tmp_path, capsys):
    """Every fixture opens and agrees with Mesa (the samplers' check is the next test's: it takes minutes
    for all of them)."""
    fixtures = sorted(FIXTURES.glob("*.brdf")) + sorted(GLSL_FIXTURES.glob("*.brdf"))
    code, out, err = _run(capsys, str(_folder(tmp_path, *fixtures)), "--grid", "4", "--samples", "0")
    assert code == 0, out + err
    assert "llvmpipe" in out
    for f in fixtures:
        row = next(line for line in out.splitlines() if line.startswith(f.name))
        assert row.split()[1] == "yes" and row.endswith("pass"), row
    assert f"{len(fixtures)} files: {len(fixtures)} pass, 0 fail" in out


def test_check_models_runs_the_adaptive_samplers_check_on_a_file(tmp_path, capsys):
    """Both adaptive samplers pass check's chi-square tests (alpha = 0.01, Sidak over the run's 20 tests),
    pdf integral, acceptance and leaf bounds on the principled fixture (anisotropic, three lobes)."""
    code, out, err = _run(
        capsys, str(_folder(tmp_path, GLSL_FIXTURES / "principled.brdf")), "--grid", "3", "--samples", "20000"
    )
    assert code == 0, out + err
    assert "Sidak-corrected over 20 tests" in out
    header = next(line for line in out.splitlines() if line.startswith("file"))
    row = next(line for line in out.splitlines() if line.startswith("principled.brdf"))
    assert header.split()[-2:] == ["samplers", "verdict"] and row.split()[-2:] == ["pass", "pass"], row


def test_check_models_reports_a_broken_file_and_exits_1(tmp_path, capsys):
    fixtures = list(FIXTURES.glob("*.brdf"))
    folder = _folder(tmp_path, *fixtures)
    (folder / "broken.brdf").write_text(
        f"analytic\n::begin parameters\n::end parameters\n::begin shader\n{SIGNATURE}\n{{\n"
        "    return vec3(1.0)\n}\n::end shader\n"
    )
    out_csv = tmp_path / "table.csv"
    code, out, err = _run(capsys, str(folder), "--grid", "3", "--samples", "0", "--csv", str(out_csv))
    assert code == 1 and err == ""
    lines = out.splitlines()
    row = next(i for i, line in enumerate(lines) if line.startswith("broken.brdf"))
    assert lines[row].split()[1] == "no" and lines[row].endswith("FAIL")
    assert "broken.brdf:8" in lines[row + 1]  # the message, at the file's line
    assert f"{len(fixtures) + 1} files: {len(fixtures)} pass, 1 FAIL" in out
    with out_csv.open() as fh:
        rows = {r["file"]: r for r in csv.DictReader(fh)}
    assert rows["broken.brdf"]["verdict"] == "FAIL" and rows["tinted_lambert.brdf"]["verdict"] == "pass"


def test_check_models_refuses_files_that_only_visualise(tmp_path, capsys):
    folder = _folder(tmp_path, FIXTURES / "tinted_lambert.brdf")
    (folder / "angles.brdf").write_text(
        "analytic\n::begin parameters\nbool show_thetaH 0\n::end parameters\n::begin shader\n"
        f"{SIGNATURE} {{ return vec3(show_thetaH ? acos(dot(N, normalize(L + V))) : 0.5); }}\n::end shader\n"
    )
    code, out, _ = _run(capsys, str(folder), "--grid", "3", "--samples", "0")
    assert code == 0
    assert next(line for line in out.splitlines() if line.startswith("angles.brdf")).endswith(
        "refused (visualisation only)"
    )
    assert "2 files: 1 pass, 0 fail, 1 refused (visualisation only)" in out


def test_check_models_without_the_folder_exits_2_with_one_line(tmp_path, capsys):
    code, out, err = _run(capsys, str(tmp_path / "nowhere"))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "no such folder" in err
