"""Renders in bands of rows (a film too large for memory): the same estimator as the whole film, memory that
does not grow with the image, outputs streamed band by band and written atomically."""

from __future__ import annotations

import json
import os
import signal
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.scene import load_scene
from renderer import render as render_module
from renderer.image_io import ExrRows, PngRows, read_exr, tonemap, write_exr
from renderer.render import band_memory, band_plan, band_rows, prepare, render_memory
from tests.renderer.test_integrator import _mixed_scene
from tests.renderer.test_render import scene_file  # noqa: F401 - the fixture

MiB = 1 << 20


def _in_bands(job, spp: int, rows: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    bands = list(job.bands(spp, rows))
    assert [b.row0 for b in bands] == list(range(0, job.tracer.height, rows))
    assert all(b.spp == spp for b in bands)
    return np.concatenate([b.image for b in bands])


@pytest.mark.parametrize("sampler", ["cosine", "analytic"])
def test_bands_equal_the_whole_film_bit_for_bit(tmp_path: Path, sampler: str) -> None:
    """A band traces the very paths the whole film's passes trace for its pixels (same pass indices, batch
    and sample numbers; every random number of a compiled strategy is keyed by the path), so a render in
    bands equals the progressive render bit for bit: here passes of 2 + 2 + 1 spp, bands of 5 rows (the last
    one shorter), on two threads."""
    scene = _mixed_scene(tmp_path, sampler)
    whole = prepare(scene, width=20, height=18, seed=7)
    whole.batch = 2
    image = whole.run(spp=5).image
    job = prepare(scene, width=20, height=18, seed=7)
    job.batch = 2
    banded = _in_bands(job, 5, rows=5)
    assert np.array_equal(banded, image)
    assert image.max() > 0 and job.spp == 5 and job.info()["bands"] == {"rows": 5, "count": 4}


def test_bands_of_a_table_sampler_agree_with_the_whole_film(tmp_path: Path) -> None:
    """Strategies with tables draw through their sampler objects, seeded per wavefront and slice (only the
    first bounces' warps read the renderer's per-pixel Sobol points), so bands (other wavefronts) draw other
    numbers: the same estimator, not the same image. Twelve whole passes and
    twelve passes in bands of 3 rows (other pass indices: other sample numbers and keys) agree on 4x4-pixel
    blocks within a Bonferroni-corrected two-sided z-test at alpha = 0.01, the error bars from the
    pass-to-pass spread."""
    from scipy.stats import norm

    passes = 12
    job = prepare(_mixed_scene(tmp_path, "adaptive_warp"), seed=21)
    w = h = 16
    whole = [job.tracer.render_pass(k, 16) for k in range(passes)]
    banded = [
        np.concatenate(
            [job.tracer.render_pass(k, 16, pixels=(r * w, min(h, r + 3) * w)) for r in range(0, h, 3)]
        )
        for k in range(100, 100 + passes)
    ]
    a, b = (np.array([x.reshape(4, 4, 4, 4, 3).mean(axis=(1, 3)) for x in run]) for run in (whole, banded))
    se = np.sqrt(a.var(0, ddof=1) / passes + b.var(0, ddof=1) / passes)
    z = np.abs(a.mean(0) - b.mean(0)) / np.maximum(se, 1e-12)
    assert z.max() < norm.isf(0.01 / (2 * 48)), z.max()
    assert a.mean(0).std() > 0.05
    same_pass = [job.tracer.render_pass(0, 16, pixels=(r * w, min(h, r + 3) * w)) for r in range(0, h, 3)]
    assert not np.array_equal(whole[0], np.concatenate(same_pass))


@pytest.mark.parametrize("strategy", ["adaptive_warp", "uniform_cdf"])
def test_a_table_strategys_first_bounce_reads_the_pixels_sobol_points(tmp_path: Path, strategy: str) -> None:
    """Below the Sobol depth a strategy with tables draws its BRDF sample from the pixel's Sobol point (as
    the compiled strategies do), not from its wavefront's stream: with direct light only (one bounce) and a
    warp that reads nothing else, an image in bands of 3 rows (other wavefronts, other slices, other seeds
    of the samplers' streams) is the whole film's, bit for bit."""
    job = prepare(_mixed_scene(tmp_path, strategy), seed=21, max_depth=1)
    w = h = 16
    whole = job.tracer.render_pass(0, 16)
    banded = [job.tracer.render_pass(0, 16, pixels=(r * w, min(h, r + 3) * w)) for r in range(0, h, 3)]
    assert np.array_equal(whole, np.concatenate(banded))
    assert whole.max() > 0


def test_band_plan_follows_the_memory_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    """Bands only when the whole film exceeds the budget; then the most rows whose estimate fits
    ``BAND_BYTES`` (and the machine); refused when not even one row fits."""
    from core.budget import BudgetError

    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(4 << 30))
    assert band_plan(512, 512) is None
    assert render_memory(16384, 16384) > 0.8 * (4 << 30)
    rows = band_plan(16384, 16384)
    assert rows is not None and 1 < rows < 16384
    cap = min(render_module.BAND_BYTES, 0.8 * (4 << 30))
    assert band_memory(16384, 16384, rows) <= cap < band_memory(16384, 16384, rows + 1)
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(64 << 30))  # a large machine renders the whole film
    assert band_plan(16384, 16384) is None
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(4 << 20))
    with pytest.raises(BudgetError, match="in bands of one row needs"):
        band_plan(16384, 16384)
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(40 * MiB))  # RIS candidates shrink the bands
    assert band_rows(4096, 4096, ris_candidates=4) < band_rows(4096, 4096)


def test_memory_of_a_render_in_bands_does_not_grow_with_the_image(
    scene_file: Path,  # noqa: F811
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A 1024x1024 render in bands of at most 12 MiB (estimate) allocates, at its peak, no more than the
    estimate of one band: less than the whole film's float64 sum alone (24 MiB), whose render would need
    ~25x a band. Measured by tracemalloc over every numpy array and Python object the bands and the writers
    allocate (the passes, the band films, the EXR planes, the PNG rows)."""
    monkeypatch.setattr(render_module, "BAND_BYTES", 12 * MiB)
    side = 1024
    rows = band_rows(side, side)
    assert rows < side // 8
    estimate = band_memory(side, side, rows)
    assert estimate <= 12 * MiB < side * side * 24 < render_memory(side, side) / 4
    job = prepare(load_scene(scene_file), width=side, height=side, seed=3)
    tracemalloc.start()
    try:
        with (
            ExrRows(tmp_path / "big.exr", side, side) as exr,
            PngRows(tmp_path / "big.png", side, side) as png,
        ):
            for band in job.bands(1, rows):
                exr.write(band.image)
                png.write(band.image)
            exr.commit()
            png.commit()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= estimate, (peak / MiB, estimate / MiB)
    img = read_exr(tmp_path / "big.exr")
    assert img.shape == (side, side, 3) and img.max() > 0


def test_rows_writers_stream_the_same_files_and_are_atomic(tmp_path: Path) -> None:
    """EXR and PNG written in bands hold the image ``write_exr`` and ``tonemap`` give; a write that ends by
    an exception, or is left incomplete, leaves the previous file and no temporary file."""
    from PIL import Image

    rng = np.random.default_rng(4)
    img = (rng.random((23, 17, 3)) * 1.5).astype(np.float32)
    with (
        ExrRows(tmp_path / "a.exr", 17, 23, {"spp": 3}) as exr,
        PngRows(tmp_path / "a.png", 17, 23, 0.5) as png,
    ):
        for r in range(0, 23, 5):
            exr.write(img[r : r + 5])
            png.write(img[r : r + 5])
        exr.commit()
        png.commit()
    write_exr(tmp_path / "b.exr", img)
    assert np.array_equal(read_exr(tmp_path / "a.exr"), read_exr(tmp_path / "b.exr"))
    assert np.array_equal(np.asarray(Image.open(tmp_path / "a.png").convert("RGB")), tonemap(img, 0.5))
    import OpenEXR

    with OpenEXR.File(str(tmp_path / "a.exr")) as f:
        assert json.loads(f.header()["brdf_studio"]) == {"spp": 3}

    before = {p: p.read_bytes() for p in (tmp_path / "a.exr", tmp_path / "a.png")}
    with pytest.raises(KeyboardInterrupt):
        with ExrRows(tmp_path / "a.exr", 17, 23) as exr, PngRows(tmp_path / "a.png", 17, 23) as png:
            exr.write(img[:5])
            png.write(img[:5])
            raise KeyboardInterrupt
    exr, png = ExrRows(tmp_path / "a.exr", 17, 23), PngRows(tmp_path / "a.png", 17, 23)
    with pytest.raises(ValueError, match="5 of 23 rows"):
        exr.write(img[:5])
        exr.commit()
    exr.discard()
    png.discard()
    assert {p: p.read_bytes() for p in before} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr", "a.png", "b.exr"]


def test_cli_renders_in_bands_what_it_renders_whole(
    scene_file: Path,  # noqa: F811
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """On a machine too small for the film (``BRDF_STUDIO_MEMORY``), ``render`` writes the same EXR (bit
    for bit, ``cosine``), the same PNG pixels and a sidecar naming the bands; what bands cannot do is one
    line with exit code 2."""
    from PIL import Image

    args = ["render", str(scene_file), "--spp", "3", "--width", "40", "--height", "30", "--quiet"]
    assert main([*args, "-o", str(tmp_path / "whole.exr")]) == 0
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(600_000))
    assert band_plan(40, 30) is not None
    assert main([*args, "-o", str(tmp_path / "band.exr")]) == 0
    assert np.array_equal(read_exr(tmp_path / "band.exr"), read_exr(tmp_path / "whole.exr"))
    pixels = [np.asarray(Image.open(tmp_path / f"{n}.png").convert("RGB")) for n in ("whole", "band")]
    assert np.array_equal(*pixels)
    info = json.loads((tmp_path / "band.json").read_text())
    assert (
        info["spp"] == 3
        and info["bands"]["count"] > 1
        and "bands" not in json.loads((tmp_path / "whole.json").read_text())
    )
    capsys.readouterr()
    base = [
        "render",
        str(scene_file),
        "--width",
        "40",
        "--height",
        "30",
        "--quiet",
        "-o",
        str(tmp_path / "x.exr"),
    ]
    for extra, message in (
        (["--time", "2"], "give --spp N instead of --time"),
        (["--until-cancelled"], "instead of --until-cancelled"),
        (["--spp", "1", "--compare", "uniform,cosine"], "not --compare"),
        (["--spp", "1", "--reference", str(tmp_path / "whole.exr")], "--reference needs the whole image"),
    ):
        assert main([*base, *extra]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "in bands of rows" in err and message in err, err
    assert not (tmp_path / "x.exr").exists()


def test_cli_interrupted_in_bands_keeps_the_previous_outputs(
    scene_file: Path,  # noqa: F811
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A SIGINT after the first band (a real signal to this process, handled as on the command line): the
    pass in flight ends, nothing is written, the previous EXR/PNG/JSON stay as they were, no temporary file
    is left, exit code 130 with one line."""
    out = tmp_path / "o.exr"
    for ext, data in ((".exr", b"old exr"), (".png", b"old png"), (".json", b"{}")):
        out.with_suffix(ext).write_bytes(data)
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(600_000))
    real = render_module.RenderJob.bands

    def bands(self, *a, **kw):  # type: ignore[no-untyped-def]
        for k, band in enumerate(real(self, *a, **kw)):
            if k == 1:
                os.kill(os.getpid(), signal.SIGINT)
            yield band

    monkeypatch.setattr(render_module.RenderJob, "bands", bands)
    code = main(
        [
            "render",
            str(scene_file),
            "--spp",
            "3",
            "--width",
            "40",
            "--height",
            "30",
            "--quiet",
            "-o",
            str(out),
        ]
    )
    err = capsys.readouterr().err.strip()
    assert code == 130 and "interrupted; saved nothing" in err and len(err.splitlines()) == 1, err
    assert [out.with_suffix(e).read_bytes() for e in (".exr", ".png", ".json")] == [
        b"old exr",
        b"old png",
        b"{}",
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["o.exr", "o.png", "o.json", "scene.json", "floor.obj", "ball.obj"]
    )
