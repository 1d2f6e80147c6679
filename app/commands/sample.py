"""``brdf-studio sample``: draw directions from a sampler and write them with their pdf and weight.

Output columns: ``x y z`` (the direction ``wi`` in the local frame, z = normal), ``pdf`` (per unit solid angle)
and ``weight = f cos(theta_i) / pdf`` (luminance of ``f_r``). Formats by extension: ``.csv`` (with a header),
``.npy`` (an ``(n, 5)`` float64 array) and ``.ply`` (an ASCII point cloud on the hemisphere with the vertex
properties ``pdf`` and ``weight``, which MeshLab and ParaView open). Files are written atomically.
"""

from __future__ import annotations

import argparse
import io
import math
from pathlib import Path

import numpy as np

from app.commands.eval import add_brdf_arguments, brdf_from_args
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.io import atomic_write_bytes
from core.model import LUMINANCE
from core.sampling import make_sampler

FORMATS = (".csv", ".npy", ".ply")


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser("sample", help="draw sample directions from a sampler and write them (csv, npy, ply)")
    add_brdf_arguments(p)
    add_sampler_arguments(p)
    p.add_argument("--theta", type=float, required=True, metavar="DEG", help="outgoing polar angle, [0, 90]")
    p.add_argument("--phi", type=float, default=0.0, metavar="DEG", help="outgoing azimuth (default 0)")
    p.add_argument("-n", "--samples", type=int, required=True, metavar="N", help="number of directions")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output file: .csv, .npy or .ply")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    return ["sample"]


def add_sampler_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sampler", default="adaptive", metavar="S", help="sampling strategy (default adaptive)")
    p.add_argument(
        "--n-max", type=float, default=None, metavar="X", help="adaptive: mean trials target (> 1)"
    )


def sampler_options(args: argparse.Namespace) -> dict:
    return {} if args.n_max is None else {"n_max": args.n_max}


def check_theta(theta: float) -> float:
    if not math.isfinite(theta) or not (0.0 <= theta <= 90.0):
        raise ParameterError(f"--theta must be an angle in [0, 90] degrees, got {theta:g}")
    return theta


def sample_table(sampler, wo: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``(n, 5)``: x, y, z, pdf, weight."""
    batch = sampler.sample(wo, n, seed)
    wi, pdf = batch.wi, batch.pdf
    f = batch.f @ LUMINANCE
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(pdf > 0.0, f * np.maximum(wi[:, 2], 0.0) / pdf, 0.0)
    return np.column_stack([wi, pdf, weight])


def encode(table: np.ndarray, suffix: str) -> bytes:
    if suffix == ".npy":
        buf = io.BytesIO()
        np.save(buf, table)
        return buf.getvalue()
    if suffix == ".csv":
        buf = io.StringIO()
        np.savetxt(buf, table, delimiter=",", header="x,y,z,pdf,weight", comments="", fmt="%.17g")
        return buf.getvalue().encode()
    head = (
        "ply\nformat ascii 1.0\ncomment BRDF Studio sample directions (local frame, z = normal)\n"
        f"element vertex {len(table)}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float pdf\nproperty float weight\nend_header\n"
    )
    buf = io.StringIO()
    np.savetxt(buf, table, fmt="%.9g")
    return (head + buf.getvalue()).encode()


def run(args: argparse.Namespace) -> int:
    suffix = Path(args.output).suffix.lower()
    if suffix not in FORMATS:
        raise ParameterError(f"output '{args.output}' must end in one of {', '.join(FORMATS)}")
    check_theta(args.theta)
    if not math.isfinite(args.phi):
        raise ParameterError("--phi must be a finite angle in degrees")
    if args.samples <= 0:
        raise ParameterError(f"-n must be a positive number of samples, got {args.samples}")
    brdf = brdf_from_args(args)
    sampler = make_sampler(args.sampler, brdf, **sampler_options(args))
    table = sample_table(sampler, degrees_to_dir(args.theta, args.phi), args.samples, args.seed)
    atomic_write_bytes(args.output, encode(table, suffix))
    w = table[:, 4]
    spread = f"relative std {float(np.std(w) / np.mean(w)):.3g}" if np.mean(w) > 0 else "every weight 0"
    print(f"wrote {len(table)} directions to {args.output} (weight mean {np.mean(w):.6g}, {spread})")
    return 0
