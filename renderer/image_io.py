"""Image files: linear HDR EXR (OpenEXR), tone-mapped sRGB PNG, JSON sidecars, labelled composites,
error metrics against a reference, and error-vs-time curves (CSV + PNG).

Every write is atomic (a temporary file beside the target, then ``os.replace``). :class:`ExrRows` and
:class:`PngRows` write an image band by band, top to bottom, for renders too large to hold as one film.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import struct
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from core.errors import FileFormatError, OutputError
from core.io import atomic_write_bytes, atomic_write_text

# ------------------------------------------------------------------------------------------------- EXR


def read_exr(path: str | os.PathLike[str]) -> np.ndarray:
    """An EXR file as linear RGB ``(h, w, 3)`` float32 (a luminance-only file is repeated to grey)."""
    import OpenEXR

    p = Path(path)
    if not p.is_file():
        raise FileFormatError(f"{p}: image file not found")
    try:
        with OpenEXR.File(str(p)) as f:
            ch = {k: np.asarray(v.pixels) for k, v in f.channels().items()}
    except Exception as exc:  # OpenEXR raises plain exceptions for bad files
        raise FileFormatError(f"{p}: not a readable EXR file ({exc})") from None
    if "RGB" in ch:
        img = ch["RGB"]
    elif "RGBA" in ch:
        img = ch["RGBA"][..., :3]
    elif all(k in ch for k in "RGB"):
        img = np.stack([ch["R"], ch["G"], ch["B"]], axis=-1)
    elif "Y" in ch:
        img = np.repeat(ch["Y"][..., None], 3, axis=-1)
    else:
        raise FileFormatError(f"{p}: the EXR file has no RGB or Y channels (it has {', '.join(ch)})")
    img = np.asarray(img, dtype=np.float32)
    if img.ndim != 3 or img.size == 0:
        raise FileFormatError(f"{p}: the EXR file holds no image")
    if not np.all(np.isfinite(img)):
        raise FileFormatError(f"{p}: the image holds NaN or infinite pixels")
    return img


def write_exr(
    path: str | os.PathLike[str], image: np.ndarray, metadata: Mapping[str, Any] | None = None
) -> None:
    """Write linear RGB ``(h, w, 3)`` as a 32-bit float EXR; ``metadata`` goes into a header attribute."""
    import OpenEXR

    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"cannot write '{target}': folder '{folder}' does not exist")
    header: dict[str, Any] = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    if metadata:
        header["brdf_studio"] = json.dumps(metadata, default=str)
    pixels = np.ascontiguousarray(image[..., :3], dtype=np.float32)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".exr", dir=folder)
        os.close(fd)
    except OSError as exc:
        raise OutputError(f"cannot write '{target}': {exc.strerror or exc}") from None
    try:
        OpenEXR.File(header, {"RGB": pixels}).write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes private files; an image is an ordinary file
        os.replace(tmp, target)
    except Exception as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise OutputError(f"cannot write '{target}': {exc}") from None


class _RowsFile:
    """A temporary file beside ``path`` that rows of an image are streamed into, top to bottom; it becomes
    ``path`` (``os.replace``) on :meth:`commit` once every row is written, and is deleted on :meth:`discard`
    or when the ``with`` block ends by an exception: an interrupted write leaves the previous ``path``."""

    suffix = ".tmp"

    def __init__(self, path: str | os.PathLike[str], width: int, height: int):
        self.target = Path(path)
        self.width, self.height = int(width), int(height)
        self.rows_written = 0
        folder = self.target.parent if str(self.target.parent) else Path(".")
        if not folder.is_dir():
            raise OutputError(f"cannot write '{self.target}': folder '{folder}' does not exist")
        try:
            fd, self.tmp = tempfile.mkstemp(prefix=f".{self.target.name}.", suffix=self.suffix, dir=folder)
            os.close(fd)
        except OSError as exc:
            raise OutputError(f"cannot write '{self.target}': {exc.strerror or exc}") from None
        self._done = False

    def write(self, rows: np.ndarray) -> None:
        """Append ``rows (k, width, 3)``: the next ``k`` rows of the image."""
        if rows.ndim != 3 or rows.shape[1:] != (self.width, 3):
            raise ValueError(f"rows of shape {rows.shape}; expected (k, {self.width}, 3)")
        if self.rows_written + len(rows) > self.height:
            raise ValueError(f"{self.rows_written + len(rows)} rows written to an image of {self.height}")
        try:
            self._write(rows)
        except Exception as exc:
            self.discard()
            raise OutputError(f"cannot write '{self.target}': {exc}") from None
        self.rows_written += len(rows)

    def commit(self) -> None:
        """Close the file and put it in place of ``path`` (every row must have been written)."""
        if self.rows_written != self.height:
            raise ValueError(f"{self.rows_written} of {self.height} rows written")
        try:
            self._close()
            os.chmod(self.tmp, 0o666 & ~_umask())  # mkstemp makes private files; an image is an ordinary one
            os.replace(self.tmp, self.target)
        except Exception as exc:
            self.discard()
            raise OutputError(f"cannot write '{self.target}': {exc}") from None
        self._done = True

    def discard(self) -> None:
        """Close and delete the temporary file; ``path`` is left as it was."""
        if self._done:
            return
        self._done = True
        with contextlib.suppress(Exception):
            self._close()
        with contextlib.suppress(OSError):
            os.unlink(self.tmp)

    def __enter__(self) -> _RowsFile:
        return self

    def __exit__(self, kind: object, *_: object) -> None:
        if kind is not None:
            self.discard()

    def _write(self, rows: np.ndarray) -> None:
        raise NotImplementedError

    def _close(self) -> None:
        raise NotImplementedError


class ExrRows(_RowsFile):
    """A 32-bit float RGB EXR (ZIP, scanlines in increasing y, as :func:`write_exr`) written band by band:
    OpenEXR's scanline writer (``OpenEXR.OutputFile.writePixels``) compresses each block of 16 rows as it
    arrives, so memory holds one band, never the image. ``metadata`` goes into the ``brdf_studio`` attribute."""

    suffix = ".exr"

    def __init__(
        self,
        path: str | os.PathLike[str],
        width: int,
        height: int,
        metadata: Mapping[str, Any] | None = None,
    ):
        super().__init__(path, width, height)
        import Imath
        import OpenEXR

        header = OpenEXR.Header(self.width, self.height)
        channel = Imath.Channel(Imath.PixelType(Imath.PixelType.FLOAT))
        header["channels"] = {"R": channel, "G": channel, "B": channel}
        header["compression"] = Imath.Compression(Imath.Compression.ZIP_COMPRESSION)
        if metadata:
            header["brdf_studio"] = json.dumps(metadata, default=str).encode()
        try:
            self._file = OpenEXR.OutputFile(self.tmp, header)
        except Exception as exc:
            self.discard()
            raise OutputError(f"cannot write '{self.target}': {exc}") from None

    def _write(self, rows: np.ndarray) -> None:
        planes = {
            c: np.ascontiguousarray(rows[..., k], dtype=np.float32).tobytes() for k, c in enumerate("RGB")
        }
        self._file.writePixels(planes, len(rows))

    def _close(self) -> None:
        self._file.close()


class PngRows(_RowsFile):
    """An 8-bit sRGB PNG (tone-mapped as :func:`write_png`) written band by band: each row is zlib-compressed
    as it arrives (filter type 0) and the compressed bytes go out as ``IDAT`` chunks, so memory holds one band,
    never the image."""

    suffix = ".png"

    def __init__(self, path: str | os.PathLike[str], width: int, height: int, exposure: float = 0.0):
        super().__init__(path, width, height)
        import zlib

        self.exposure = exposure
        self._zip = zlib.compressobj(6)
        self._fh = open(self.tmp, "wb")  # noqa: SIM115 - closed by commit or discard
        ihdr = struct.pack(">IIBBBBB", self.width, self.height, 8, 2, 0, 0, 0)  # 8-bit RGB, no interlace
        self._fh.write(b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr))

    def _write(self, rows: np.ndarray) -> None:
        rgb8 = rows if rows.dtype == np.uint8 else tonemap(rows, self.exposure)
        lines = np.zeros((len(rgb8), 1 + 3 * self.width), dtype=np.uint8)  # a filter byte (0) per row
        lines[:, 1:] = rgb8.reshape(len(rgb8), -1)
        data = self._zip.compress(lines.tobytes())
        if data:
            self._fh.write(_png_chunk(b"IDAT", data))

    def _close(self) -> None:
        if self._fh.closed:
            return
        if self.rows_written == self.height:
            self._fh.write(_png_chunk(b"IDAT", self._zip.flush()) + _png_chunk(b"IEND", b""))
            self._fh.flush()
            os.fsync(self._fh.fileno())
        self._fh.close()


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    import zlib

    return (
        struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    )


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# ------------------------------------------------------------------------------------------------- PNG


def tonemap(image: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear RGB to 8-bit sRGB ``(h, w, 3)`` uint8: scale by ``2**exposure``, clip, sRGB transfer curve."""
    x = np.clip(np.nan_to_num(image[..., :3] * (2.0**exposure), nan=0.0, posinf=1.0), 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.round(srgb * 255.0).astype(np.uint8)


def png_bytes(rgb8: np.ndarray) -> bytes:
    from matplotlib.image import imsave

    buf = io.BytesIO()
    imsave(buf, rgb8, format="png")
    return buf.getvalue()


def write_png(path: str | os.PathLike[str], image: np.ndarray, exposure: float = 0.0) -> None:
    """Tone-mapped sRGB PNG of a linear image (uint8 input is written as is)."""
    rgb8 = image if image.dtype == np.uint8 else tonemap(image, exposure)
    atomic_write_bytes(path, png_bytes(rgb8))


def write_sidecar(path: str | os.PathLike[str], info: Mapping[str, Any]) -> None:
    atomic_write_text(path, json.dumps(info, indent=2, default=str) + "\n")


# ------------------------------------------------------------------------------------------- composite

# A 5x7 bitmap font for labels (digits, letters, a few signs): no font files or extra packages needed.
_GLYPHS = {
    "A": "01110 10001 10001 11111 10001 10001 10001",
    "B": "11110 10001 10001 11110 10001 10001 11110",
    "C": "01110 10001 10000 10000 10000 10001 01110",
    "D": "11110 10001 10001 10001 10001 10001 11110",
    "E": "11111 10000 10000 11110 10000 10000 11111",
    "F": "11111 10000 10000 11110 10000 10000 10000",
    "G": "01110 10001 10000 10111 10001 10001 01111",
    "H": "10001 10001 10001 11111 10001 10001 10001",
    "I": "01110 00100 00100 00100 00100 00100 01110",
    "J": "00111 00010 00010 00010 00010 10010 01100",
    "K": "10001 10010 10100 11000 10100 10010 10001",
    "L": "10000 10000 10000 10000 10000 10000 11111",
    "M": "10001 11011 10101 10101 10001 10001 10001",
    "N": "10001 10001 11001 10101 10011 10001 10001",
    "O": "01110 10001 10001 10001 10001 10001 01110",
    "P": "11110 10001 10001 11110 10000 10000 10000",
    "Q": "01110 10001 10001 10001 10101 10010 01101",
    "R": "11110 10001 10001 11110 10100 10010 10001",
    "S": "01111 10000 10000 01110 00001 00001 11110",
    "T": "11111 00100 00100 00100 00100 00100 00100",
    "U": "10001 10001 10001 10001 10001 10001 01110",
    "V": "10001 10001 10001 10001 10001 01010 00100",
    "W": "10001 10001 10001 10101 10101 10101 01010",
    "X": "10001 10001 01010 00100 01010 10001 10001",
    "Y": "10001 10001 01010 00100 00100 00100 00100",
    "Z": "11111 00001 00010 00100 01000 10000 11111",
    "0": "01110 10001 10011 10101 11001 10001 01110",
    "1": "00100 01100 00100 00100 00100 00100 01110",
    "2": "01110 10001 00001 00010 00100 01000 11111",
    "3": "11111 00010 00100 00010 00001 10001 01110",
    "4": "00010 00110 01010 10010 11111 00010 00010",
    "5": "11111 10000 11110 00001 00001 10001 01110",
    "6": "00110 01000 10000 11110 10001 10001 01110",
    "7": "11111 00001 00010 00100 01000 01000 01000",
    "8": "01110 10001 10001 01110 10001 10001 01110",
    "9": "01110 10001 10001 01111 00001 00010 01100",
    ".": "00000 00000 00000 00000 00000 01100 01100",
    ",": "00000 00000 00000 00000 01100 00100 01000",
    ":": "00000 01100 01100 00000 01100 01100 00000",
    "=": "00000 00000 11111 00000 11111 00000 00000",
    "-": "00000 00000 00000 11111 00000 00000 00000",
    "+": "00000 00100 00100 11111 00100 00100 00000",
    "/": "00001 00010 00010 00100 01000 01000 10000",
    "(": "00010 00100 01000 01000 01000 00100 00010",
    ")": "01000 00100 00010 00010 00010 00100 01000",
    "_": "00000 00000 00000 00000 00000 00000 11111",
    "%": "11000 11001 00010 00100 01000 10011 00011",
    " ": "00000 00000 00000 00000 00000 00000 00000",
}


def draw_text(img: np.ndarray, text: str, x: int, y: int, scale: int = 2, color: int = 255) -> None:
    """Draw ``text`` (upper-cased; unknown characters as blanks) into uint8 ``img`` at pixel ``(x, y)``."""
    h, w = img.shape[:2]
    for k, ch in enumerate(text.upper()):
        rows = _GLYPHS.get(ch, _GLYPHS[" "]).split()
        for r, row in enumerate(rows):
            for c, bit in enumerate(row):
                if bit == "1":
                    y0, x0 = y + r * scale, x + (k * 6 + c) * scale
                    if y0 + scale <= h and x0 + scale <= w and y0 >= 0 and x0 >= 0:
                        img[y0 : y0 + scale, x0 : x0 + scale] = color


def composite(images: Sequence[np.ndarray], labels: Sequence[str], exposure: float = 0.0) -> np.ndarray:
    """Tone-mapped images side by side, each with its label on a dark band above it; uint8 ``(h, W, 3)``."""
    if not images:
        raise ValueError("nothing to compose")
    tiles = [tonemap(im, exposure) for im in images]
    h = max(t.shape[0] for t in tiles)
    scale = 2 if h >= 128 else 1
    band = 7 * scale + 6
    gap = 4
    width = sum(t.shape[1] for t in tiles) + gap * (len(tiles) - 1)
    out = np.full((h + band, width, 3), 24, dtype=np.uint8)
    x = 0
    for tile, label in zip(tiles, labels, strict=True):
        out[band : band + tile.shape[0], x : x + tile.shape[1]] = tile
        max_chars = max(1, tile.shape[1] // (6 * scale) - 1)
        draw_text(out, label[:max_chars], x + 3, 3, scale=scale)
        x += tile.shape[1] + gap
    return out


# ---------------------------------------------------------------------------------------------- errors


def image_errors(image: np.ndarray, reference: np.ndarray) -> dict[str, float]:
    """RMSE and relMSE of ``image`` against ``reference`` (both linear ``(h, w, 3)``).

    ``rmse = sqrt(mean((x - r)^2))`` over pixels and channels; ``relmse = mean((x - r)^2 / (r^2 + 1e-2))``
    (the small constant keeps black pixels from dominating, as is customary).
    """
    if image.shape != reference.shape:
        raise FileFormatError(
            f"the reference image is {reference.shape[1]}x{reference.shape[0]} but the render is "
            f"{image.shape[1]}x{image.shape[0]}; render at the reference's size"
        )
    d = image.astype(np.float64) - reference.astype(np.float64)
    return {
        "rmse": float(np.sqrt(np.mean(d * d))),
        "relmse": float(np.mean(d * d / (reference.astype(np.float64) ** 2 + 1e-2))),
    }


def write_error_curves(
    stem: str | os.PathLike[str], curves: Mapping[str, Sequence[Mapping[str, float]]], title: str = ""
) -> tuple[Path, Path]:
    """Write ``stem.csv`` (strategy, spp, seconds, rmse, relmse) and ``stem.png`` (RMSE vs time, log-log).

    ``curves`` maps a strategy name to its records (dicts with keys ``spp``, ``seconds``, ``rmse``, ``relmse``).
    """
    stem = Path(stem)
    csv_path = stem.with_suffix(".csv")
    png_path = stem.with_suffix(".png")
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["strategy", "spp", "seconds", "rmse", "relmse"])
    for name, recs in curves.items():
        for r in recs:
            w.writerow([name, int(r["spp"]), f"{r['seconds']:.4f}", f"{r['rmse']:.6g}", f"{r['relmse']:.6g}"])
    atomic_write_text(csv_path, buf.getvalue())

    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 4), dpi=100)
    ax = fig.add_subplot(1, 1, 1)
    for name, recs in curves.items():
        pts = [(r["seconds"], r["rmse"]) for r in recs if r["seconds"] > 0 and r["rmse"] > 0]
        if pts:
            ax.loglog(*zip(*pts, strict=True), marker="o", ms=3, label=name)
    ax.set_xlabel("render time (s)")
    ax.set_ylabel("RMSE vs reference")
    ax.set_title(title or "error vs time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    buf2 = io.BytesIO()
    fig.savefig(buf2, format="png")
    atomic_write_bytes(png_path, buf2.getvalue())
    return csv_path, png_path
