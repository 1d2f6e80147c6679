"""The sampler study: precomputation, memory, speed and the error of the reflected-radiance estimator.

For every BRDF, incident angle and light (white furnace, a small bright light, an HDR environment map), each
sampling strategy estimates ``L_r(wo) = integral f L cos d(omega)``.
Every strategy here draws independent samples, so the error of an N-sample estimate is ``sigma / sqrt(N)``
with ``sigma^2`` the per-sample variance, measured on a batch of ``batch`` samples (far steadier than a few
repeated small runs when the integrand is heavy-tailed, as with a small bright light). The bias is checked
against a reference made with many samples of the strategy with the lowest pilot variance: ``bias_z`` is the
difference in combined standard errors. Speed is measured on the same runs, so the
error-against-time curves and the efficiency ``1 / (variance * time per sample)`` (the seed's definition)
come from one measurement.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from core.brdf import BRDF, LUMINANCE, all_models
from core.geometry import degrees_to_dir
from core.io import atomic_write_text
from core.sampling import Sampler, make_sampler
from core.sampling.base import current_sampler
from core.sampling.ris import ris_sample
from core.study_lights import CapLight, Furnace, LatLongEnvironment

DEFAULT_SAMPLERS = (
    "uniform",
    "cosine",
    "analytic",
    "adaptive_exact",
    "adaptive_warp",
    "uniform_cdf",
    "compress_cdf",
    "factored",
    "rgl_warp",
    "ris",
)
RIS_CANDIDATES = 8


def default_lights() -> list[Any]:
    return [
        Furnace(),
        CapLight(axis=degrees_to_dir(40.0, 180.0), half_angle=math.radians(4.0), radiance=200.0),
        LatLongEnvironment(LatLongEnvironment.procedural_sky()),
    ]


@dataclass
class Row:
    material: str
    theta_o: float
    light: str
    sampler: str
    samples: int
    rel_rmse: float
    seconds_per_sample: float
    reference: float
    reference_rel_stderr: float
    efficiency: float
    precompute_seconds: float
    memory_bytes: int
    samples_per_second: float
    rel_bias: float
    bias_z: float
    """Difference from the reference in combined standard errors (|z| > 5 flags a biased strategy)."""


@dataclass
class StudyConfig:
    thetas: Sequence[float] = (0.0, 30.0, 60.0, 80.0)
    counts: Sequence[int] = (16, 64, 256, 1024)
    batch: int = 1 << 17
    reference_samples: int = 1 << 20
    samplers: Sequence[str] = DEFAULT_SAMPLERS
    options: dict[str, dict[str, Any]] = field(default_factory=lambda: {"adaptive_exact": {"n_max": 2.0}})


class _Estimator:
    """One strategy's estimator of ``L_r``: ``draw(wo, n, seed) -> per-sample contributions (n,)``."""

    def __init__(self, name: str, brdf: BRDF, options: dict[str, Any]):
        self.name = name
        self.brdf = brdf
        t0 = time.perf_counter()
        if name == "ris":
            source = "analytic" if brdf.model.sample is not None else "cosine"
            self.sampler: Sampler = make_sampler(source, brdf)
        else:
            self.sampler = make_sampler(name, brdf, **options.get(name, {}))
        self.precompute = time.perf_counter() - t0

    def warm(self, wo: np.ndarray, light: Any) -> float:
        """First use at ``wo`` (lazy tables are built here); returns its seconds."""
        t0 = time.perf_counter()
        self.draw(wo, 64, light, seed=1)
        return time.perf_counter() - t0

    def draw(self, wo: np.ndarray, n: int, light: Any, seed: int) -> np.ndarray:
        if self.name == "ris":
            kept = ris_sample(self.sampler, wo, light.radiance, n, RIS_CANDIDATES, seed=seed)
            g = (kept.f @ LUMINANCE) * np.maximum(kept.wi[:, 2], 0.0) * light.radiance(kept.wi)
            return g * kept.weight
        drawn = self.sampler.sample(wo, n, seed=seed)
        wi, pdf = drawn.wi, drawn.pdf
        g = (drawn.f @ LUMINANCE) * np.maximum(wi[:, 2], 0.0) * light.radiance(wi)
        return np.where(pdf > 0.0, g / np.where(pdf > 0.0, pdf, 1.0), 0.0)

    def memory(self) -> int:
        return int(self.sampler.info().get("memory_bytes", 0))


def current_samplers(config: StudyConfig) -> tuple[list[str], dict[str, dict[str, Any]]]:
    """The study's strategies and their options by current name: a former name (``adaptive``) is read as
    the strategy it means, with the notice that names it (:func:`core.sampling.base.current_sampler`)."""
    names: list[str] = []
    options: dict[str, dict[str, Any]] = {}
    for given in config.samplers:
        if given == "ris":
            names.append(given)
            continue
        name, opts = current_sampler(given, config.options.get(given, {}))
        names.append(name)
        options[name] = opts
    return names, options


def _applicable(name: str, brdf: BRDF) -> bool:
    return not (name == "analytic" and brdf.model.sample is None)


def study_material(
    label: str,
    brdf: BRDF,
    config: StudyConfig,
    lights: Sequence[Any],
    tick: Callable[[], None] = lambda: None,
) -> list[Row]:
    """Every row of the study for one material."""
    samplers, options = current_samplers(config)
    estimators = [_Estimator(s, brdf, options) for s in samplers if _applicable(s, brdf)]
    rows: list[Row] = []
    for theta in config.thetas:
        wo = degrees_to_dir(min(theta, 89.9))
        warm = {e.name: e.warm(wo, lights[0]) for e in estimators}
        for light in lights:
            pilot = {e.name: np.var(e.draw(wo, 4096, light, seed=7)) for e in estimators}
            best = min(estimators, key=lambda e: pilot[e.name])
            ref_samples = best.draw(wo, config.reference_samples, light, seed=99)
            reference = float(ref_samples.mean())
            ref_err = float(ref_samples.std() / math.sqrt(len(ref_samples)))
            for e in estimators:
                t0 = time.perf_counter()
                values = e.draw(wo, config.batch, light, seed=1000)
                per_sample = (time.perf_counter() - t0) / config.batch
                var = float(np.var(values))
                bias = float(values.mean()) - reference
                scale = abs(reference) if reference != 0.0 else 1.0
                for n in config.counts:
                    # Every strategy here draws independent samples, so the mean of N has
                    # MSE = variance / N (+ bias^2, zero for an unbiased strategy up to noise).
                    mse = var / n
                    rows.append(
                        Row(
                            material=label,
                            theta_o=float(theta),
                            light=light.name,
                            sampler=e.name,
                            samples=int(n),
                            rel_rmse=math.sqrt(mse) / scale,
                            seconds_per_sample=per_sample,
                            reference=reference,
                            reference_rel_stderr=ref_err / scale,
                            efficiency=1.0 / (var * per_sample) if var > 0 else math.inf,
                            precompute_seconds=e.precompute + warm[e.name],
                            memory_bytes=e.memory(),
                            samples_per_second=1.0 / per_sample,
                            rel_bias=bias / scale,
                            bias_z=bias / math.sqrt(var / config.batch + ref_err**2)
                            if var > 0 or ref_err > 0
                            else 0.0,
                        )
                    )
                tick()
    return rows


def materials(
    names: Iterable[str] | None = None, measured: Iterable[str | Path] = ()
) -> list[tuple[str, BRDF]]:
    """Registered models at their default (seed) parameters, plus measured files."""
    out = []
    wanted = set(names) if names else None
    for m in all_models():
        if wanted is None or m.name in wanted:
            out.append((m.name, m.bind()))
    for path in measured:
        from core.measured import load_measured, measured_label

        out.append((measured_label(path), load_measured(path)))
    return out


def write_results(rows: list[Row], out_dir: Path) -> dict[str, Path]:
    """CSV, a Markdown summary and log-log plots (error vs samples and vs time, one line per sampler)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"csv": out_dir / "study.csv", "markdown": out_dir / "study.md"}
    fields = list(asdict(rows[0]).keys()) if rows else []
    lines = [",".join(fields)]
    for r in rows:
        lines.append(",".join(_fmt(v) for v in asdict(r).values()))
    atomic_write_text(paths["csv"], "\n".join(lines) + "\n")
    atomic_write_text(paths["markdown"], summary_markdown(rows))
    paths.update(plot(rows, out_dir))
    return paths


def _fmt(v: Any) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _eff(e: float) -> str:
    return "inf (zero variance)" if e > 1e20 else f"{e:.3g}"


def _geomean(values: Iterable[float]) -> float:
    v = [max(x, 1e-16) for x in values if math.isfinite(x)]
    return float(np.exp(np.mean(np.log(v)))) if v else float("nan")


# A case (material, angle, light) whose reference is below this fraction of the same material's largest under the
# same light is left out of the summaries: the light reaches the viewer only through the BRDF's far tail there.
NEGLIGIBLE = 1e-6


def counted(rows: list[Row]) -> tuple[list[Row], list[tuple[str, float, str]]]:
    """The rows the summaries average over, and the cases left out as negligible (``NEGLIGIBLE``).

    In such a case (Lewis ``kd = 0`` under the small light at 0° and 80°: ``L_r`` about 1e-9 of its value at
    30°) the reference is not resolved (the pilot's lowest-variance estimator may see no light at all, giving
    0), relative errors are measured against round-off, and a sampler that does see the tail gets an efficiency
    ``1 / (variance × time)`` of ~1e21 while one that does not gets an infinite one, which the geometric mean
    cannot use: such a case decided a whole column's mean by itself."""
    peak: dict[tuple[str, str], float] = {}
    for r in rows:
        key = (r.material, r.light)
        peak[key] = max(peak.get(key, 0.0), abs(r.reference))
    kept = [r for r in rows if abs(r.reference) > NEGLIGIBLE * peak[(r.material, r.light)]]
    left = {(r.material, r.theta_o, r.light) for r in rows} - {(r.material, r.theta_o, r.light) for r in kept}
    return kept, sorted(left)


def _means_table(rows: list[Row], samplers: list[str], lights: list[str], n_max: int) -> list[str]:
    """Per sampler: geometric means of the relative RMSE at ``n_max`` and of the efficiency, per light."""
    out = [
        "| sampler | "
        + " | ".join(f"RMSE {li}" for li in lights)
        + " | "
        + " | ".join(f"eff {li}" for li in lights)
        + " |",
        "|" + "---|" * (1 + 2 * len(lights)),
    ]
    for s in samplers:
        at = [[r for r in rows if r.sampler == s and r.light == li and r.samples == n_max] for li in lights]
        errs = [_geomean(r.rel_rmse for r in sel) for sel in at]
        effs = [_geomean(r.efficiency for r in sel) for sel in at]
        out.append(
            f"| {s} | "
            + " | ".join(f"{e:.2e}" for e in errs)
            + " | "
            + " | ".join(_eff(e) for e in effs)
            + " |"
        )
    return out


def summary_markdown(rows: list[Row]) -> str:
    """Per material: precompute, memory, samples/s, relative RMSE at the largest N per light; then averages
    (over the cases ``counted`` keeps)."""
    if not rows:
        return "(no results)\n"
    rows, left_out = counted(rows)
    n_max = max(r.samples for r in rows)
    samplers = list(dict.fromkeys(r.sampler for r in rows))
    lights = list(dict.fromkeys(r.light for r in rows))
    out = [f"Relative RMSE of L_r at N = {n_max} samples (geometric mean over incident angles), per light.\n"]
    header = "| material | sampler | precompute s | memory KB | Msamples/s | " + " | ".join(lights) + " |"
    out += [header, "|" + "---|" * (5 + len(lights))]
    for mat in dict.fromkeys(r.material for r in rows):
        for s in samplers:
            sel = [r for r in rows if r.material == mat and r.sampler == s]
            if not sel:
                continue
            errs = [
                _geomean(r.rel_rmse for r in sel if r.light == li and r.samples == n_max) for li in lights
            ]
            out.append(
                f"| {mat} | {s} | {max(r.precompute_seconds for r in sel):.3f} | {sel[0].memory_bytes / 1024:.1f} | "
                f"{_geomean(r.samples_per_second for r in sel) / 1e6:.2f} | "
                + " | ".join(f"{e:.2e}" for e in errs)
                + " |"
            )
    if left_out:
        cases = ", ".join(f"{m} at {t:g}° ({li})" for m, t, li in left_out)
        out.append(
            f"\nLeft out as negligible (reference below {NEGLIGIBLE:g} of the material's largest): {cases}."
        )
    shared = set.intersection(
        *({(r.material, r.theta_o, r.light) for r in rows if r.sampler == s} for s in samplers)
    )
    common = [r for r in rows if (r.material, r.theta_o, r.light) in shared]
    if len(common) < len(rows):
        mats = len({r.material for r in common})
        out.append(
            f"\nOn the cases every sampler has ({mats} of {len({r.material for r in rows})} materials; a ranking "
            "needs the same cases in every mean): geometric means of the relative RMSE at N and of the efficiency "
            "1/(var*time).\n"
        )
        out += _means_table(common, samplers, lights, n_max)
    out.append(
        "\nAcross all materials and angles, each sampler over the cases it has (geometric means): relative RMSE "
        "at N, and efficiency 1/(var*time).\n"
    )
    out += _means_table(rows, samplers, lights, n_max)
    out.append("\n" + wins_markdown(rows))
    out.append("\n" + seed_comparison_markdown(rows))
    return "\n".join(out) + "\n"


def wins_markdown(rows: list[Row]) -> str:
    """How often each strategy has the lowest error at equal samples and at equal time, per light.

    RIS is left out of the ranking: it spends several BRDF evaluations per sample and knows the light; so are
    the negligible cases (``counted``).
    """
    rows, _ = counted(rows)
    cases: dict[tuple[str, float, str], dict[str, Row]] = {}
    n_max = max(r.samples for r in rows)
    for r in rows:
        if r.samples == n_max and r.sampler != "ris":
            cases.setdefault((r.material, r.theta_o, r.light), {})[r.sampler] = r
    lights = list(dict.fromkeys(r.light for r in rows))
    samplers = [s for s in dict.fromkeys(r.sampler for r in rows) if s != "ris"]
    out = [
        "Cases (material x angle) in which a strategy has the lowest variance (ties within 1 % shared), RIS excluded:\n"
    ]
    out.append(
        "| light | "
        + " | ".join(f"{s} (equal N)" for s in samplers)
        + " | "
        + " | ".join(f"{s} (equal time)" for s in samplers)
        + " |"
    )
    out.append("|" + "---|" * (1 + 2 * len(samplers)))
    for li in lights:
        by_n = dict.fromkeys(samplers, 0.0)
        by_t = dict.fromkeys(samplers, 0.0)
        for (_, _, light), entries in cases.items():
            if light != li:
                continue
            for table, key in (
                (by_n, lambda r: r.rel_rmse),
                (by_t, lambda r: r.rel_rmse**2 * r.seconds_per_sample),
            ):
                best = min(key(r) for r in entries.values())
                winners = [s for s, r in entries.items() if key(r) <= best * 1.01 + 1e-300]
                for s in winners:
                    table[s] += 1.0 / len(winners)
        out.append(
            f"| {li} | "
            + " | ".join(f"{by_n[s]:.1f}" for s in samplers)
            + " | "
            + " | ".join(f"{by_t[s]:.1f}" for s in samplers)
            + " |"
        )
    return "\n".join(out) + "\n"


# The seed's published figures (Montes 2008, slides "Memory" and "Computation Time"), per model: one quadtree
# at n_max = 2 (KB), the factored PDF (KB), 60 quadtrees' precomputation (s), the factored PDF's (s).
SEED_TABLES: dict[str, tuple[float, float, float, float]] = {
    "ashikhmin_shirley": (0.103, 1031, 57.61, 3.12),
    "beard_maxwell": (28.710, 6454, 49.08, 102.9),
    "blinn": (6.914, 6481, 32.12, 565.7),
    "coupled": (0.103, 1033, 51.25, 3.21),
    "he": (28.711, 1034, 300.8, 8.00),
    "lafortune": (30.891, 6445, 32.33, 312.5),
    "lewis": (40.699, 6445, 32.49, 312.4),
    "minnaert": (28.711, 1031, 35.33, 3.17),
    "oren_nayar": (0.103, 1033, 28.99, 3.08),
    "phong": (21.082, 6445, 29.99, 312.3),
    "poulin_fournier": (6.914, 1038, 112.7, 8.09),
    "schlick_d": (9.094, 1033, 55.17, 3.24),
    "schlick_s": (9.094, 1043, 41.65, 8.30),
    "strauss": (13.453, 1052, 38.82, 15.36),
    "cook_torrance": (0.103, 1029, 38.84, 2.97),
    "ward": (8.004, 1038, 33.57, 26.62),
}


def seed_comparison_markdown(rows: list[Row]) -> str:
    """Memory and precomputation beside the seed's tables. The adaptive sampler builds a material's whole table
    at once (its nodes' trees serve every incident direction), so its figures are the table's, beside the
    seed's single quadtree (one incident direction); the others also build everything up front."""
    out = [
        "Memory and precomputation beside the seed (seed: 2008 hardware, its own implementation; ours: this run).\n",
        "| model | adaptive KB, whole table (seed: 1 QT, n_max 2) | adaptive s | factored KB (seed) | factored s (seed) "
        "| uniform_cdf KB / s | compress_cdf KB / s |",
        "|---|---|---|---|---|---|---|",
    ]
    mats = list(dict.fromkeys(r.material for r in rows))
    for mat in mats:
        sel = [r for r in rows if r.material == mat]

        def first(s: str, sel: list[Row] = sel) -> Row | None:
            return next((r for r in sel if r.sampler == s), None)

        ada = [
            r
            for r in sel
            if r.sampler == "adaptive_exact" and r.light == sel[0].light and r.samples == sel[0].samples
        ]
        seed = SEED_TABLES.get(mat)
        cells = []
        if ada:
            kb = max(r.memory_bytes for r in ada) / 1024
            sec = max(r.precompute_seconds for r in ada)
            cells += [f"{kb:.1f} ({seed[0]:g})" if seed else f"{kb:.1f}", f"{sec:.2f}"]
        else:
            cells += ["-", "-"]
        fac = first("factored")
        if fac:
            cells.append(
                f"{fac.memory_bytes / 1024:.1f} ({seed[1]:g})" if seed else f"{fac.memory_bytes / 1024:.1f}"
            )
            cells.append(
                f"{fac.precompute_seconds:.2f} ({seed[3]:g})" if seed else f"{fac.precompute_seconds:.2f}"
            )
        else:
            cells += ["-", "-"]
        for s in ("uniform_cdf", "compress_cdf"):
            r = first(s)
            cells.append(f"{r.memory_bytes / 1024:.0f} / {r.precompute_seconds:.2f}" if r else "-")
        out.append(f"| {mat} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def plot(rows: list[Row], out_dir: Path) -> dict[str, Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = {}
    rows, _ = counted(rows)
    lights = list(dict.fromkeys(r.light for r in rows))
    samplers = list(dict.fromkeys(r.sampler for r in rows))
    for xaxis in ("samples", "time"):
        fig, axes = plt.subplots(1, len(lights), figsize=(5 * len(lights), 4), squeeze=False)
        for ax, li in zip(axes[0], lights, strict=True):
            for s in samplers:
                counts = sorted({r.samples for r in rows if r.sampler == s and r.light == li})
                if not counts:
                    continue
                err = [
                    _geomean(r.rel_rmse for r in rows if r.sampler == s and r.light == li and r.samples == n)
                    for n in counts
                ]
                if xaxis == "samples":
                    x = counts
                else:
                    sec = _geomean(r.seconds_per_sample for r in rows if r.sampler == s and r.light == li)
                    x = [n * sec for n in counts]
                ax.loglog(x, err, marker="o", label=s)
            ax.set_title(li)
            ax.set_xlabel("samples" if xaxis == "samples" else "seconds per estimate")
            ax.set_ylabel("relative RMSE (geometric mean)")
            ax.grid(True, which="both", alpha=0.3)
        axes[0][0].legend(fontsize=8)
        fig.tight_layout()
        path = out_dir / f"error_vs_{xaxis}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths[f"error_vs_{xaxis}"] = path
    return paths
