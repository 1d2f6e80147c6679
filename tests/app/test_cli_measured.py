"""``brdf-studio export``, ``fit`` and ``eval --measured`` with RGL .bsdf files: outputs, and one clear line with
exit code 2 for every bad input."""

from __future__ import annotations

import json

import pytest

from app.cli import main


@pytest.fixture(scope="module")
def ward_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "ward.bsdf"
    assert main(["export", "--model", "ward", "--param", "sx=0.1", "sy=0.3", "-o", str(path)]) == 0
    return path


def test_export_then_eval(ward_file, capsys):
    capsys.readouterr()
    assert main(["eval", "--measured", str(ward_file), "--wi", "30,0", "--wo", "30,180", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["f_r"]
    main(
        ["eval", "--model", "ward", "--param", "sx=0.1", "sy=0.3", "--wi", "30,0", "--wo", "30,180", "--json"]
    )
    ref = json.loads(capsys.readouterr().out)["f_r"]
    assert got == pytest.approx(ref, rel=0.05)


def test_fit_recovers_and_writes_a_material(ward_file, tmp_path, capsys):
    out = tmp_path / "fitted.json"
    assert (
        main(["fit", "--measured", str(ward_file), "--model", "ward", "--starts", "1", "--out", str(out)])
        == 0
    )
    text = capsys.readouterr().out
    assert "residual" in text and "time:" in text
    material = json.loads(out.read_text())
    assert material["model"] == "ward"
    assert material["params"]["sx"] == pytest.approx(0.1, rel=0.02)
    assert material["params"]["sy"] == pytest.approx(0.3, rel=0.02)


@pytest.mark.parametrize(
    "argv,message",
    [
        (["fit", "--measured", "{missing}", "--model", "ward"], "does not exist"),
        (["fit", "--measured", "{ward}", "--model", "nope"], "unknown model 'nope'"),
        (["fit", "--measured", "{ward}", "--model", "ward", "--fix", "zz=1"], "has no parameter 'zz'"),
        (["fit", "--measured", "{ward}", "--model", "ward", "--metric", "l1"], "invalid choice"),
        (["fit", "--measured", "{bad}", "--model", "ward"], "truncated"),
        (["export", "--model", "ward", "-o", "{tmp}/x.txt"], "not a measured BRDF file"),
        (["export", "--model", "ward", "-o", "{tmp}/none/x.bsdf"], "does not exist"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, message, ward_file, tmp_path, capsys):
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(ward_file.read_bytes()[:500])
    subs = {"{missing}": str(tmp_path / "missing.bsdf"), "{ward}": str(ward_file), "{bad}": str(bad)}
    argv = [subs.get(a, a.replace("{tmp}", str(tmp_path))) for a in argv]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors, where the CLI does not catch them
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert len([line for line in err.splitlines() if line.strip()]) <= 2  # argparse adds its usage line


def test_the_app_document_loads_a_bsdf_material(ward_file, tmp_path):
    """The app's document makes a material measured from a .bsdf file, and refuses a corrupt one unchanged."""
    from app.document import Document
    from core.errors import FileFormatError
    from core.scene import Material, Scene

    doc = Document(Scene(materials=[Material(name="white", model="lambert", params={"kd": (0.8, 0.8, 0.8)})]))
    doc.set_measured(str(ward_file))
    assert doc.scene.materials[0].measured == str(ward_file)
    assert doc.brdf().model.name == "rgl_anisotropic"
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(b"tensor_file")
    with pytest.raises(FileFormatError, match="truncated"):
        doc.set_measured(str(bad))
    assert doc.scene.materials[0].measured == str(ward_file)
