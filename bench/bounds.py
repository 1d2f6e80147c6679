"""The exact mode's leaf bounds, over the issue's matrix: every model, every outgoing angle, a number of trials.

    .venv/bin/python bench/bounds.py [--trials 1e7] [--models phong,lafortune] [--out results/bench]
                                     [model files (.brdf, .py) ...]

For every built-in model (:func:`core.brdf.all_models`, at its default parameters) and every model file
given as an argument, the exact mode's table is built (no disk cache, in-memory tables cleared, all cores:
the build a render gets; its seconds reported, after a small table's build has compiled what it calls), then at each ``theta_o`` of ``THETAS`` and ``phi_o`` of
``PHIS`` samples are drawn from one fixed ``wo`` until at least ``--trials`` trials have been made. Each row
reports the trials, the leaf-bound violations among them (trials with ``g > c V p``, the sampler's
``bound_violations``: must be 0), the acceptance (samples over trials; the envelope's guarantee is
``>= 1 / n_max``) and the table's least acceptance over its trees. ``phi_o`` takes an axis (0), a value
inside the first quadrant (40) and one in the second (135): mirror-symmetric materials fold it, the others
see another azimuth node.

Prints one table per model and a summary, and writes ``bounds.csv`` under ``--out`` (default
``results/bench``). ``--trials`` defaults to 1e7 (the issue's count); ``1e6`` runs the matrix in a tenth of
the time.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from core.brdf import BRDF, all_models, make_brdf  # noqa: E402
from core.geometry import degrees_to_dir  # noqa: E402
from core.sampling import make_sampler  # noqa: E402
from core.sampling.adaptive import clear_memory_cache  # noqa: E402

THETAS = (0.0, 30.0, 60.0, 80.0, 89.0, 89.9)
PHIS = (0.0, 40.0, 135.0)
CHUNK = 1_000_000
"""Samples drawn per call (a fixed ``wo`` repeated)."""
SEED = 20270401
N_MAX = 2.0


@dataclass
class Row:
    model: str
    theta: float
    phi: float
    trials: int
    samples: int
    violations: int
    acceptance: float
    acceptance_min: float
    build_s: float
    draw_s: float


WARM = {"max_thetas": 7, "rounds": 1, "quad_tol": 1e-2, "phi_count": 2, "capacity": 256}
"""A small table's options: built first for each model, so that the build timed is not its compiling."""


def warm_up(brdf: BRDF) -> None:
    make_sampler("adaptive_exact", brdf, n_max=N_MAX, cache=False, **WARM).sample(
        degrees_to_dir(45.0), 100, seed=1
    )


def run_model(label: str, brdf: BRDF, trials: int) -> list[Row]:
    warm_up(brdf)
    clear_memory_cache()
    sampler = make_sampler("adaptive_exact", brdf, n_max=N_MAX, cache=False, threads=True)
    t0 = time.perf_counter()
    info = sampler.info()  # builds the table
    build = time.perf_counter() - t0
    rows = []
    for k, theta in enumerate(THETAS):
        for j, phi in enumerate(PHIS):
            wo = degrees_to_dir(theta, phi)
            t_before, s_before, v_before = sampler.trials, sampler.samples, sampler.violations
            t1 = time.perf_counter()
            chunk = 0
            while sampler.trials - t_before < trials:
                # samples a chunk asks for: what is left of the trials at the acceptance seen so far
                made = sampler.trials - t_before
                acc = (sampler.samples - s_before) / made if made else 1.0 / N_MAX
                n = int(min(CHUNK, max(1000, math.ceil((trials - made) * acc))))
                sampler.sample(wo, n, seed=SEED + 1000 * (len(THETAS) * j + k) + chunk)
                chunk += 1
            t_made = sampler.trials - t_before
            s_made = sampler.samples - s_before
            rows.append(
                Row(label, theta, phi, t_made, s_made, sampler.violations - v_before, s_made / t_made,
                    float(info["acceptance_min"]), build, time.perf_counter() - t1)
            )  # fmt: skip
    return rows


def cases(models: list[str] | None, files: list[str]) -> list[tuple[str, BRDF]]:
    out = [(m.name, m.bind()) for m in all_models() if not models or m.name in models]
    out += [(Path(f).name, make_brdf(f)) for f in files]
    return out


def format_rows(rows: list[Row]) -> str:
    header = ["model", "theta", "phi", "trials", "violations", "acceptance", "least (table)", "build s"]
    body = [
        [r.model, f"{r.theta:g}", f"{r.phi:g}", f"{r.trials:.3g}", str(r.violations), f"{r.acceptance:.3f}",
         f"{r.acceptance_min:.3f}", f"{r.build_s:.2f}"]
        for r in rows
    ]  # fmt: skip
    widths = [max(len(x) for x in col) for col in zip(header, *body, strict=True)]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(line, widths, strict=True)))
             for line in [header, *body]]  # fmt: skip
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def summary(rows: list[Row]) -> str:
    """One line per model: its trials, violations, least acceptance seen and build seconds."""
    out = []
    for model in dict.fromkeys(r.model for r in rows):
        mine = [r for r in rows if r.model == model]
        out.append(
            f"| {model} | {sum(r.trials for r in mine):.3g} | {sum(r.violations for r in mine)} | "
            f"{min(r.acceptance for r in mine):.3f} | {mine[0].acceptance_min:.3f} | {mine[0].build_s:.2f} |"
        )
    head = "| model | trials | violations | least acceptance seen | least (table) | build s |\n|---|---|---|---|---|---|"
    return head + "\n" + "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="*", help="model files (.brdf, .py) to add to the built-in models")
    ap.add_argument("--trials", type=float, default=1e7, help="trials per (model, theta, phi) (default 1e7)")
    ap.add_argument("--models", default="", help="comma-separated built-in models (default all)")
    ap.add_argument("--out", default=str(ROOT / "results" / "bench"), help="folder for bounds.csv")
    args = ap.parse_args(argv)
    models = [m for m in args.models.split(",") if m] or None
    trials = int(args.trials)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows: list[Row] = []
    t0 = time.perf_counter()
    for label, brdf in cases(models, args.files):
        mine = run_model(label, brdf, trials)
        rows += mine
        print(format_rows(mine), flush=True)
        print(flush=True)
    path = out / "bounds.csv"
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(asdict(rows[0])))
        w.writeheader()
        w.writerows(asdict(r) for r in rows)
    total = sum(r.violations for r in rows)
    print(summary(rows))
    print(f"\n{len(rows)} rows, {sum(r.trials for r in rows):.3g} trials, {total} violations "
          f"({time.perf_counter() - t0:.0f} s); wrote {path}")  # fmt: skip
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main())
