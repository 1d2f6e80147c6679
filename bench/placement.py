"""How much of a caller's stratified points each strategy keeps, and what a placed draw costs.

For each strategy and model, one outgoing direction: estimates of ``E[g(wi)]`` from ``--grid``² jittered-grid
points (one per cell) and from as many independent points, ``--repeats`` times each, through
``Sampler.sample_into(..., points=)`` (what the renderer hands every strategy at the first two bounces). The
ratio of the two estimates' spreads is printed per integrand (1: nothing kept; the smaller, the better).
Then the CPU time of one draw with ``f``, from the strategy's own stream and from placed points, alternated
in one process, best of ``--runs`` (one thread).

    .venv/bin/python bench/placement.py [--grid 32] [--repeats 40] [--runs 7] [--out results/bench]

Writes ``placement.csv`` under ``--out``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from core.brdf import make_brdf
from core.geometry import degrees_to_dir
from core.io import write_csv_rows
from core.sampling import make_sampler

CASES = [
    ("adaptive_warp", "adaptive_warp", {"cache": False}),
    ("adaptive_exact", "adaptive_exact", {"cache": False}),
    ("uniform_cdf", "uniform_cdf", {}),
    ("factored", "factored", {}),
    ("analytic", "analytic", {}),
]
MODELS = [("phong", {"n": 8.0}), ("ggx", {"alpha": 0.3})]
INTEGRANDS = {
    "wi_z": lambda w: w[:, 2],
    "wi_x": lambda w: w[:, 0],
    "wi_y": lambda w: w[:, 1],
    "step": lambda w: (w[:, 1] > 0.1).astype(np.float64),
    "exp": lambda w: np.exp(3.0 * w[:, 0] - 2.0 * w[:, 1]),
}


def _draw(sampler, wo: np.ndarray, points: np.ndarray | None, seed: int, n: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    wi, pdf, f = np.empty((n, 3)), np.empty(n), np.empty((n, 3))
    sampler.sample_into(np.ascontiguousarray(np.tile(wo, (n, 1))), seed, wi, pdf, f, points=points)
    return wi


def spread_ratios(sampler, wo: np.ndarray, grid: int, repeats: int) -> dict[str, float]:  # type: ignore[no-untyped-def]
    cells = np.stack(np.meshgrid(np.arange(grid), np.arange(grid), indexing="ij"), -1).reshape(-1, 2)
    n = grid * grid
    rng = np.random.default_rng(12)
    strat, iid = [], []
    for r in range(repeats):
        s = _draw(sampler, wo, (cells + rng.random((n, 2))) / grid, r, n)
        i = _draw(sampler, wo, rng.random((n, 2)), r, n)
        strat.append([g(s).mean() for g in INTEGRANDS.values()])
        iid.append([g(i).mean() for g in INTEGRANDS.values()])
    ratio = np.std(strat, axis=0) / np.std(iid, axis=0)
    return dict(zip(INTEGRANDS, ratio.tolist(), strict=True))


def draw_ns(sampler, runs: int, n: int = 100_000) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """ns a draw from the stream and from placed points (random ``wo``), alternated, best of ``runs``."""
    rng = np.random.default_rng(1)
    wo = rng.normal(size=(n, 3))
    wo[:, 2] = np.abs(wo[:, 2])
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    points = rng.random((n, 2))
    wi, pdf, f = np.empty((n, 3)), np.empty(n), np.empty((n, 3))
    sampler.sample_into(wo, 0, wi, pdf, f)
    sampler.sample_into(wo, 0, wi, pdf, f, points=points)
    own = placed = np.inf
    for r in range(runs):
        t = time.process_time()
        sampler.sample_into(wo, r, wi, pdf, f)
        own = min(own, time.process_time() - t)
        t = time.process_time()
        sampler.sample_into(wo, r, wi, pdf, f, points=points)
        placed = min(placed, time.process_time() - t)
    return own / n * 1e9, placed / n * 1e9


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--grid", type=int, default=32, help="points per side of the jittered grid (default 32)")
    ap.add_argument("--repeats", type=int, default=40, help="estimates of each kind (default 40)")
    ap.add_argument("--runs", type=int, default=7, help="timed draws of each kind (default 7)")
    ap.add_argument("--out", default="results/bench", help="folder for placement.csv")
    args = ap.parse_args(argv)
    if args.grid < 2 or args.repeats < 2 or args.runs < 1:
        print("error: --grid and --repeats must be at least 2, --runs at least 1", file=sys.stderr)
        return 2
    wo = degrees_to_dir(35.0, 20.0)
    rows = []
    print(f"spread of jittered-grid estimates / independent points' ({args.grid}^2 points, {args.repeats} repeats;"
          f" wo at 35 deg, phi 20 deg), and ns a draw with f (own stream / placed points)")  # fmt: skip
    print(
        f"{'strategy':<18}{'model':<8}"
        + "".join(f"{k:>8}" for k in INTEGRANDS)
        + f"{'own ns':>9}{'placed':>9}"
    )
    for label, name, options in CASES:
        for model, params in MODELS:
            sampler = make_sampler(name, make_brdf(model, params), **options)
            if hasattr(sampler, "threads"):
                sampler.threads = False
            ratios = spread_ratios(sampler, wo, args.grid, args.repeats)
            own, placed = draw_ns(sampler, args.runs)
            rows.append({"strategy": label, "model": model, **ratios, "own_ns": own, "placed_ns": placed})
            print(f"{label:<18}{model:<8}" + "".join(f"{v:8.2f}" for v in ratios.values())
                  + f"{own:9.1f}{placed:9.1f}")  # fmt: skip
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv_rows(out / "placement.csv", rows)
    print(f"wrote {out / 'placement.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
