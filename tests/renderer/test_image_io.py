"""Image files: EXR round trip, PNG, labelled composite, error metrics and error-vs-time curves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.errors import FileFormatError, OutputError
from renderer.image_io import (
    composite,
    image_errors,
    read_exr,
    tonemap,
    write_error_curves,
    write_exr,
    write_png,
)


def test_exr_round_trip_is_exact(tmp_path: Path, rng: np.random.Generator) -> None:
    img = (rng.random((5, 7, 3)) * 100).astype(np.float32)
    write_exr(tmp_path / "a.exr", img, {"spp": 4})
    assert np.array_equal(read_exr(tmp_path / "a.exr"), img)


def test_bad_exr_and_bad_folder(tmp_path: Path) -> None:
    (tmp_path / "x.exr").write_bytes(b"not an exr")
    with pytest.raises(FileFormatError, match="not a readable EXR"):
        read_exr(tmp_path / "x.exr")
    with pytest.raises(OutputError, match="does not exist"):
        write_exr(tmp_path / "no" / "a.exr", np.zeros((2, 2, 3)))


def test_png_and_tonemap(tmp_path: Path) -> None:
    img = np.array([[[0.0, 0.5, 1.0], [2.0, np.nan, 0.0031308]]])
    t = tonemap(img)
    assert t.dtype == np.uint8
    # sRGB transfer: 0.5 linear -> 188/255; 1 and above -> 255; NaN shown black
    assert t[0, 0].tolist() == [0, 188, 255] and t[0, 1].tolist() == [255, 0, 10]
    write_png(tmp_path / "a.png", img)
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_composite_places_tiles_and_labels() -> None:
    a = np.zeros((32, 20, 3))
    b = np.ones((32, 20, 3))
    c = composite([a, b], ["UNIFORM", "ADAPTIVE"])
    assert c.shape[1] == 44  # two tiles and a 4-pixel gap
    band = c.shape[0] - 32
    assert np.all(c[band:, :20] == 0) and np.all(c[band:, 24:] == 255)
    assert (c[:band] == 255).any()  # label text drawn


def test_errors_and_curves(tmp_path: Path) -> None:
    ref = np.full((4, 4, 3), 2.0)
    img = ref.copy()
    img[0, 0, 0] = 3.0
    e = image_errors(img, ref)
    assert e["rmse"] == pytest.approx(np.sqrt(1.0 / 48))
    assert e["relmse"] == pytest.approx(1.0 / 48 / (4.0 + 1e-2))
    with pytest.raises(FileFormatError, match="reference image is 4x4"):
        image_errors(np.zeros((2, 4, 3)), ref)
    curves = {"uniform": [{"spp": 1, "seconds": 0.1, "rmse": 0.5, "relmse": 0.1}]}
    csv_path, png_path = write_error_curves(tmp_path / "err", curves)
    assert csv_path.read_text().splitlines()[1].startswith("uniform,1,0.1000,0.5,")
    assert png_path.stat().st_size > 0
