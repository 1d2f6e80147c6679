"""Sample sets of the current material and direction, written as CSV, NPY or PLY (no Qt).

Columns: ``x y z`` (the sampled ``wi`` in the local frame, z = normal), ``pdf`` (per unit solid angle) and
the luminance weight ``f cos / pdf`` (0 where the pdf is 0). The PLY is an ASCII point cloud on the
hemisphere that MeshLab and ParaView open (``pdf`` and ``weight`` as extra vertex properties).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from core.brdf import BRDF, luminance
from core.errors import OutputError
from core.io import atomic_write_bytes
from core.sampling import make_sampler

COLUMNS = ("x", "y", "z", "pdf", "weight")


def sample_set(brdf: BRDF, wo: np.ndarray, sampler: str, n: int, seed: int = 0, **options) -> np.ndarray:
    """``(n, 5)`` rows ``x, y, z, pdf, weight`` from the named strategy."""
    s = make_sampler(sampler, brdf, **options)
    batch = s.sample(np.asarray(wo, dtype=np.float64), int(n), seed)
    wi, pdf = batch.wi, batch.pdf
    fcos = luminance(batch.f) * np.maximum(wi[:, 2], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(pdf > 0, fcos / pdf, 0.0)
    return np.column_stack([wi, pdf, weight])


def write_sample_set(path: str | Path, rows: np.ndarray) -> Path:
    """Write rows of :func:`sample_set`; the format follows the suffix (``.csv``, ``.npy``, ``.ply``)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        buf = io.StringIO()
        np.savetxt(buf, rows, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.9g")
        data = buf.getvalue().encode()
    elif suffix == ".npy":
        buf = io.BytesIO()
        np.save(buf, rows)
        data = buf.getvalue()
    elif suffix == ".ply":
        head = [
            "ply", "format ascii 1.0", "comment BRDF Studio sample set: wi in the local frame, z = normal",
            f"element vertex {len(rows)}", "property float x", "property float y", "property float z",
            "property float pdf", "property float weight", "end_header",
        ]  # fmt: skip
        body = "\n".join(" ".join(f"{v:.7g}" for v in r) for r in rows)
        data = ("\n".join(head) + "\n" + body + "\n").encode()
    else:
        raise OutputError(f"cannot write a sample set as '{suffix or path.name}': use .csv, .npy or .ply")
    atomic_write_bytes(path, data)
    return path
