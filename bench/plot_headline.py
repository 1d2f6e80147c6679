"""The README's figure: error against time on Mitsuba's Cornell box (ours against Mitsuba 3), and the demo
scene's equal-time error per strategy (uniform, analytic, the two adaptive modes).

    .venv/bin/python bench/plot_headline.py [--results docs/results] [--out docs/results/headline.png]

Reads the two tables kept in ``docs/results`` (each written from a run of its benchmark; the commands are in
``docs/results/renderer.md``):

- ``cornell_time_to_rmse.csv``: seconds to reach each RMSE against an 8192-spp Mitsuba reference, from
  ``python bench/render.py --cornell --time 20 --skip-scalar``;
- ``demo_equal_time.csv``: RMSE after 20 s of rendering, divided by uniform's, three seeds, from
  ``python bench/render.py --size 512 --time 20 --skip-throughput --strategies
  uniform,analytic,adaptive_exact,adaptive_warp --seed S``.

Runs in a second; renders nothing.
"""

from __future__ import annotations

import argparse
import csv
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
STRATEGIES = ("uniform", "analytic", "adaptive_exact", "adaptive_warp")


def read_rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--results", type=Path, default=ROOT / "docs" / "results")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "results" / "headline.png")
    args = ap.parse_args(argv)

    curves: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for row in read_rows(args.results / "cornell_time_to_rmse.csv"):
        curves[row["renderer"]].append((float(row["seconds"]), float(row["rmse"])))
    ratios: dict[str, list[float]] = defaultdict(list)
    for row in read_rows(args.results / "demo_equal_time.csv"):
        ratios[row["strategy"]].append(float(row["rmse_over_uniform"]))

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1.25, 1]})
    for name, points in curves.items():
        seconds, rmse = zip(*sorted(points), strict=True)
        left.loglog(seconds, rmse, "o-", label=name)
    left.set_xlabel("render time (s)")
    left.set_ylabel("RMSE against the reference")
    left.set_title("Mitsuba's Cornell box, 256², time to each error")
    left.grid(True, which="both", alpha=0.3)
    left.legend(fontsize=8)

    names = [s for s in STRATEGIES if s in ratios]
    for i, name in enumerate(names):
        values = ratios[name]
        right.bar(i, sorted(values)[len(values) // 2], color=f"C{i}", alpha=0.5)
        right.plot([i] * len(values), values, "k.", markersize=8)
    right.axhline(0.2, color="grey", linestyle="--", linewidth=1)
    right.text(len(names) - 0.5, 0.205, "1/5 of uniform", ha="right", va="bottom", fontsize=8, color="grey")
    right.set_xticks(
        range(len(names)),
        [n.replace("_", "_\n", 1) if n.startswith("adaptive_") else n for n in names],
    )
    right.set_ylabel("RMSE ÷ uniform's (three seeds)")
    right.set_title("Demo scene, 512², 20 s each")
    right.set_ylim(0, 1.05)
    right.grid(True, axis="y", alpha=0.3)

    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
