"""Renders too large for one film, in bands of rows (``brdf-studio render``'s path for them), and the check
every written image passes."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from app.commands import _signals
from app.commands._args import with_extension
from core.errors import BrdfStudioError, ParameterError


def check_finite(image: np.ndarray, strategy: str) -> None:
    """Refuse an image with a value that is not finite (nothing is written then)."""
    bad = int(np.count_nonzero(~np.isfinite(image)))
    if bad:
        from core.scene import MAX_RADIANCE

        raise BrdfStudioError(
            f"{strategy}: {bad} pixel values are not finite; the image was not written (radiance per channel "
            f"must stay within [0, {MAX_RADIANCE:g}]: lower the scene's light intensities or the map's scale)"
        )


def check_band_request(
    args: argparse.Namespace, time_s: float | None, strategies: list[str], width: int, height: int
) -> None:
    """A render in bands takes a sample count and one strategy: one line naming what it cannot do."""
    from core.budget import MEMORY_FRACTION, available_memory, format_bytes
    from renderer.render import render_memory

    why = (
        f"a {width}x{height} render needs {format_bytes(render_memory(width, height, args.ris))} as one film "
        f"(this machine has {format_bytes(MEMORY_FRACTION * available_memory())} for it), so it is rendered in "
        "bands of rows, each with all its samples"
    )
    if time_s is not None:
        given = (
            "--until-cancelled" if args.until_cancelled else "--time" if args.time else "the scene's time_s"
        )
        raise ParameterError(f"{why}: give --spp N instead of {given}, or a smaller --width/--height")
    if len(strategies) > 1:
        raise ParameterError(f"{why}: render one strategy at a time (--sampler S), not --compare")
    if args.reference:
        raise ParameterError(f"{why}: --reference needs the whole image after every pass; compare afterwards")


def render_in_bands(
    job, strategy: str, spp: int, rows: int, stem: Path, exposure: float, quiet: bool
) -> bool:  # type: ignore[no-untyped-def]
    """Render ``job`` in bands of ``rows`` rows, each streamed to the EXR and PNG as it is finished (temporary
    files that replace ``stem.exr/.png`` when the last band is written, with the sidecar). Returns whether the
    outputs were written: a Ctrl-C (or SIGTERM) stops after the pass in flight and deletes the temporary files,
    so the previous outputs stay as they were."""
    from tqdm import tqdm

    from renderer.image_io import ExrRows, PngRows, write_sidecar

    width, height = job.tracer.width, job.tracer.height
    bar = tqdm(total=height, desc=f"{strategy}: render in bands", unit="row", disable=quiet, file=sys.stderr)
    exr = ExrRows(with_extension(stem, ".exr"), width, height, {"spp": spp, "sampler": strategy})
    try:
        png = PngRows(with_extension(stem, ".png"), width, height, exposure)
    except BaseException:
        exr.discard()
        bar.close()
        raise
    try:
        done = 0
        with _signals.cooperative() as stop:
            for band in job.bands(spp, rows, cancel=stop):
                _signals.reinstall()
                check_finite(band.image, strategy)
                exr.write(band.image)
                png.write(band.image)
                done = band.row1
                bar.update(band.row1 - band.row0)
        if done < height:
            return False
        with _signals.cooperative():  # a Ctrl-C now is recorded: the three files are put in place together
            exr.commit()
            png.commit()
            write_sidecar(with_extension(stem, ".json"), job.info())
        return True
    except KeyboardInterrupt:  # a second Ctrl-C: stop now
        return False
    finally:
        exr.discard()
        png.discard()
        bar.close()
