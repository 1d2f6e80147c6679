"""A model file goes wherever a model name goes on the command line (issue 37, parts 3 and 7).

Every command that takes ``--model`` is run on a ``.brdf`` shader (``tests/app/fixtures/cli_plastic.brdf``:
one float, one color, one bool parameter) or on the example Python model
(``resources/models/blinn_phong.py``), in-process through ``app.cli.main`` as the console script runs it.
Then the files that do not load, or values that do not fit: exit code 2 and one line naming the file and the
line at fault; and a shader whose values are not a BRDF's, which loads with one ``notice:`` line per kind.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.brdf import make_brdf
from core.geometry import degrees_to_dir

ROOT = Path(__file__).resolve().parents[2]
SHADER = ROOT / "tests" / "app" / "fixtures" / "cli_plastic.brdf"
PYTHON = ROOT / "resources" / "models" / "blinn_phong.py"
MEASURED = ROOT / "resources" / "materials" / "red_plastic_ct.binary"


def run_cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def plastic(wi: np.ndarray, wo: np.ndarray, diffuse, shininess: float, highlight: bool) -> np.ndarray:
    """The fixture's formula (its header comment)."""
    h = (wi + wo) / np.linalg.norm(wi + wo)
    lobe = (shininess + 8.0) / (8.0 * math.pi) * max(h[2], 0.0) ** shininess
    return np.asarray(diffuse) / math.pi + (0.04 * lobe if highlight else 0.0)


# ----------------------------------------------------------------------------------------- every command


def test_eval_takes_the_shaders_own_parameters(capsys):
    argv = ["eval", "--model", SHADER, "--wi", "30,0", "--wo", "40,170"]
    code, out, err = run_cli(capsys, *argv, "--param", "diffuse=0.1,0.2,0.3", "shininess=20", "highlight=1")
    assert code == 0 and err == ""
    expected = plastic(degrees_to_dir(30, 0), degrees_to_dir(40, 170), (0.1, 0.2, 0.3), 20.0, True)
    np.testing.assert_allclose([float(x) for x in out.split()], expected, rtol=1e-8)
    code, out, _ = run_cli(capsys, *argv, "--param", "highlight=0")  # a bool takes 0 or 1
    np.testing.assert_allclose(
        [float(x) for x in out.split()], np.array([0.5, 0.3, 0.2]) / math.pi, rtol=1e-8
    )


def test_eval_of_a_python_file_relative_to_the_working_directory(capsys, monkeypatch):
    monkeypatch.chdir(PYTHON.parent)
    code, out, _ = run_cli(
        capsys, "eval", "--model", PYTHON.name, "--param", "n=25", "--wi", "20,10", "--wo", "50,200", "--json"
    )
    assert code == 0
    data = json.loads(out)
    expected = make_brdf(str(PYTHON), {"n": 25}).eval(degrees_to_dir(50, 200), degrees_to_dir(20, 10))[0]
    np.testing.assert_allclose(data["f_r"], expected, rtol=1e-12)
    assert data["brdf"].startswith(str(PYTHON) + "@")  # the key names the file and its content


def test_albedo_of_a_shader(capsys):
    """Without its highlight the fixture is Lambertian: albedo = diffuse at every angle."""
    code, out, _ = run_cli(
        capsys, "albedo", "--model", SHADER, "--param", "highlight=0", "diffuse=0.2,0.4,0.6", "--json"
    )
    assert code == 0
    rows = json.loads(out)["albedo"]
    assert len(rows) == 4
    for row in rows:
        np.testing.assert_allclose(row["value"], [0.2, 0.4, 0.6], rtol=1e-6)


@pytest.mark.parametrize(("model", "sampler"), [(PYTHON, "analytic"), (SHADER, "adaptive_warp")])
def test_sample_from_a_model_file(capsys, tmp_path, model, sampler):
    out_file = tmp_path / "draws.npy"
    code, out, _ = run_cli(
        capsys,
        "sample",
        "--model",
        model,
        "--sampler",
        sampler,
        "--theta",
        "35",
        "-n",
        "2000",
        "-o",
        out_file,
    )
    assert code == 0 and "wrote 2000 directions" in out
    table = np.load(out_file)
    assert table.shape == (2000, 5) and np.all(np.isfinite(table))
    np.testing.assert_allclose(np.linalg.norm(table[:, :3], axis=1), 1.0, rtol=1e-12)
    assert np.all(table[:, 3] > 0.0)


def test_check_a_shader_with_an_adaptive_sampler(capsys):
    code, out, _ = run_cli(
        capsys,
        "check",
        "--model",
        SHADER,
        "--sampler",
        "adaptive_exact",
        "--theta",
        "0",
        "60",
        "--samples",
        "20000",
    )
    assert code == 0, out
    assert f"{SHADER} / adaptive_exact" in out and out.count("PASS") == 2 and "all passed" in out


def test_export_a_shader(capsys, tmp_path):
    from core.measured import load_measured

    out_file = tmp_path / "plastic.bsdf"
    code, out, _ = run_cli(capsys, "export", "--model", SHADER, "--param", "highlight=0", "-o", out_file)
    assert code == 0 and f"wrote {out_file}" in out
    back = load_measured(out_file)
    wo, wi = degrees_to_dir(30, 0), degrees_to_dir(45, 120)
    np.testing.assert_allclose(back.eval(wo, wi)[0], np.array([0.5, 0.3, 0.2]) / math.pi, rtol=0.02)


def test_fit_a_shader_and_read_the_material_in_a_scene(capsys, tmp_path):
    """The written material names the file relative to itself: a scene beside it reads the same model."""
    from core.scene import scene_from_dict

    out_file = tmp_path / "fitted.json"
    code, out, _ = run_cli(
        capsys, "fit", "--measured", MEASURED, "--model", SHADER, "--fix", "shininess=50", "highlight=1",
        "--starts", "1", "--out", out_file,
    )  # fmt: skip
    assert code == 0, out
    assert "diffuse" in out and "highlight  1 (fixed)" in out
    material = json.loads(out_file.read_text())
    assert material["name"] == "cli_plastic fit of red_plastic_ct"
    assert not Path(material["model"]).is_absolute()
    assert (tmp_path / material["model"]).resolve() == SHADER.resolve()
    scene = scene_from_dict({"version": 2, "materials": [material]}, "fitted.json", base_dir=tmp_path)
    assert scene.materials[0].model == str(SHADER)
    assert scene.materials[0].params["shininess"] == 50.0


def test_models_describes_a_file(capsys):
    code, out, _ = run_cli(capsys, "models", "--json", SHADER)
    assert code == 0
    (entry,) = json.loads(out)
    assert entry["name"] == str(SHADER) and entry["analytic_sampler"] is False
    kinds = {p["name"]: (p["kind"], p["default"], p["min"], p["max"]) for p in entry["parameters"]}
    assert kinds == {
        "diffuse": ("color", [0.5, 0.3, 0.2], 0.0, 1.0),
        "shininess": ("float", 50.0, 1.0, 500.0),
        "highlight": ("bool", 1.0, 0.0, 1.0),
    }
    assert entry["file"]["path"] == str(SHADER) and len(entry["file"]["sha256"]) == 64
    assert "isotropic" in entry["traits"]  # measured at load
    code, out, _ = run_cli(capsys, "models", "lambert", PYTHON)
    assert code == 0 and out.startswith("lambert") and f"{PYTHON} Blinn-Phong" in out


# ------------------------------------------------------------------------------------------------- bad files

SHADER_HEAD = "analytic\n::begin parameters\nfloat rough 0 1 0.5\n::end parameters\n::begin shader\n"
SHADER_TAIL = "::end shader\n"
"""A shader file around a body whose first line is line 6."""


def _shader(body: str) -> str:
    return SHADER_HEAD + textwrap.dedent(body).lstrip("\n") + SHADER_TAIL


BAD_FILES = {
    "syntax error": (
        "bad.brdf",
        _shader(
            "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    float a = 1.0\n    return vec3(a);\n}\n"
        ),
        9,
        "syntax error",
    ),
    "unknown function": (
        "bad.brdf",
        _shader("vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    return vec3(fresnel(L, N));\n}\n"),
        8,
        "unknown function 'fresnel'",
    ),
    "wrong BRDF signature": (
        "bad.brdf",
        _shader("float BRDF(vec3 L, vec3 V, vec3 N)\n{\n    return 1.0;\n}\n"),
        6,
        "BRDF must be declared as",
    ),
    "default outside its range (shader)": (
        "bad.brdf",
        "analytic\n::begin parameters\nfloat rough 0 1 1.5\n::end parameters\n::begin shader\n"
        "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(rough); }\n" + SHADER_TAIL,
        3,
        "outside [0, 1]",
    ),
    "default outside its range (Python)": (
        "bad.py",
        "from core.brdf import Param\n\nPARAMS = (\n    Param('kd', 0.5),\n    Param('n', 0.5, 1.0, 100.0),\n)\n\n"
        "def eval(wi, wo, p):\n    return p[0], p[0], p[0]\n",
        5,
        "outside its allowed range [1, 100]",
    ),
    "Python file that raises": (
        "bad.py",
        "from core.brdf import Param\n\nPARAMS = (Param('kd', 0.5),)\nscale = 1.0 / 0.0\n",
        4,
        "ZeroDivisionError",
    ),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_a_bad_file_is_one_line_naming_the_file_and_line(capsys, tmp_path, case):
    name, text, line, words = BAD_FILES[case]
    path = tmp_path / name
    path.write_text(text)
    code, out, err = run_cli(capsys, "eval", "--model", path, "--wi", "30,0", "--wo", "30,180")
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"brdf-studio eval: error: {path}:{line}:"), lines[0]
    assert words in lines[0]


@pytest.mark.parametrize(
    ("model", "value", "line", "range_text"),
    [
        (SHADER, "shininess=600", 9, "[1, 500]"),
        (PYTHON, "n=0.5", 23, "[1, 10000]"),
        (SHADER, "highlight=2", 10, ""),
    ],
)
def test_a_param_outside_its_range_names_its_declaration(capsys, model, value, line, range_text):
    code, _, err = run_cli(capsys, "eval", "--model", model, "--param", value, "--wi", "0,0", "--wo", "0,0")
    assert code == 2
    (text,) = err.strip().splitlines()
    assert text.startswith(f"brdf-studio eval: error: {model}:{line}: --param {value}:"), text
    assert range_text in text and ("true or false" in text or "outside its allowed range" in text)
    assert model.read_text().splitlines()[line - 1].lstrip().startswith(("float", "bool", 'Param("n"'))


def test_an_unknown_param_lists_the_files_own(capsys):
    code, _, err = run_cli(
        capsys, "eval", "--model", SHADER, "--param", "kd=0.5", "--wi", "0,0", "--wo", "0,0"
    )
    assert code == 2 and "no parameter 'kd'" in err and "diffuse, shininess, highlight" in err


@pytest.mark.parametrize("case", ["missing", "folder", "binary"])
def test_unreadable_model_files(capsys, tmp_path, case):
    path = tmp_path / ("m.brdf" if case != "binary" else "m.py")
    if case == "folder":
        path.mkdir()
    elif case == "binary":
        path.write_bytes(b"\x7fELF\x02\x01\x01\x00\xff\xfe" * 10)
    code, out, err = run_cli(capsys, "albedo", "--model", path)
    assert code == 2 and out == ""
    (text,) = err.strip().splitlines()
    assert text.startswith(f"brdf-studio albedo: error: {path}:")
    assert {"missing": "no such model file", "folder": "not a regular file", "binary": "not a text file"}[
        case
    ] in text


NOT_A_BRDF = _shader(
    """
    vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
    {
        float d = dot(L, V);
        return vec3(d, sqrt(d - 0.5), rough);
    }
    """
)
"""Negative where L and V are more than 90 degrees apart, NaN (sqrt of a negative) where 60."""


def test_values_that_are_not_a_brdfs_are_notices_and_the_command_goes_on(capsys, tmp_path):
    path = tmp_path / "not_a_brdf.brdf"
    path.write_text(NOT_A_BRDF)
    code, out, err = run_cli(capsys, "eval", "--model", path, "--wi", "60,0", "--wo", "60,180")
    assert code == 0
    assert [float(x) for x in out.split()] == [0.0, 0.0, 0.5]  # taken as 0
    notices = err.strip().splitlines()
    assert len(notices) == 2 and all(
        n.startswith("brdf-studio eval: notice: not_a_brdf.brdf returns ") for n in notices
    )
    assert "NaN values" in notices[0] and "negative values" in notices[1]
    assert all("first at L (theta" in n and "taken as 0" in n for n in notices)


def test_check_passes_a_sampler_on_a_shader_with_notices(capsys, tmp_path):
    """``check`` judges the sampler against the BRDF as it is used (bad values taken as 0): the notices are
    printed, and they do not fail it (docs/model-files.md)."""
    path = tmp_path / "not_a_brdf_check.brdf"
    path.write_text(NOT_A_BRDF)
    code, out, err = run_cli(
        capsys, "check", "--model", path, "--sampler", "cosine", "--theta", "30", "--samples", "20000"
    )
    assert code == 0, out
    assert "brdf-studio check: notice:" in err and "all passed" in out


def test_the_console_script_exits_2_without_a_traceback(tmp_path):
    path = tmp_path / "bad.brdf"
    path.write_text(BAD_FILES["unknown function"][1])
    proc = subprocess.run(
        [sys.executable, "-m", "app", "eval", "--model", str(path), "--wi", "0,0", "--wo", "0,0"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and f"{path}:8:" in proc.stderr


def test_check_passes_where_the_model_is_zero_for_every_direction(capsys, tmp_path):
    """A shader that is NaN (taken as 0) for every wi when V is the normal, as BRDF Explorer's Oren-Nayar
    (normalize(V - N (V.N)) of a zero vector): at theta 0 there is nothing to accept, the sampler draws the
    cosine density, and check passes on its chi-square tests instead of failing on an acceptance of 0."""
    shader = tmp_path / "blind_at_normal.brdf"
    shader.write_text(
        "analytic\n::begin parameters\nfloat k 0 1 0.5\n::end parameters\n::begin shader\n"
        "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n"
        "    float c = dot(normalize(V - N * dot(V, N)), vec3(1.0, 0.0, 0.0));\n"
        "    return vec3(k * (1.0 + 0.0 * c) / 3.14159265);\n}\n::end shader\n"
    )
    argv = ("check", "--model", str(shader), "--sampler", "adaptive_exact", "--samples", "20000")
    code, out, _ = run_cli(capsys, *argv, "--theta", "0,45")
    assert code == 0, out
    assert "acceptance=0.000" in out and "2 rows FAILED" not in out and "all passed" in out
