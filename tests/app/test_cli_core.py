"""The library commands of the CLI: ``eval``, ``albedo`` (analytic and ``--measured``) and ``demo``.

Run in-process through ``app.cli.main`` (the same code path as the console script), plus one real
subprocess to check the installed entry point's exit code and that no traceback reaches the user.
Expected numbers are closed forms (Lambert: ``f = kd / pi``, albedo ``kd``) or the library's own evaluation
of the same BRDF (the CLI must only parse and print, to the printed precision).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from app.cli import main
from core.brdf import make_brdf
from core.geometry import degrees_to_dir
from core.merl import SCALES, write_merl


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def constant_merl(tmp_path_factory) -> str:
    """A MERL file whose every cell holds raw (1500, 1500/1.15, 1500/1.66): f = 1 in each channel."""
    path = tmp_path_factory.mktemp("cli") / "const.binary"
    raw = np.empty((3, 90, 90, 180))
    raw[:] = (1.0 / SCALES)[:, None, None, None]
    write_merl(path, raw)
    return str(path)


def test_eval_lambert_prints_kd_over_pi(capsys):
    code, out, err = run_cli(
        capsys, "eval", "--model", "lambert", "--param", "kd=0.2,0.5,0.8", "--wi", "30,0", "--wo", "45,90"
    )
    assert code == 0 and err == ""
    np.testing.assert_allclose(
        [float(x) for x in out.split()], np.array([0.2, 0.5, 0.8]) / math.pi, rtol=1e-8
    )


def test_eval_matches_library_for_another_model(capsys):
    name = "ward" if "ward" in [line.split()[0] for line in _models(capsys)] else "lambert"
    code, out, _ = run_cli(capsys, "eval", "--model", name, "--wi", "20,10", "--wo", "50,200", "--json")
    assert code == 0
    data = json.loads(out)
    expected = make_brdf(name).eval(degrees_to_dir(50, 200), degrees_to_dir(20, 10))[0]
    np.testing.assert_allclose(data["f_r"], expected, rtol=1e-12)


def _models(capsys) -> list[str]:
    main(["models"])
    out, _ = capsys.readouterr()
    return [line for line in out.splitlines() if line and not line.startswith(" ")]


def test_eval_below_horizon_is_zero(capsys):
    code, out, _ = run_cli(capsys, "eval", "--model", "lambert", "--wi", "90,0", "--wo", "10,0")
    assert code == 0 and [float(x) for x in out.split()] == [0.0, 0.0, 0.0]


def test_eval_measured(capsys, constant_merl):
    code, out, _ = run_cli(capsys, "eval", "--measured", constant_merl, "--wi", "30,0", "--wo", "40,120")
    assert code == 0
    np.testing.assert_allclose([float(x) for x in out.split()], [1.0, 1.0, 1.0], rtol=1e-9)


def test_albedo_table_and_json(capsys):
    code, out, _ = run_cli(capsys, "albedo", "--model", "lambert", "--param", "kd=0.25")
    assert code == 0
    rows = [line.split() for line in out.splitlines()[2:]]
    assert [float(r[0]) for r in rows] == [0.0, 30.0, 60.0, 80.0]  # the default angles
    for r in rows:
        np.testing.assert_allclose([float(x) for x in r[1:4]], 0.25, rtol=1e-6)
    code, out, _ = run_cli(
        capsys, "albedo", "--model", "lambert", "--param", "kd=0.25", "--theta", "10", "85", "--json"
    )
    data = json.loads(out)
    assert [a["theta_deg"] for a in data["albedo"]] == [10.0, 85.0]
    for a in data["albedo"]:
        assert all(abs(v - 0.25) <= e + 1e-13 for v, e in zip(a["value"], a["error"], strict=True))


def test_albedo_measured(capsys, constant_merl):
    """f = 1 everywhere above the horizon: rho = pi (within the stated error)."""
    code, out, _ = run_cli(capsys, "albedo", "--measured", constant_merl, "--theta", "20", "--json")
    assert code == 0
    a = json.loads(out)["albedo"][0]
    assert all(abs(v - math.pi) <= e + 1e-12 for v, e in zip(a["value"], a["error"], strict=True))


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["eval", "--model", "nope", "--wi", "0,0", "--wo", "0,0"], "unknown model 'nope'"),
        (["eval", "--model", "lambert", "--param", "kd=2", "--wi", "0,0", "--wo", "0,0"], r"'kd'.*\[0, 1\]"),
        (
            ["eval", "--model", "lambert", "--param", "zz=1", "--wi", "0,0", "--wo", "0,0"],
            "no parameter 'zz'",
        ),
        (["eval", "--model", "lambert", "--param", "kd", "--wi", "0,0", "--wo", "0,0"], "name=value"),
        (["eval", "--model", "lambert", "--param", "kd=nan", "--wi", "0,0", "--wo", "0,0"], "finite"),
        (
            ["eval", "--model", "lambert", "--wi", "91,0", "--wo", "0,0"],
            r"--wi: theta must be within \[0, 90\]",
        ),
        (["eval", "--model", "lambert", "--wi=-1,0", "--wo", "0,0"], r"theta must be within \[0, 90\]"),
        (["eval", "--model", "lambert", "--wi", "30", "--wo", "0,0"], "THETA,PHI"),
        (["eval", "--model", "lambert", "--wi", "0,0", "--wo", "a,b"], "--wo must be two numbers"),
        (["eval", "--model", "lambert", "--wi", "0,inf", "--wo", "0,0"], "finite"),
        (["eval", "--wi", "0,0", "--wo", "0,0"], "give --model"),
        (["eval", "--model", "merl", "--wi", "0,0", "--wo", "0,0"], "give --measured FILE"),
        (
            ["albedo", "--model", "lambert", "--theta", "95"],
            r"--theta: must be a number in \[0, 90\], got '95'",
        ),
        (["albedo", "--model", "lambert", "--theta", "x"], "--theta: must be a number"),
        (["albedo", "--model", "nope"], "unknown model"),
        (["albedo", "--measured", "/nonexistent/file.binary"], "does not exist"),
        (["demo", "--material", "no such material"], "unknown demo material"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, argv, message):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"brdf-studio {argv[0]}: error:")
    assert __import__("re").search(message, lines[0]), lines[0]


@pytest.mark.parametrize("kind", ["truncated", "header", "nan"])
def test_corrupt_measured_file(capsys, tmp_path, kind):
    path = tmp_path / "bad.binary"
    header = np.array([90, 90, 360 if kind == "header" else 180], dtype="<i4").tobytes()
    n = 1000 if kind == "truncated" else 3 * 90 * 90 * 180
    body = np.full(n, np.nan if kind == "nan" else 1.0).tobytes()
    path.write_bytes(header + body)
    code, _, err = run_cli(capsys, "albedo", "--measured", str(path))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert {"truncated": "truncated", "header": "dimensions", "nan": "non-finite"}[kind] in err


def test_measured_and_model_together_is_refused(capsys, constant_merl):
    code, _, err = run_cli(
        capsys, "eval", "--model", "lambert", "--measured", constant_merl, "--wi", "0,0", "--wo", "0,0"
    )
    assert code == 2 and "either --model or --measured" in err


def test_demo_runs_on_one_material(capsys):
    code, out, _ = run_cli(capsys, "demo", "--material", "white paper")
    assert code == 0
    assert "== white paper" in out and "energy: conserving" in out and "reciprocity: reciprocal" in out
    assert "0.80000" in out  # Lambert kd = 0.8: albedo 0.8


def test_console_script_exit_code_and_no_traceback():
    proc = subprocess.run(
        [sys.executable, "-m", "app", "eval", "--model", "lambert", "--wi", "100,0", "--wo", "0,0"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "theta must be within" in proc.stderr


def test_the_parser_does_not_import_what_only_one_command_needs():
    """Every command's parser is built on every call (``--help`` included): scipy's statistics (0.7 s, for
    ``check`` only) and Qt are imported by the commands that use them, not by the parser."""
    code = (
        "import sys; from app.cli import build_parser; build_parser(); "
        "print(sorted(m for m in ('scipy.stats', 'PySide6.QtWidgets', 'vtk', 'pyvista') if m in sys.modules))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_setup_compiles_or_loads_every_group_and_says_so(capsys):
    """``brdf-studio setup`` runs every warm-up group of the models, samplers and renderer, one line each."""
    from core.warmup import WARM_UPS as CORE
    from renderer.tracer_warmup import WARM_UPS as RENDERER

    code, out, err = run_cli(capsys, "setup")
    assert code == 0, err
    lines = out.splitlines()
    for package, groups in (("core", CORE), ("renderer", RENDERER)):
        mine = [line.removeprefix(f"[{package}] ") for line in lines if line.startswith(f"[{package}] ")]
        assert mine[0].startswith("numba cache: "), mine
        for group in groups:
            assert any(line.endswith(f" s  {group.label}") for line in mine), group.label
        assert mine[-1].endswith(" s  total"), mine
