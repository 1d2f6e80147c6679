"""``brdf-studio sample``: draw directions from a sampler and write them with their pdf and weight.

Output columns: ``x y z`` (the direction ``wi`` in the local frame, z = normal), ``pdf`` (per unit solid angle)
and ``weight = f cos(theta_i) / pdf`` (luminance of ``f_r``). Formats by extension: ``.csv`` (with a header),
``.npy`` (an ``(n, 5)`` float64 array) and ``.ply`` (an ASCII point cloud on the hemisphere with the vertex
properties ``pdf`` and ``weight``, which MeshLab and ParaView open). Files are written atomically.
"""

from __future__ import annotations

import argparse
import io
import shutil
from pathlib import Path

import numpy as np

from app.commands._args import azimuth, check_output, name, number, seed, theta, whole
from app.commands.eval import add_brdf_arguments, brdf_from_args
from core.brdf import LUMINANCE
from core.budget import BudgetError, format_bytes, round_down
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.io import atomic_write
from core.sampling import make_sampler

FORMATS = (".csv", ".npy", ".ply")
CHUNK = 1 << 20
"""Directions drawn and written at a time: any ``-n`` needs the memory of one chunk (~0.3 GiB at most)."""
BYTES_PER_ROW = {".npy": 40, ".csv": 120, ".ply": 70}
"""Upper bounds of a row's size in each format (``%.17g`` text for csv, ``%.9g`` for ply)."""
MAX_SAMPLES = 10**15


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser("sample", help="draw sample directions from a sampler and write them (csv, npy, ply)")
    add_brdf_arguments(p)
    add_sampler_arguments(p)
    p.add_argument("--theta", type=theta, required=True, metavar="DEG", help="outgoing polar angle, [0, 90]")
    p.add_argument("--phi", type=azimuth, default=0.0, metavar="DEG", help="outgoing azimuth (default 0)")
    p.add_argument(
        "-n", "--samples", type=whole(1, MAX_SAMPLES), required=True, metavar="N", help="number of directions"
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output file: .csv, .npy or .ply")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default 0)")
    return ["sample"]


def add_sampler_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--sampler",
        type=name,
        default="adaptive_exact",
        metavar="S",
        help="sampling strategy (default adaptive_exact)",
    )
    p.add_argument(
        "--n-max",
        type=number(1.0, 1000.0, lo_open=True),
        default=None,
        metavar="X",
        help="adaptive: mean trials target, (1, 1000]",
    )


def sampler_options(args: argparse.Namespace) -> dict:
    return {} if args.n_max is None else {"n_max": args.n_max}


def sample_table(sampler, wo: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``(n, 5)``: x, y, z, pdf, weight."""
    batch = sampler.sample(wo, n, seed)
    wi, pdf = batch.wi, batch.pdf
    f = batch.f @ LUMINANCE
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(pdf > 0.0, f * np.maximum(wi[:, 2], 0.0) / pdf, 0.0)
    return np.column_stack([wi, pdf, weight])


def chunk_seed(seed: int, k: int) -> int:
    """The seed of chunk ``k``: ``seed`` itself for the first (so a small request is one draw with ``seed``),
    independent streams for the others."""
    if k == 0:
        return seed
    return int(np.random.SeedSequence([seed, k]).generate_state(1, np.uint64)[0] >> np.uint64(1))


def header(n: int, suffix: str) -> bytes:
    """What precedes the rows of an ``n``-row file."""
    if suffix == ".npy":
        buf = io.BytesIO()
        np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (n, 5)})
        return buf.getvalue()  # the magic string and the header
    if suffix == ".csv":
        return b"x,y,z,pdf,weight\n"
    return (
        "ply\nformat ascii 1.0\ncomment BRDF Studio sample directions (local frame, z = normal)\n"
        f"element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float pdf\nproperty float weight\nend_header\n"
    ).encode()


def rows(table: np.ndarray, suffix: str) -> bytes:
    """The rows of ``table (m, 5)`` in the format of ``suffix``."""
    if suffix == ".npy":
        return np.ascontiguousarray(table, dtype="<f8").tobytes()
    buf = io.StringIO()
    if suffix == ".csv":
        np.savetxt(buf, table, delimiter=",", fmt="%.17g")
    else:
        np.savetxt(buf, table, fmt="%.9g")
    return buf.getvalue().encode()


def encode(table: np.ndarray, suffix: str) -> bytes:
    """A whole file holding ``table (n, 5)``."""
    return header(len(table), suffix) + rows(table, suffix)


def _check_output(path: Path, suffix: str, n: int) -> None:
    if suffix not in FORMATS:
        raise ParameterError(f"output '{path}' must end in one of {', '.join(FORMATS)}")
    check_output(path)
    folder = path.parent if str(path.parent) else Path(".")
    need = n * BYTES_PER_ROW[suffix]
    free = shutil.disk_usage(folder).free
    if need > free:
        fits = free // BYTES_PER_ROW[suffix]
        advice = f"use -n {round_down(fits)} or fewer" if fits >= 1 else "free some space or write elsewhere"
        raise BudgetError(
            f"{n:.3g} directions as {suffix} need up to {format_bytes(need)} of disk; '{folder}' has "
            f"{format_bytes(free)} free; {advice}"
        )


def run(args: argparse.Namespace) -> int:
    out = Path(args.output)
    suffix = out.suffix.lower()
    n = int(args.samples)
    _check_output(out, suffix, n)
    brdf = brdf_from_args(args)
    sampler = make_sampler(args.sampler, brdf, **sampler_options(args))
    wo = degrees_to_dir(args.theta, args.phi)
    total = total_sq = 0.0
    from tqdm import tqdm

    with (
        atomic_write(out, "wb") as fh,
        tqdm(total=n, unit="dir", disable=n <= CHUNK or None, desc="sample") as bar,
    ):
        fh.write(header(n, suffix))
        for k, start in enumerate(range(0, n, CHUNK)):
            table = sample_table(sampler, wo, min(CHUNK, n - start), chunk_seed(args.seed, k))
            fh.write(rows(table, suffix))
            w = table[:, 4]
            total += float(w.sum())
            total_sq += float(np.dot(w, w))
            bar.update(len(table))
    mean = total / n
    var = max(0.0, total_sq / n - mean * mean)
    spread = f"relative std {np.sqrt(var) / mean:.3g}" if mean > 0 else "every weight 0"
    print(f"wrote {n} directions to {args.output} (weight mean {mean:.6g}, {spread})")
    return 0
