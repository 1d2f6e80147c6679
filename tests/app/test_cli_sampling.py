"""``brdf-studio sample`` and ``brdf-studio check``: outputs in every format, validation report, and one-line
errors with exit code 2 for bad input."""

from __future__ import annotations

import numpy as np
import pytest

from app.cli import main


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "cache"))


def _run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("suffix", [".csv", ".npy", ".ply"])
def test_sample_writes_directions_with_pdf_and_weight(tmp_path, capsys, suffix):
    out = tmp_path / f"dirs{suffix}"
    code, text, err = _run(
        capsys, "sample", "--model", "phong", "--param", "n=50", "--sampler", "adaptive_exact", "--n-max", "1.5",
        "--theta", "40", "--phi", "10", "-n", "500", "-o", str(out),
    )  # fmt: skip
    assert code == 0, err
    assert "wrote 500 directions" in text
    if suffix == ".npy":
        table = np.load(out)
    elif suffix == ".csv":
        table = np.loadtxt(out, delimiter=",", skiprows=1)
        assert out.read_text().splitlines()[0] == "x,y,z,pdf,weight"
    else:
        lines = out.read_text().splitlines()
        assert lines[0] == "ply" and "element vertex 500" in lines and "property float weight" in lines
        table = np.loadtxt(lines[lines.index("end_header") + 1 :])
    assert table.shape == (500, 5)
    np.testing.assert_allclose(np.linalg.norm(table[:, :3], axis=1), 1.0, atol=1e-6)
    assert np.all(table[:, 2] > 0) and np.all(table[:, 3] > 0)
    # adaptive: the luminance weight is the same for every sample
    assert np.std(table[:, 4]) / np.mean(table[:, 4]) < 1e-6


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--model", "nope", "--theta", "10", "-n", "5"], "unknown model 'nope'"),
        (["--model", "lambert", "--sampler", "nope", "--theta", "10", "-n", "5"], "unknown sampler 'nope'"),
        (
            ["--model", "lambert", "--theta", "91", "-n", "5"],
            "--theta: must be a number in [0, 90], got '91'",
        ),
        (["--model", "lambert", "--theta=-1", "-n", "5"], "--theta: must be a number in [0, 90], got '-1'"),
        (
            ["--model", "lambert", "--theta", "10", "-n", "0"],
            "--samples: must be a whole number in [1, 1e15]",
        ),
        (
            ["--model", "lambert", "--theta", "10", "-n", "5", "--n-max", "1"],
            "--n-max: must be a number in (1, 1000], got '1'",
        ),
    ],
)
def test_sample_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, message):
    code, _, err = _run(capsys, "sample", *argv, "-o", str(tmp_path / "x.csv"))
    assert code == 2
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_sample_unwritable_output_and_bad_format(tmp_path, capsys):
    code, _, err = _run(
        capsys,
        "sample",
        "--model",
        "lambert",
        "--theta",
        "0",
        "-n",
        "5",
        "-o",
        str(tmp_path / "no" / "x.csv"),
    )
    assert code == 2 and "cannot write" in err
    code, _, err = _run(capsys, "sample", "--model", "lambert", "--theta", "0", "-n", "5", "-o", "x.txt")
    assert code == 2 and ".csv" in err


def test_check_prints_the_report_and_passes(capsys):
    code, text, err = _run(
        capsys,
        "check",
        "--model",
        "lambert",
        "--sampler",
        "adaptive_exact",
        "--theta",
        "30",
        "--samples",
        "200000",
    )
    assert code == 0, text + err
    assert (
        "p_sphere=" in text and "int_pdf=1.0000" in text and "violations=0" in text and "all passed" in text
    )


def test_check_fails_on_a_bad_theta(capsys):
    code, _, err = _run(capsys, "check", "--model", "lambert", "--theta", "100")
    assert code == 2 and "[0, 90]" in err
