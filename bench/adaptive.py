"""The adaptive sampler against its targets, side by side in one run: build, throughput with ``f``, error.

    .venv/bin/python bench/adaptive.py [--models phong,ward,merl] [--quick] [--runs 3] [--out results/bench]
                                       [--option warp_chi2=0.2 ...]

Cases: every isotropic model at its default parameters, the synthetic measured material
``resources/materials/red_plastic_ct.binary`` (model ``merl``), the two anisotropic cases of the targets (Ward
``sx = 0.05, sy = 0.25``; Ashikhmin-Shirley ``nu = 10, nv = 200``) and the other anisotropic models at their
defaults. ``--models`` keeps the cases of the named models; ``--option K=V`` sets an adaptive table option
(:class:`~core.sampling.adaptive.TableOptions`) for both modes' tables and samplers.

1. **Build**, one row per mode: each mode builds its own table, the exact mode's (``adaptive``,
   ``TableOptions()``: with the rejection bounds) and the rejection-free mode's (``adaptive_warp``,
   ``TableOptions(bounds=False)``: without the bounds' refinement and probes). A material's whole table
   (:func:`core.sampling.adaptive.table.build_table`) on one core, with no disk cache and the in-memory
   tables cleared before each run; best of ``--runs`` (the modes alternate, so a change of machine load hits
   them alike). Memory, trees, leaves per tree and the table's own checks come from the same build: the
   least acceptance (exact mode only: a warp table has no bounds), the rejection-free density's largest
   chi^2 at a cell's edge, and the normalizer's estimated error (exact mode only: the warp mode draws
   without the normalizer). The sampler's own build (``make_sampler(..., cache=False).preload()`` after
   :func:`~core.sampling.adaptive.clear_memory_cache`: all cores, the one a render gets) is reported beside
   it, with whether its table has the one-core build's leaves. The targets are judged for each mode's row.
2. **Throughput, f included**: ``VIEWS`` outgoing directions drawn as a render meets them (``cos theta_o``
   distributed as ``cos``, ``phi_o`` uniform, fixed seed), interleaved over ``SAMPLES`` rows each (row ``r``
   has view ``r mod VIEWS``, as consecutive rows of a render have different views), one ``sample_each`` call
   over all rows per sampler, best of ``--runs`` (the samplers alternate, so a change of machine load hits
   them alike); compilation and the table's build are not counted. ``cosine`` returns ``f`` as every
   sampler does: it is "cosine sampling plus one evaluation", the reference of the target ratio.
3. **Error**, from the same batches: the furnace weight ``w = lum(f) cos / pdf`` per view (its relative
   standard deviation: 0 up to rounding for the exact mode, a few per cent for the rejection-free one), the
   exact mode's mean trials and bound violations (must be 0), the relative error of the mean weight against
   the quadrature reference of the directional albedo (:func:`core.analysis.albedo`, luminance) at
   ``ALBEDO_THETAS``, and the furnace efficiency ``1 / (relative variance x seconds per sample)`` of
   ``cosine``, ``analytic`` (where the model has one), ``adaptive`` and ``adaptive_warp``: speed against
   error in one number (higher is better; the exact mode's is infinite up to rounding).

Prints the three tables with the targets beside them and writes ``adaptive_build.csv`` (one row per case
and mode), ``adaptive_throughput.csv``, ``adaptive_error.csv``, ``adaptive_albedo.csv`` (per theta_o) and
``adaptive.png`` under ``--out`` (default ``results/bench``). ``--quick`` (a smoke test, under a minute):
Phong and the anisotropic Ward case, 20 views of 500 samples, one run. ``--build-only``: section 1's one-core
builds alone, printed (the build's CPU seconds against the target; no files).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np

from core.analysis import albedo
from core.brdf import BRDF, LUMINANCE, all_models, make_brdf
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.merl import measured_brdf
from core.sampling import SampleBatch, Sampler, applicable_samplers, make_sampler
from core.sampling.adaptive import AdaptiveSampler, AdaptiveTable, TableOptions, clear_memory_cache
from core.sampling.adaptive.records import TableReport, table_options
from core.sampling.adaptive.store import memory_bytes
from core.sampling.adaptive.table import build_table

ROOT = Path(__file__).resolve().parents[1]

VIEWS = 200
SAMPLES = 5000
"""Rows per view: ``VIEWS * SAMPLES = 10^6`` rows per ``sample_each`` call."""
VIEW_SEED = 20261201
ALBEDO_THETAS = (0.0, 30.0, 60.0, 80.0)
ALBEDO_PHI = 30.0
"""Off the mirror axes of the anisotropic materials."""
ALBEDO_SAMPLES = 100_000

BUILD_TARGET_ISOTROPIC_S = 0.2
BUILD_TARGET_ANISOTROPIC_S = 2.0
MEMORY_TARGET_ANISOTROPIC_KB = 1024.0
THROUGHPUT_TARGET = 0.5
"""Adaptive samples per second over cosine's (f included in both)."""
ROUNDING_VARIANCE = 1e-24
"""A relative variance of the furnace weight below this is float64 rounding (a relative std of 1e-12; the
exact mode's is ~1e-15): its efficiency is reported as infinite rather than as 1e34."""

SAMPLERS = ("cosine", "analytic", "adaptive_exact", "adaptive_warp")
MEASURED_FILE = "red_plastic_ct.binary"
ANISOTROPIC_TARGETS = {"ward": {"sx": 0.05, "sy": 0.25}, "ashikhmin_shirley": {"nu": 10.0, "nv": 200.0}}
"""The anisotropic cases the targets name (other parameters at their defaults)."""
QUICK_MODELS = ("phong", "ward")
MODES = {"exact": "adaptive_exact", "warp": "adaptive_warp"}
"""The adaptive sampler's modes and the names of their samplers."""


def mode_options(options: dict[str, Any]) -> dict[str, TableOptions]:
    """Each mode's table options: the sampler's defaults with ``options`` (``--option``) applied, and the
    rejection-free mode's without bounds (as its sampler builds it)."""
    exact = table_options(**options)
    return {"exact": exact, "warp": replace(exact, bounds=False)}


"""Each mode's table as its sampler builds it at the defaults (``n_max = 2``; the warp sampler sets
``bounds=False`` itself)."""


@dataclass(frozen=True)
class Case:
    """One material of the benchmark and the targets that apply to it."""

    label: str
    brdf: BRDF
    kind: str
    """``isotropic``, ``measured`` or ``anisotropic``."""
    build_target_s: float | None
    memory_target_kb: float | None


def cases(models: Sequence[str] | None, quick: bool) -> list[Case]:
    """The benchmark's materials, in table order (``models``: only these model names; ``quick``: by default
    only those of ``QUICK_MODELS``)."""
    keep = set(models) if models else set(QUICK_MODELS) if quick else model_names()
    out: list[Case] = []
    for model in all_models():
        if model.isotropic and model.name in keep:
            out.append(Case(model.name, model.bind(), "isotropic", BUILD_TARGET_ISOTROPIC_S, None))
    if "merl" in keep:
        path = files("resources") / "materials" / MEASURED_FILE
        # a MERL table is isotropic by construction (its parameterization): the isotropic target applies
        brdf = measured_brdf(str(path))
        out.append(Case(f"merl:{MEASURED_FILE}", brdf, "measured", BUILD_TARGET_ISOTROPIC_S, None))
    for name, params in ANISOTROPIC_TARGETS.items():
        if name in keep:
            label = name + " " + " ".join(f"{k}={v:g}" for k, v in params.items())
            out.append(
                Case(label, make_brdf(name, params), "anisotropic", BUILD_TARGET_ANISOTROPIC_S,
                     MEMORY_TARGET_ANISOTROPIC_KB)
            )  # fmt: skip
    for model in all_models():
        if not model.isotropic and model.name not in ANISOTROPIC_TARGETS and model.name in keep:
            out.append(Case(model.name, model.bind(), "anisotropic", None, None))
    return out


def model_names() -> set[str]:
    """The names ``--models`` accepts."""
    return {m.name for m in all_models()} | {"merl"}


# ------------------------------------------------------------------------------------------ inputs
def render_views(n: int, seed: int = VIEW_SEED) -> np.ndarray:
    """``(n, 3)`` outgoing directions as a render meets them: density proportional to ``cos theta_o``
    (``cos^2`` uniform), ``phi_o`` uniform."""
    u = np.random.default_rng(seed).random((n, 2))
    cos_t = np.sqrt(u[:, 0])
    sin_t = np.sqrt(1.0 - u[:, 0])
    phi = 2.0 * math.pi * u[:, 1]
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)


def furnace_weights(batch: SampleBatch) -> np.ndarray:
    """``(n,)``: ``lum(f) cos / pdf`` (0 where the density or the cosine is 0: such a sample adds nothing)."""
    cos = np.maximum(batch.wi[:, 2], 0.0)
    fcos = (batch.f @ LUMINANCE) * cos
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(batch.pdf > 0.0, fcos / batch.pdf, 0.0)


# ------------------------------------------------------------------------------------------ 1. build
@dataclass
class BuildResult:
    """Section 1 for one case and one mode."""

    mode: str
    """A key of ``MODES``."""
    seconds: float
    """Best of the runs, one core."""
    cpu_seconds: float
    """Best CPU time of the runs (the process's: the one build thread's, with the GIL-holding Python of the
    layout): less affected by a shared machine's load than ``seconds``."""
    runs_s: list[float]
    sampler_seconds: float
    """The sampler's own build (all cores)."""
    memory_kb: float
    trees: int
    leaves: int
    report: TableReport
    same_table: bool
    """The sampler's table has the leaves of the one-core build (threads must not change the table)."""


def measure_builds(brdf: BRDF, runs: int, options: dict[str, Any]) -> dict[str, tuple[list[float], list[float],
                                                                                  AdaptiveTable, TableReport]]:  # fmt: skip
    """Per mode: seconds and CPU seconds of each one-core build of its table from empty caches, and the last
    table with its report (the modes alternate within a run)."""
    times: dict[str, list[float]] = {mode: [] for mode in MODES}
    cpus: dict[str, list[float]] = {mode: [] for mode in MODES}
    last: dict[str, tuple[AdaptiveTable, TableReport]] = {}
    for _ in range(runs):
        for mode in MODES:
            clear_memory_cache()
            t0 = time.perf_counter()
            c0 = time.process_time()
            last[mode] = build_table(brdf, mode_options(options)[mode], threads=1)
            cpus[mode].append(time.process_time() - c0)
            times[mode].append(time.perf_counter() - t0)
    return {mode: (times[mode], cpus[mode], *last[mode]) for mode in MODES}


def sampler_build(sampler: Sampler, mode: str, times: list[float], cpus: list[float], table: AdaptiveTable,
                  report: TableReport) -> BuildResult:  # fmt: skip
    """Section 1 for one mode: the one-core builds beside ``sampler``'s own (all cores, from empty caches)."""
    assert isinstance(sampler, AdaptiveSampler) and sampler.mode == mode
    clear_memory_cache()
    sampler.preload()
    mine = sampler.table
    return BuildResult(
        mode=mode, seconds=min(times), cpu_seconds=min(cpus), runs_s=times, sampler_seconds=sampler.report.seconds,
        memory_kb=memory_bytes(table) / 1024.0, trees=report.trees, leaves=report.leaves, report=report,
        same_table=len(mine.corners) == len(table.corners) and len(mine.root) == len(table.root),
    )  # fmt: skip


# ------------------------------------------------------------------------------------------ 2. throughput
def make_samplers(brdf: BRDF, options: dict[str, Any]) -> dict[str, Sampler]:
    """The compared samplers of ``brdf`` (no disk cache for the adaptive ones: the table is built here; their
    table ``options`` from ``--option``)."""
    out: dict[str, Sampler] = {"cosine": make_sampler("cosine", brdf)}
    if "analytic" in applicable_samplers(brdf):
        out["analytic"] = make_sampler("analytic", brdf)
    out["adaptive_exact"] = make_sampler("adaptive_exact", brdf, cache=False, **{"n_max": 2.0, **options})
    out["adaptive_warp"] = make_sampler("adaptive_warp", brdf, cache=False, **options)
    return out


def time_samplers(
    samplers: dict[str, Sampler], rows: np.ndarray, runs: int
) -> tuple[dict[str, float], dict[str, SampleBatch]]:
    """Best seconds of ``sample_each(rows)`` per sampler and one batch of each (the last run's)."""
    for s in samplers.values():
        s.sample_each(rows[:1000], seed=1)  # compiled code loaded, tables made: not counted
    best = dict.fromkeys(samplers, math.inf)
    batches: dict[str, SampleBatch] = {}
    for run in range(runs):
        for name, s in samplers.items():
            t0 = time.perf_counter()
            batches[name] = s.sample_each(rows, seed=100 + run)
            best[name] = min(best[name], time.perf_counter() - t0)
    return best, batches


# ------------------------------------------------------------------------------------------ 3. error
@dataclass
class ErrorResult:
    """Section 3 for one sampler of one case."""

    weight_rel_std_mean: float
    """Relative standard deviation of the furnace weight within a view, mean over the views."""
    weight_rel_std_max: float
    rel_variance: float
    """Relative variance of the furnace weight within a view, mean over the views."""
    efficiency: float
    """``1 / (rel_variance x seconds per sample)``."""
    albedo_error_max: float
    """Largest ``|mean weight / albedo - 1|`` over ``ALBEDO_THETAS``."""
    albedo_sigma_max: float
    """Largest statistical standard deviation of that relative error (``rel std / sqrt(n)``)."""


def per_view_stats(weights: np.ndarray, views: int) -> tuple[np.ndarray, np.ndarray]:
    """Relative std and relative variance of the weights of each view (rows interleaved by view)."""
    w = weights.reshape(-1, views)
    mean = w.mean(axis=0)
    var = w.var(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_var = np.where(mean > 0.0, var / mean**2, np.nan)
    return np.sqrt(rel_var), rel_var


@dataclass
class AlbedoRow:
    """The mean furnace weight of one sampler at one ``theta_o`` against the quadrature reference."""

    theta_deg: float
    sampler: str
    reference: float
    reference_error: float
    mean_weight: float
    rel_error: float
    rel_sigma: float


def albedo_rows(samplers: dict[str, Sampler], brdf: BRDF, n: int) -> list[AlbedoRow]:
    rows = []
    for theta in ALBEDO_THETAS:
        ref = albedo(brdf, theta, ALBEDO_PHI)
        value = float(np.asarray(ref.value) @ LUMINANCE)
        error = float(np.asarray(ref.error) @ LUMINANCE)
        wo = degrees_to_dir(theta, ALBEDO_PHI)
        for name, s in samplers.items():
            w = furnace_weights(s.sample(wo, n, seed=7))
            mean = float(w.mean())
            rows.append(
                AlbedoRow(theta, name, value, error / value if value > 0 else math.nan, mean,
                          mean / value - 1.0 if value > 0 else math.nan,
                          float(w.std()) / (math.sqrt(n) * value) if value > 0 else math.nan)
            )  # fmt: skip
    return rows


# ------------------------------------------------------------------------------------------ the run
@dataclass
class CaseResult:
    case: Case
    builds: dict[str, BuildResult]
    """Section 1 per mode (the keys of ``MODES``)."""
    seconds: dict[str, float]
    """Best seconds of the throughput batch per sampler."""
    rows: int
    errors: dict[str, ErrorResult]
    albedo: list[AlbedoRow]
    exact_info: dict[str, Any] = field(default_factory=dict)
    acceptance_min_views: float = math.nan
    """The exact mode's least acceptance at the benchmark's views (the table's own guarantee: 1/n_max)."""


def run_case(case: Case, runs: int, views: int, samples: int, albedo_samples: int,
             options: dict[str, Any]) -> CaseResult:  # fmt: skip
    measured = measure_builds(case.brdf, runs, options)
    samplers = make_samplers(case.brdf, options)
    # each sampler keeps the table it built: clearing the memory cache for the next mode does not drop it
    builds = {mode: sampler_build(samplers[MODES[mode]], mode, *measured[mode]) for mode in MODES}
    exact = samplers["adaptive_exact"]
    assert isinstance(exact, AdaptiveSampler)
    view_dirs = render_views(views)
    rows = np.ascontiguousarray(np.tile(view_dirs, (samples, 1)))
    seconds, batches = time_samplers(samplers, rows, runs)
    errors: dict[str, ErrorResult] = {}
    albedo_detail = albedo_rows(samplers, case.brdf, albedo_samples)
    for name, batch in batches.items():
        rel_std, rel_var = per_view_stats(furnace_weights(batch), views)
        mean_rel_var = float(np.nanmean(rel_var))
        per_sample = seconds[name] / len(rows)
        mine = [a for a in albedo_detail if a.sampler == name]
        errors[name] = ErrorResult(
            weight_rel_std_mean=float(np.nanmean(rel_std)), weight_rel_std_max=float(np.nanmax(rel_std)),
            rel_variance=mean_rel_var,
            efficiency=1.0 / (mean_rel_var * per_sample) if mean_rel_var > ROUNDING_VARIANCE else math.inf,
            albedo_error_max=max(abs(a.rel_error) for a in mine),
            albedo_sigma_max=max(a.rel_sigma for a in mine),
        )  # fmt: skip
    return CaseResult(
        case, builds, seconds, len(rows), errors, albedo_detail, exact.info(),
        float(np.min(exact.acceptance(view_dirs))),
    )  # fmt: skip


def run_builds(cases_: list[Case], runs: int, options: dict[str, Any] | None = None) -> None:
    """Section 1 alone (``--build-only``): each mode's one-core build from empty caches, best of ``runs``, the
    target judged on CPU seconds; no sampler's own build, no throughput, no files."""
    print(f"kernels loaded or compiled (not counted): {warm_up():.1f} s", flush=True)
    print(f"Build of each mode's whole table, one core, empty caches, best of {runs} (target "
          f"{BUILD_TARGET_ISOTROPIC_S:g} s CPU isotropic; load {os.getloadavg()[0]:.1f} at the start)")  # fmt: skip
    rows = []
    for case in cases_:
        measured = measure_builds(case.brdf, runs, options or {})
        for mode, (times, cpus, _, report) in measured.items():
            exact = mode == "exact"
            rows.append([
                case.label, mode, f"{min(times):.3f}", f"{min(cpus):.3f}", " ".join(f"{c:.3f}" for c in cpus),
                _g(case.build_target_s or math.nan), _met(min(cpus), case.build_target_s), str(report.trees),
                f"{report.leaves / max(report.trees, 1):.0f}", str(report.evaluations),
                _g(report.acceptance_min) if exact else "-", _g(report.norm_error_max) if exact else "-",
            ])  # fmt: skip
    header = ["case", "mode", "s", "cpu s", "cpu s runs", "target", "met", "trees", "leaves/tree", "evaluations",
              "acc min", "norm err"]  # fmt: skip
    print(format_table(header, rows))
    print(f"load {os.getloadavg()[0]:.1f} at the end")


def warm_up() -> float:
    """Load (or compile) every kernel the measurements call, on small tables and batches: seconds."""
    t0 = time.perf_counter()
    small = {"max_thetas": 7, "warp_tol": 1e-2, "quad_tol": 1e-2, "phi_count": 2, "capacity": 256}
    wo = render_views(8)
    for brdf in (make_brdf("phong"), make_brdf("ward", {"sx": 0.1, "sy": 0.3})):
        build_table(brdf, TableOptions(**small), threads=1)
        for name in ("cosine", "analytic"):
            make_sampler(name, brdf).sample_each(wo, seed=1)
        for name in ("adaptive_exact", "adaptive_warp"):
            s = make_sampler(name, brdf, cache=False, **small)
            s.sample_each(wo, seed=1)
            s.acceptance(wo)
    clear_memory_cache()
    return time.perf_counter() - t0


def run(
    cases_: list[Case],
    runs: int,
    views: int,
    samples: int,
    albedo_samples: int,
    out: Path,
    options: dict[str, Any] | None = None,
) -> list[CaseResult]:
    """Measure every case, print the tables, write the CSV files and the plot."""
    print(f"kernels loaded or compiled (not counted): {warm_up():.1f} s", flush=True)
    results = []
    for case in cases_:
        t0 = time.perf_counter()
        r = run_case(case, runs, views, samples, albedo_samples, options or {})
        results.append(r)
        print(f"  {case.label:<36} build exact {r.builds['exact'].seconds:6.3f} s "
              f"({r.builds['exact'].cpu_seconds:.3f} s cpu)  warp {r.builds['warp'].seconds:6.3f} s "
              f"({r.builds['warp'].cpu_seconds:.3f} s cpu)  "
              f"adaptive {r.seconds['cosine'] / r.seconds['adaptive_exact']:4.2f} x cosine  "
              f"warp {r.seconds['cosine'] / r.seconds['adaptive_warp']:4.2f} x cosine  "
              f"violations {r.exact_info['bound_violations']}  ({time.perf_counter() - t0:.1f} s, "
              f"load {os.getloadavg()[0]:.1f})",
              flush=True)  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    paths = write_csvs(results, out)
    print()
    print_tables(results, runs, views, samples)
    try:
        plot(results, out / "adaptive.png")
        paths.append(out / "adaptive.png")
    except Exception as exc:  # noqa: BLE001 - a plot that fails must not lose the tables
        print(f"(no plot: {exc})")
    print("\nwrote " + ", ".join(str(p) for p in paths))
    return results


# ------------------------------------------------------------------------------------------ output
def _met(value: float, target: float | None, above: bool = False) -> str:
    if target is None:
        return "-"
    return "yes" if (value >= target if above else value <= target) else "NO"


def build_records(results: list[CaseResult]) -> list[dict[str, Any]]:
    """One record per case and mode; the checks a mode's table does not have are blank (the warp table has
    no bounds, hence no acceptance, and its mode draws without the normalizer)."""
    out = []
    for r in results:
        c = r.case
        for mode, b in r.builds.items():
            exact = mode == "exact"
            out.append({
                "case": c.label, "kind": c.kind, "model": c.brdf.model.name, "mode": mode,
                "build_s": b.seconds, "build_cpu_s": b.cpu_seconds, "build_s_runs": " ".join(f"{t:.4f}" for t in b.runs_s),
                "build_s_all_cores": b.sampler_seconds, "memory_kb": b.memory_kb, "trees": b.trees,
                "leaves": b.leaves, "leaves_per_tree": b.leaves / max(b.trees, 1),
                "rounds": b.report.rounds, "evaluations": b.report.evaluations,
                "acceptance_min": b.report.acceptance_min if exact else "",
                "chi2_max_edge": b.report.chi2_max_edge, "chi2_max_phi_edge": b.report.chi2_max_phi_edge,
                "normalizer_error": b.report.norm_error_max if exact else "",
                "same_table_all_cores": b.same_table,
                "target_s": c.build_target_s if c.build_target_s is not None else "",
                "target_kb": c.memory_target_kb if c.memory_target_kb is not None else "",
                "build_met": _met(b.seconds, c.build_target_s),
                "memory_met": _met(b.memory_kb, c.memory_target_kb),
            })  # fmt: skip
    return out


def throughput_records(results: list[CaseResult]) -> list[dict[str, Any]]:
    out = []
    for r in results:
        for name, seconds in r.seconds.items():
            ratio = r.seconds["cosine"] / seconds
            adaptive = name.startswith("adaptive_exact")
            out.append({
                "case": r.case.label, "sampler": name, "rows": r.rows, "seconds": seconds,
                "msamples_per_s": r.rows / seconds / 1e6, "ratio_to_cosine": ratio,
                "target": THROUGHPUT_TARGET if adaptive else "",
                "met": _met(ratio, THROUGHPUT_TARGET if adaptive else None, above=True),
            })  # fmt: skip
    return out


def error_records(results: list[CaseResult]) -> list[dict[str, Any]]:
    out = []
    for r in results:
        for name, e in r.errors.items():
            rec: dict[str, Any] = {"case": r.case.label, "sampler": name, **asdict(e)}
            exact = name == "adaptive_exact"
            rec["mean_trials"] = r.exact_info["mean_trials"] if exact else ""
            rec["bound_violations"] = r.exact_info["bound_violations"] if exact else ""
            rec["acceptance_min_views"] = r.acceptance_min_views if exact else ""
            out.append(rec)
    return out


def albedo_records(results: list[CaseResult]) -> list[dict[str, Any]]:
    return [{"case": r.case.label, **asdict(a)} for r in results for a in r.albedo]


def write_csv(records: list[dict[str, Any]], path: Path) -> Path:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(records[0]) if records else [])
        w.writeheader()
        w.writerows(records)
    return path


def write_csvs(results: list[CaseResult], out: Path) -> list[Path]:
    return [
        write_csv(build_records(results), out / "adaptive_build.csv"),
        write_csv(throughput_records(results), out / "adaptive_throughput.csv"),
        write_csv(error_records(results), out / "adaptive_error.csv"),
        write_csv(albedo_records(results), out / "adaptive_albedo.csv"),
    ]


def format_table(header: list[str], rows: list[list[str]]) -> str:
    """Columns right-aligned to their widest cell (the first left-aligned)."""
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows, strict=True)]

    def line(cells: list[str]) -> str:
        first = str(cells[0]).ljust(widths[0])
        return "  ".join([first, *(str(c).rjust(w) for c, w in zip(cells[1:], widths[1:], strict=True))])

    return "\n".join([line(header), "  ".join("-" * w for w in widths), *(line(r) for r in rows)])


def _g(x: float, digits: int = 3) -> str:
    if isinstance(x, str):
        return x
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "inf"
    return f"{x:.{digits}g}"


def _blank(x: float | str) -> float:
    """A record's value, NaN where it is blank (printed ``-``)."""
    return math.nan if x == "" else float(x)


def print_tables(results: list[CaseResult], runs: int, views: int, samples: int) -> None:
    targets = (
        f"target {BUILD_TARGET_ISOTROPIC_S:g} s isotropic; {BUILD_TARGET_ANISOTROPIC_S:g} s and "
        f"{MEMORY_TARGET_ANISOTROPIC_KB:g} KB for the named anisotropic cases"
    )
    print(
        f"1. Build of each mode's whole table (exact: with the rejection bounds; warp: without), one core, "
        f"empty caches, best of {runs};\n   s all cores: the sampler's own build ({targets})"
    )
    rows = []
    for rec in build_records(results):
        rows.append([
            rec["case"], rec["mode"], f"{rec['build_s']:.3f}", f"{rec['build_cpu_s']:.3f}",
            _g(_blank(rec["target_s"])), rec["build_met"],
            f"{rec['build_s_all_cores']:.3f}", f"{rec['memory_kb']:.0f}", _g(_blank(rec["target_kb"]), 4),
            rec["memory_met"], str(rec["trees"]), f"{rec['leaves_per_tree']:.0f}",
            _g(_blank(rec["acceptance_min"])), _g(rec["chi2_max_edge"]), _g(_blank(rec["normalizer_error"])),
            "" if rec["same_table_all_cores"] else "DIFFERS",
        ])  # fmt: skip
    header = ["case", "mode", "s", "cpu s", "target", "met", "s all cores", "KB", "target", "met", "trees",
              "leaves/tree", "acc min", "chi2 edge", "norm err", "table"]  # fmt: skip
    print(format_table(header, rows))

    print(
        f"\n2. Throughput with f, {views} render views x {samples} samples, one sample_each call, best of "
        f"{runs} (M samples/s; target adaptive >= {THROUGHPUT_TARGET:g} x cosine)"
    )
    rows = []
    for r in results:
        rate = {n: f"{r.rows / s / 1e6:.2f}" for n, s in r.seconds.items()}
        ratio = {n: r.seconds["cosine"] / s for n, s in r.seconds.items()}
        rows.append([
            r.case.label, rate["cosine"], rate.get("analytic", "-"),
            rate["adaptive_exact"], f"{ratio['adaptive_exact']:.2f}", _met(ratio["adaptive_exact"], THROUGHPUT_TARGET, True),
            rate["adaptive_warp"], f"{ratio['adaptive_warp']:.2f}",
            _met(ratio["adaptive_warp"], THROUGHPUT_TARGET, True),
        ])  # fmt: skip
    header = ["case", "cosine", "analytic", "adaptive_exact", "x cos", "met", "warp", "x cos", "met"]
    print(format_table(header, rows))

    thetas = ", ".join(f"{t:g}" for t in ALBEDO_THETAS)
    print(
        "\n3. Error in the furnace: relative std of the weight lum(f) cos / pdf within a view (mean over "
        "the views);\n   the exact mode's mean trials and bound violations (must be 0); "
        f"|mean weight / albedo - 1|, the worst of theta_o = {thetas} deg\n   (its statistical sigma in "
        "brackets); the efficiency 1 / (relative variance x seconds per sample)"
    )
    rows = []
    for r in results:
        e = r.errors

        def eff(name: str, e: dict[str, ErrorResult] = e) -> str:
            return _g(e[name].efficiency) if name in e else "-"

        def alb(name: str, e: dict[str, ErrorResult] = e) -> str:
            return f"{_g(e[name].albedo_error_max, 2)} ({_g(e[name].albedo_sigma_max, 1)})"

        rows.append([
            r.case.label, _g(e["adaptive_exact"].weight_rel_std_mean, 2),
            _g(e["adaptive_warp"].weight_rel_std_mean, 2), f"{r.exact_info['mean_trials']:.3f}",
            str(r.exact_info["bound_violations"]), alb("adaptive_exact"), alb("adaptive_warp"), eff("cosine"),
            eff("analytic"), eff("adaptive_exact"), eff("adaptive_warp"),
        ])  # fmt: skip
    header = ["case", "std exact", "std warp", "trials", "viol.", "albedo err exact", "albedo err warp",
              "eff cosine", "eff analytic", "eff exact", "eff warp"]  # fmt: skip
    print(format_table(header, rows))


def plot(results: list[CaseResult], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [r.case.label for r in results]
    x = np.arange(len(results))
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.5), layout="constrained")
    ax = axes[0]
    for j, mode in enumerate(MODES):
        ax.bar(x + (j - 0.5) * 0.4, [r.builds[mode].seconds for r in results], width=0.4,
               label=f"{MODES[mode]} ({mode})")  # fmt: skip
    ax.scatter(x, [r.case.build_target_s or np.nan for r in results], marker="_", s=300, color="k", zorder=3,
               label="target")  # fmt: skip
    ax.set_yscale("log")
    ax.set_ylabel("build of each mode's table, one core (s)")
    ax.legend()
    ax = axes[1]
    for j, name in enumerate(("adaptive_exact", "adaptive_warp")):
        ax.bar(x + (j - 0.5) * 0.4, [r.seconds["cosine"] / r.seconds[name] for r in results], width=0.4,
               label=name)  # fmt: skip
    ax.axhline(THROUGHPUT_TARGET, color="k", lw=0.8, ls="--")
    ax.set_ylabel("samples per second / cosine's (f included)")
    ax.legend()
    ax = axes[2]
    for j, name in enumerate(("cosine", "analytic", "adaptive_warp")):
        eff = [r.errors[name].efficiency if name in r.errors else np.nan for r in results]
        eff = [e if math.isfinite(e) else np.nan for e in eff]  # a zero-variance density's: not drawn
        ax.bar(x + (j - 1) * 0.27, eff, width=0.27, label=name)
    ax.set_yscale("log")
    ax.set_ylabel("furnace efficiency 1 / (rel. variance x s per sample)")
    ax.set_title("adaptive_exact: infinite up to rounding, not drawn", fontsize=9)
    ax.legend()
    for ax in axes:
        ax.set_xticks(x, labels, rotation=70, ha="right", fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _number(text: str) -> int | float:
    try:
        return int(text)
    except ValueError:
        return float(text)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", default="", help="comma-separated model names (merl: the measured material)")
    ap.add_argument("--quick", action="store_true", help="few models, small counts, one run (a smoke test)")
    ap.add_argument("--runs", type=int, help="timed runs, the best kept (default 3; 1 with --quick)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench", help="folder for CSV and PNG")
    ap.add_argument("--build-only", action="store_true",
                    help="section 1 only: each mode's one-core build (no throughput, no files)")  # fmt: skip
    ap.add_argument("--option", action="append", default=[], metavar="K=V",
                    help="an adaptive table option for both modes, e.g. warp_chi2=0.2 (repeatable)")  # fmt: skip
    a = ap.parse_args(argv)
    options: dict[str, Any] = {}
    for item in a.option:
        key, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--option takes K=V, got {item!r}")
        options[key] = value if key == "parameterization" else _number(value)
    try:
        mode_options(options)
    except (ParameterError, ValueError) as exc:
        ap.error(str(exc))
    models = [m for m in a.models.split(",") if m]
    unknown = sorted(set(models) - model_names())
    if unknown:
        ap.error(f"unknown model(s): {', '.join(unknown)}; known: {', '.join(sorted(model_names()))}")
    runs = a.runs if a.runs is not None else (1 if a.quick else 3)
    if runs < 1:
        ap.error(f"--runs must be positive, got {runs}")
    views, samples, albedo_samples = (20, 500, 5000) if a.quick else (VIEWS, SAMPLES, ALBEDO_SAMPLES)
    if a.build_only:
        run_builds(cases(models, a.quick), runs, options)
        return 0
    run(cases(models, a.quick), runs, views, samples, albedo_samples, a.out, options)
    return 0


if __name__ == "__main__":
    sys.exit(main())
