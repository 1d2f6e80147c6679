"""Spectral RGL .bsdf files (the RGL database's own format: ``wavelengths`` and ``spectra`` in place of ``rgb``)
read as linear sRGB (core/rgl/spectral.py: CIE 1931 2-degree observer under D65).

The test files are written here from an exported analytic table (its NDF, sigma, VNDF and luminance warps),
with the stored values replaced by spectra: ``grey value x g(lambda)`` at every node.

Tolerances:
- a flat spectrum reads back as its grey value to 2e-6 relative (float32 storage, twice: 6e-8 each, and the
  white correction makes a flat spectrum exactly grey in float64);
- a coloured spectrum against Mitsuba 3's own conversion of a reflectance spectrum in its RGB variants
  (``mi.spectrum_list_to_srgb(..., d65=True)``: 5 nm tables, a 1000-point rectangle rule, no white correction)
  to 5e-3 absolute on channels of ~0.1-0.9;
- chi-square (core.chi2, Sidak-corrected 1 % over the two cases) of ``rgl_warp`` draws on spectral files;
- fitting a grey Phong written as a flat spectrum recovers its parameters within the issue's 2 %.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core.brdf import make_brdf
from core.fit import fit
from core.geometry import degrees_to_dir
from core.measured import load_measured
from core.rgl.export import ExportOptions, tabulate
from core.rgl.material import RGLTable, read_bsdf, rgl_brdf, write_bsdf
from core.rgl.spectral import rgb_weights
from core.rgl.tensor_file import read_tensor_file, write_tensor_file
from core.sampling import make_sampler
from tests.core._rgl_checks import assert_clear_errors, assert_warp_chi2

SMALL = ExportOptions(n_theta_i=8, n_phi_quadrant=4, vndf=(32, 32), samples=(16, 16), ndf=(32, 32))
PHONG = {"n": 60.0, "ks": 0.5, "kd": 0.3}
WARD = {"sx": 0.08, "sy": 0.3, "ks": 0.4, "kd": 0.2}
WAVELENGTHS = np.linspace(360.0, 1000.0, 161)
"""As the RGL database's spectral files: 360 to 1000 nm (here every 4 nm)."""


def reddish(wl: np.ndarray) -> np.ndarray:
    """A smooth reflectance inside the sRGB gamut: a ramp towards red over a floor."""
    return 0.15 + 0.7 / (1.0 + np.exp(-(wl - 590.0) / 25.0))


def write_spectral(path: Path, table: RGLTable, wavelengths: np.ndarray, spectrum: np.ndarray) -> None:
    """A spectral file with the geometry of ``table`` and, at every node, its red channel times ``spectrum``
    (one value per wavelength)."""
    fields = {k: v for k, v in table.fields().items() if k != "rgb"}
    grey = table.rgb[:, :, :1].astype(np.float64)
    spectra = grey * np.asarray(spectrum, dtype=np.float64)[None, None, :, None, None]
    fields["wavelengths"] = np.asarray(wavelengths, dtype=np.float32)
    fields["spectra"] = spectra.astype(np.float32)
    write_tensor_file(path, fields)


@pytest.fixture(scope="module")
def tables() -> dict[str, RGLTable]:
    return {
        "phong": tabulate(make_brdf("phong", PHONG), SMALL),
        "ward": tabulate(make_brdf("ward", WARD), SMALL),
    }


@pytest.fixture(scope="module")
def files(tables, tmp_path_factory) -> dict[str, Path]:
    """For each model: its RGB file, and spectral files with a flat and a reddish spectrum."""
    folder = tmp_path_factory.mktemp("spectral")
    out: dict[str, Path] = {}
    for name, table in tables.items():
        out[f"{name}_rgb"] = folder / f"{name}.bsdf"
        write_bsdf(out[f"{name}_rgb"], table)
        out[f"{name}_flat"] = folder / f"{name}_flat_spec.bsdf"
        write_spectral(out[f"{name}_flat"], table, WAVELENGTHS, np.ones_like(WAVELENGTHS))
        out[f"{name}_red"] = folder / f"{name}_red_spec.bsdf"
        write_spectral(out[f"{name}_red"], table, WAVELENGTHS, reddish(WAVELENGTHS))
    return out


def _pairs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    v = rng.normal(size=(2, n, 3))
    v[..., 2] = np.abs(v[..., 2]) + 0.05
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    return v[0], v[1]


def test_a_flat_spectrum_reads_as_its_grey(tables, files, rng):
    """Every stored value of a flat-spectrum file becomes ``(c, c, c)``; its lookups are the RGB file's."""
    for name, table in tables.items():
        read = read_bsdf(files[f"{name}_flat"])
        assert read.wavelengths is not None and read.wavelengths.shape == WAVELENGTHS.shape
        grey = table.rgb[:, :, :1].astype(np.float64)
        assert np.allclose(read.rgb, np.broadcast_to(grey, read.rgb.shape), rtol=2e-6, atol=1e-9)
        wo, wi = _pairs(rng, 3000)
        spectral, rgb = rgl_brdf(files[f"{name}_flat"]), rgl_brdf(files[f"{name}_rgb"])
        f_rgb = rgb.eval(wo, wi)[:, :1]
        assert np.allclose(spectral.eval(wo, wi), f_rgb, rtol=2e-6, atol=1e-9)
        assert spectral.model is rgb.model


def test_a_coloured_spectrum_matches_mitsuba(tables, files, rng):
    """A reddish reflectance: each node's value times the colour Mitsuba 3 makes of that spectrum in its RGB
    variants; the channels keep their order (R > G > B)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    values = reddish(WAVELENGTHS)
    expected = np.array(mi.spectrum_list_to_srgb(list(WAVELENGTHS), list(values), False, True), dtype=float)
    colour = values @ rgb_weights(WAVELENGTHS)
    assert expected[0] > expected[1] > expected[2] > 0.0
    assert np.allclose(colour, expected, rtol=0.0, atol=5e-3), (colour, expected)
    read = read_bsdf(files["phong_red"])
    grey = tables["phong"].rgb[:, :, :1].astype(np.float64)
    assert np.allclose(read.rgb, grey * colour[None, None, :, None, None], rtol=2e-6, atol=1e-9)
    wo, wi = _pairs(rng, 2000)
    f_grey = rgl_brdf(files["phong_rgb"]).eval(wo, wi)[:, :1]
    assert np.allclose(rgl_brdf(files["phong_red"]).eval(wo, wi), f_grey * colour, rtol=2e-6, atol=1e-9)


def test_the_cie_table_is_what_its_script_writes():
    """core/rgl/cie_tables.py is generated from colour-science (``python -m core.rgl.spectral``): unchanged."""
    pytest.importorskip("colour")
    from core.rgl import spectral

    assert (Path(spectral.__file__).with_name("cie_tables.py")).read_text() == spectral.table_source()


def test_light_outside_the_visible_range_has_no_colour():
    wl = np.linspace(360.0, 1000.0, 65)
    k = rgb_weights(wl)
    infrared = (wl > 830.0).astype(float)
    assert np.all(infrared @ k == 0.0)
    assert np.allclose(np.ones_like(wl) @ k, 1.0, rtol=1e-12)
    # Linear in the spectrum; a flat spectrum over 450-650 nm only (0 outside the stored range) is less light,
    # and green: the ends of the range, violet-blue and deep red, are missing.
    assert np.allclose((2.0 * reddish(wl)) @ k, 2.0 * (reddish(wl) @ k))
    narrow = np.linspace(450.0, 650.0, 11)
    colour = np.ones_like(narrow) @ rgb_weights(narrow)
    assert colour @ np.array([0.2126, 0.7152, 0.0722]) < 0.99
    assert colour[1] > colour[0] > colour[2]


CHI2_CASES = [("phong", 35.0), ("ward", 60.0)]


@pytest.mark.parametrize("name,theta", CHI2_CASES)
def test_rgl_warp_chi2_on_a_spectral_file(files, name, theta):
    sampler = make_sampler("rgl_warp", load_measured(files[f"{name}_red"]))
    drawn = assert_warp_chi2(sampler, degrees_to_dir(theta, 15.0), n_tests=len(CHI2_CASES), seed=11)
    ok = drawn.pdf > 0.0
    assert np.all(drawn.f[ok][:, 0] >= drawn.f[ok][:, 2])  # the reddish colour travels with the draws


def test_fitting_a_spectral_file(files):
    """A grey Phong written as a flat spectrum: the fit recovers its parameters (target 2 %)."""
    result = fit(load_measured(files["phong_flat"]), "phong", starts=1)
    assert result.params["n"] == pytest.approx(PHONG["n"], rel=0.02)
    for key in ("ks", "kd"):
        assert np.allclose(result.params[key], PHONG[key], rtol=0.02), (key, result.params[key])


def test_writing_a_spectral_table_writes_rgb(files, tmp_path):
    table = read_bsdf(files["phong_red"])
    out = tmp_path / "again.bsdf"
    write_bsdf(out, table)
    fields = read_tensor_file(out)
    assert "rgb" in fields and "spectra" not in fields and "wavelengths" not in fields
    again = read_bsdf(out)
    assert again.wavelengths is None and np.array_equal(again.rgb, table.rgb)


# ------------------------------------------------------------------------------------------ bad files


def _broken(good: Path, folder: Path) -> dict[str, tuple[Path, str]]:
    fields = read_tensor_file(good)
    wl, spectra = fields["wavelengths"], fields["spectra"]
    cases: dict[str, tuple[dict, str]] = {
        "no_wavelengths": (
            {k: v for k, v in fields.items() if k != "wavelengths"},
            "without field 'wavelengths'",
        ),
        "no_spectra": ({k: v for k, v in fields.items() if k != "spectra"}, "without field 'spectra'"),
        "float64": ({**fields, "spectra": spectra.astype(np.float64)}, "'spectra' is float64"),
        "rank": ({**fields, "wavelengths": wl[None, :]}, "'wavelengths' is float32 of rank 2"),
        "decreasing": ({**fields, "wavelengths": wl[::-1].copy()}, "increasing positive"),
        "one": ({**fields, "wavelengths": wl[:1], "spectra": spectra[:, :, :1]}, "at least 2"),
        "infrared": ({**fields, "wavelengths": wl + np.float32(900.0)}, "outside the visible range"),
        "count": ({**fields, "spectra": spectra[:, :, :-1]}, "len(wavelengths)"),
        "nan": ({**fields, "spectra": np.where(spectra == spectra.max(), np.nan, spectra)}, "NaN"),
        "slices": ({**fields, "spectra": spectra[:, :-1]}, "'spectra' has shape"),
    }
    out = {}
    for name, (content, phrase) in cases.items():
        path = folder / f"{name}.bsdf"
        write_tensor_file(path, content)
        out[name] = (path, phrase)
    return out


def test_corrupt_spectral_files_give_one_clear_error(files, tmp_path):
    assert_clear_errors(_broken(files["phong_flat"], tmp_path))


def test_cli_reads_a_spectral_file_and_refuses_a_corrupt_one(files, tmp_path):
    args = ["eval", "--wi", "30,0", "--wo", "30,180"]
    good = subprocess.run(
        [sys.executable, "-m", "app.cli", *args, "--measured", str(files["phong_red"])],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert good.returncode == 0, good.stderr
    bad_path, _ = _broken(files["phong_flat"], tmp_path)["infrared"]
    bad = subprocess.run(
        [sys.executable, "-m", "app.cli", *args, "--measured", str(bad_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    lines = [line for line in bad.stderr.splitlines() if line.strip()]
    assert bad.returncode == 2 and len(lines) == 1 and "visible range" in lines[0], bad.stderr
