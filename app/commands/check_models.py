"""``brdf-studio check-models DIR``: every BRDF Explorer ``.brdf`` file of a folder, imported and checked.

For each ``*.brdf`` file (sorted by name): it opens (``core.glsl``: read and compiled), and its values at the
default parameters agree with the shader itself run by Mesa's software OpenGL (:mod:`app.shader_oracle`) over
a grid of direction pairs, L and V both in the upper hemisphere: polar angles from 0 to 89 degrees, azimuths all
round. Agreement is within 1e-5 relative plus what float32 rounding can change (``docs/model-files.md``, "How
imported shaders are checked"); NaN must meet NaN. A file that agrees is then sampled: both adaptive samplers
pass ``brdf-studio check``'s tests on it (:func:`sampler_check`; ``--samples 0`` leaves them out). Files that only visualise (parameters named ``show_*``, as
BRDF Explorer's showAngles and showVectors) are refused and counted apart.

Prints a table and a summary line; ``--csv OUT`` writes the table. Exit status 0 when every file that is not
refused passes, 1 when any fails, 2 for bad arguments (a missing folder, a folder without ``.brdf`` files).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from app.commands._args import check_output, whole
from core.errors import FileFormatError

DEFAULT_POLAR_ANGLES = 7
MAX_POLAR_ANGLES = 16
LAST_POLAR_ANGLE = 89.0
"""The grid's most grazing angle, in degrees (90 itself is the horizon, where the host returns 0)."""
VISUALISATION_PREFIX = "show_"
REFUSED = "refused (visualisation only)"


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "check-models",
        help="check every .brdf file of a folder: it opens, and agrees with the shader run by Mesa",
    )
    p.add_argument("dir", type=Path, metavar="DIR", help="a folder of BRDF Explorer .brdf files")
    p.add_argument(
        "--grid",
        type=whole(2, MAX_POLAR_ANGLES),
        default=DEFAULT_POLAR_ANGLES,
        metavar="N",
        help=f"N polar angles from 0 to {LAST_POLAR_ANGLE:g} degrees and 2(N-1) azimuths "
        f"(default {DEFAULT_POLAR_ANGLES}: every 15 and 30 degrees), all ordered pairs of them",
    )
    p.add_argument(
        "--samples",
        type=whole(0, 10**8),
        default=DEFAULT_SAMPLES,
        metavar="N",
        help=f"samples per chi-square test of the adaptive samplers (default {DEFAULT_SAMPLES:g}; 0: no "
        "sampler check)",
    )
    p.add_argument("--csv", type=Path, metavar="OUT", help="also write the table to this CSV file")
    return ["check-models"]


def direction_grid(polar_angles: int) -> np.ndarray:
    """Upper-hemisphere unit vectors ``(m, 3)``: ``polar_angles`` angles ``90 k / (N - 1)`` degrees with the
    last one ``LAST_POLAR_ANGLE``, each but 0 at ``2 (N - 1)`` azimuths from 0."""
    thetas = np.radians(np.r_[np.linspace(0.0, 90.0, polar_angles)[:-1], LAST_POLAR_ANGLE])
    phis = np.radians(np.arange(2 * (polar_angles - 1)) * 180.0 / (polar_angles - 1))
    t, p = np.meshgrid(thetas[1:], phis, indexing="ij")
    sin_t = np.sin(t.ravel())
    tilted = np.stack([sin_t * np.cos(p.ravel()), sin_t * np.sin(p.ravel()), np.cos(t.ravel())], axis=1)
    return np.vstack([[0.0, 0.0, 1.0], tilted])


def direction_pairs(polar_angles: int) -> tuple[np.ndarray, np.ndarray]:
    """Every ordered pair ``(L, V)`` of :func:`direction_grid`, each ``(m*m, 3)``."""
    w = direction_grid(polar_angles)
    return np.repeat(w, len(w), axis=0), np.tile(w, (len(w), 1))


ADAPTIVE_SAMPLERS = ("adaptive_exact", "adaptive_warp")
SAMPLER_THETAS = (0.0, 30.0, 60.0, 80.0, 89.0)
"""The outgoing polar angles of the samplers' check, as ``brdf-studio check`` takes them by default."""
SAMPLER_PHI = 17.0
DEFAULT_SAMPLES = 100_000
SAMPLER_TESTS_PER_FILE = 2 * len(ADAPTIVE_SAMPLERS) * len(SAMPLER_THETAS)
"""Chi-square tests per file: both adaptive samplers x each angle x sphere and disk."""


@dataclass
class SamplerCheck:
    """The adaptive samplers' check of one model: passed, and the reasons of the rows that failed."""

    passed: bool
    reasons: list[str]


def sampler_check(path: Path, samples: int = DEFAULT_SAMPLES, n_tests: int = SAMPLER_TESTS_PER_FILE,
                  seed: int = 1) -> SamplerCheck:  # fmt: skip
    """``brdf-studio check`` of both adaptive samplers (``n_max`` 2) on the model of ``path`` at its defaults:
    at each of :data:`SAMPLER_THETAS`, chi-square on the sphere and on the disk with ``samples`` samples
    (alpha = 0.01 Sidak-corrected over ``n_tests``: the caller's whole run), the pdf's integral, the acceptance
    and the leaf bounds. Called for each file that opens and agrees with Mesa."""
    from app.commands.check import validate
    from core.brdf import make_brdf
    from core.sampling import make_sampler

    brdf = make_brdf(str(path), {})
    reasons: list[str] = []
    for strategy in ADAPTIVE_SAMPLERS:
        sampler = make_sampler(strategy, brdf, n_max=2.0)
        for theta in SAMPLER_THETAS:
            row = validate(sampler, theta, SAMPLER_PHI, samples, n_tests, seed)
            reasons += [f"{strategy} at theta {theta:g}: {why}" for why in row.get("reasons", [])]
    return SamplerCheck(not reasons, reasons)


@dataclass
class ModelCheck:
    """One row of the table."""

    file: str
    opens: bool
    verdict: str
    message: str = ""
    max_rel_error: float = math.nan
    worst_ratio: float = math.nan
    values: int = 0
    nan_both: int = 0
    nan_by_rounding: int = 0
    nan_ours_only: int = 0
    nan_mesa_only: int = 0
    samplers: bool | None = None

    @property
    def failed(self) -> bool:
        return self.verdict == "FAIL"

    def csv_row(self) -> dict[str, Any]:
        return {
            "file": self.file,
            "opens": self.opens,
            "verdict": self.verdict,
            "max_rel_error": self.max_rel_error,
            "worst_error_over_allowed": self.worst_ratio,
            "values": self.values,
            "nan_both": self.nan_both,
            "nan_by_rounding": self.nan_by_rounding,
            "nan_ours_only": self.nan_ours_only,
            "nan_mesa_only": self.nan_mesa_only,
            "samplers": "" if self.samplers is None else self.samplers,
            "message": self.message,
        }


def check_model(path: Path, L: np.ndarray, V: np.ndarray, samples: int = 0, n_tests: int = 1) -> ModelCheck:
    """Open ``path``, evaluate it and Mesa on the pairs ``(L, V)`` at its defaults, compare; then, with
    ``samples``, check the adaptive samplers on it (:func:`sampler_check`, Sidak over ``n_tests``)."""
    from app.float32_agreement import agreement_with_oracle
    from app.shader_oracle import MesaShaderError, version_line
    from core.errors import BrdfStudioError
    from core.glsl import compile_brdf, read_brdf_file

    row = ModelCheck(file=path.name, opens=False, verdict="FAIL")
    try:
        brdf = read_brdf_file(path)
        if any(p.name.startswith(VISUALISATION_PREFIX) for p in brdf.params):
            names = ", ".join(p.name for p in brdf.params if p.name.startswith(VISUALISATION_PREFIX))
            row.verdict, row.message = REFUSED, f"it shows angles or vectors ({names}), not a BRDF"
            return row
        compiled = compile_brdf(brdf)
    except BrdfStudioError as error:
        row.message = str(error)
        return row
    except Exception as error:  # a defect of the importer, reported as this file's failure
        row.message = f"internal error: {type(error).__name__}: {error}"
        return row
    row.opens = True
    params = [(p.kind, p.name, p.default) for p in brdf.params]
    try:
        agreement = agreement_with_oracle(
            compiled.evaluate,
            brdf.shader,
            params,
            L,
            V,
            source_name=str(path),
            first_line=brdf.shader_line,
        )
    except MesaShaderError as error:
        row.message = str(error).replace(":\n", ": ", 1).replace("\n", "; ")
        return row
    row.max_rel_error = agreement.max_rel_error
    row.worst_ratio = agreement.worst_ratio
    row.values = agreement.values
    row.nan_both = agreement.nan_both
    row.nan_by_rounding = agreement.nan_by_rounding
    row.nan_ours_only = agreement.nan_ours_only
    row.nan_mesa_only = agreement.nan_mesa_only
    if not agreement.passed:
        beyond = agreement.failures - agreement.nan_ours_only - agreement.nan_mesa_only
        problems = [f"{agreement.failures} of {agreement.values} values disagree"]
        if beyond:
            problems.append(
                f"{beyond} beyond the allowed error (the worst {agreement.worst_ratio:.3g} times it)"
            )
        for count, side in ((agreement.nan_mesa_only, "Mesa"), (agreement.nan_ours_only, "ours")):
            if count:
                problems.append(f"{count} NaN in {side} only, not from rounding")
        row.message = "; ".join(problems)
        return row
    if samples:
        try:
            check = sampler_check(path, samples, n_tests)
        except BrdfStudioError as error:
            check = SamplerCheck(False, [str(error)])
        row.samplers = check.passed
        if not check.passed:
            row.message = "the adaptive samplers fail their check: " + "; ".join(check.reasons)
    row.verdict = "FAIL" if row.samplers is False else "pass"
    if row.samplers is not False and version_line(brdf.shader):
        row.message = (
            "note: its '#version' line is left out for Mesa: GLSL takes one only on the program's first line, "
            "which holds BRDF Explorer's own"
        )
    return row


def _fmt(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.2g}"


def print_table(rows: list[ModelCheck]) -> None:
    with_samplers = any(r.samplers is not None for r in rows)
    width = max([len("file"), *(len(r.file) for r in rows)])
    header = f"{'file':<{width}}  opens  max rel err  err/allowed  NaN both/rounding/ours/Mesa"
    header += "  samplers" if with_samplers else ""
    print(header + "  verdict")
    for r in rows:
        refused = r.verdict == REFUSED
        nans = (
            "-"
            if refused or not r.values
            else f"{r.nan_both}/{r.nan_by_rounding}/{r.nan_ours_only}/{r.nan_mesa_only}"
        )
        line = (
            f"{r.file:<{width}}  {('yes' if r.opens else ('-' if refused else 'no')):<5}  "
            f"{_fmt(r.max_rel_error):<11}  {_fmt(r.worst_ratio):<11}  {nans:<27}"
        )
        if with_samplers:
            line += f"  { ({True: 'pass', False: 'FAIL', None: '-'}[r.samplers]):<8}"
        print(f"{line}  {r.verdict}")
        if r.message:
            print(f"    {r.message}")


def run(args: argparse.Namespace) -> int:
    folder: Path = args.dir
    if not folder.is_dir():
        raise FileFormatError(
            f"{folder}: {'not a folder' if folder.exists() else 'no such folder'} (expected a folder of .brdf files)"
        )
    files = sorted(folder.glob("*.brdf"))
    if not files:
        raise FileFormatError(f"{folder}: no .brdf files in this folder")
    if args.csv is not None:
        check_output(args.csv)

    from app.float32_agreement import ABSOLUTE_FLOOR, RELATIVE_TOLERANCE, ULPS
    from app.shader_oracle import shader_oracle

    oracle = shader_oracle()  # no software OpenGL: one clear line before any work
    L, V = direction_pairs(args.grid)
    n_dirs = len(direction_grid(args.grid))
    print(f"Mesa: {oracle.renderer}; OpenGL {oracle.version}")
    print(
        f"grid: {args.grid} polar angles (0 to {LAST_POLAR_ANGLE:g} degrees) x {2 * (args.grid - 1)} azimuths, "
        f"{n_dirs} directions, {len(L)} pairs (L, V); default parameters"
    )
    print(
        f"agreement: |ours - Mesa| <= {RELATIVE_TOLERANCE:g} max(|ours|, |Mesa|) + float32 rounding bound "
        f"({ULPS} ulps per computed quantity) + {ABSOLUTE_FLOOR:.2g}; NaN against NaN, or on one side "
        "where rounding makes it\n"
    )
    n_tests = SAMPLER_TESTS_PER_FILE * len(files)
    if args.samples:
        print(
            f"samplers: {' and '.join(ADAPTIVE_SAMPLERS)} (n_max 2) at theta {', '.join(f'{t:g}' for t in SAMPLER_THETAS)}: "
            f"chi-square on sphere and disk, {args.samples:g} samples, alpha = 0.01 Sidak-corrected over {n_tests} "
            "tests; pdf integral, acceptance, leaf bounds\n"
        )
    from tqdm import tqdm

    rows = []
    with tqdm(files, unit="file", disable=None, leave=False) as bar:  # (shown on a terminal only)
        for path in bar:
            bar.set_description(path.name)
            rows.append(check_model(path, L, V, args.samples, n_tests))
    print_table(rows)
    passed = sum(r.verdict == "pass" for r in rows)
    failed = sum(r.failed for r in rows)
    refused = sum(r.verdict == REFUSED for r in rows)
    print(
        f"\n{len(rows)} files: {passed} pass, {failed} {'FAIL' if failed else 'fail'}, "
        f"{refused} refused (visualisation only)"
    )
    if args.csv is not None:
        from core.io import write_csv_rows

        write_csv_rows(args.csv, [r.csv_row() for r in rows])
        print(f"table: {args.csv}")
    return 1 if failed else 0
