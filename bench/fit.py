"""Fitting analytic models to measured materials: parameter recovery and fit time per model.

    .venv/bin/python bench/fit.py [--models phong,ward] [--metric log] [--out results/bench]

For each case a material is written from a model with known parameters (away from the defaults the fit
starts from) as a MERL ``.binary`` file (isotropic models: MERL tables are isotropic) and as an RGL ``.bsdf``
file (every model), read back, and the same model fitted to it (``core.fit.fit``, 3 starts). Reported per
case: the measurements used, the seconds of the fit (reading the file excluded), the model evaluations, the
residual, and the largest relative error of a recovered parameter (colours: the worst channel) against the
target of 2 %. Prints a table, writes ``fit.csv`` and ``fit.png`` under ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from core.brdf import get_model, make_brdf  # noqa: E402
from core.fit import fit, parameter_errors  # noqa: E402
from core.measured import load_measured, write_measured  # noqa: E402

TARGET = 0.02

CASES: dict[str, tuple[dict, dict]] = {
    # model: (true parameters, parameters fixed in the fit)
    "lambert": ({"kd": (0.6, 0.4, 0.2)}, {}),
    "oren_nayar": ({"sigma": 0.35, "rho": (0.7, 0.5, 0.3)}, {}),
    "phong": ({"n": 60.0, "ks": (0.3, 0.3, 0.3), "kd": (0.5, 0.3, 0.2)}, {}),
    "blinn": ({"n": 40.0, "ks": (0.5, 0.4, 0.3), "kd": (0.3, 0.3, 0.4)}, {}),
    "lewis": ({"n": 200.0, "ks": (0.6, 0.5, 0.4), "kd": (0.2, 0.2, 0.2)}, {}),
    "ggx": (
        {"alpha": 0.15, "eta": (1.5, 1.5, 1.5), "k": (0.0, 0.0, 0.0), "kd": (0.3, 0.2, 0.1)},
        {"eta": (1.5, 1.5, 1.5), "k": (0.0, 0.0, 0.0)},
    ),
    "cook_torrance": (
        {"m": 0.2, "n_real": 1.5, "n_imag": 0.0, "ks": (0.6, 0.6, 0.6), "kd": (0.3, 0.2, 0.2)},
        {"n_real": 1.5, "n_imag": 0.0},
    ),
    "ward": ({"sx": 0.08, "sy": 0.3, "ks": (0.2, 0.2, 0.2), "kd": (0.4, 0.4, 0.3)}, {}),
    "ashikhmin_shirley": ({"nu": 20.0, "nv": 300.0, "ks": (0.3, 0.3, 0.3), "kd": (0.5, 0.4, 0.3)}, {}),
}


def run_case(model: str, fmt: str, folder: Path, metric: str) -> dict:
    truth, fixed = CASES[model]
    brdf = make_brdf(model, truth)
    path = folder / f"{model}{fmt}"
    write_measured(path, brdf)
    source = load_measured(path)
    t0 = time.perf_counter()
    result = fit(source, model, metric, fixed=fixed)
    seconds = time.perf_counter() - t0
    free = {k: brdf.values[k] for k in truth if k not in fixed}
    errors = parameter_errors(result.params, free)
    worst = max(errors, key=errors.get)
    return {
        "model": model,
        "format": fmt,
        "metric": metric,
        "points": result.points,
        "seconds": round(seconds, 3),
        "evaluations": result.evaluations,
        "residual": f"{result.residual:.3e}",
        "max_param_error": f"{errors[worst]:.2e}",
        "worst_param": worst,
        "met": errors[worst] <= TARGET,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--models", default=",".join(CASES), help="comma-separated models")
    parser.add_argument("--metric", choices=("log", "cbrt"), default="log")
    parser.add_argument("--out", type=Path, default=Path("results/bench"))
    args = parser.parse_args(argv)
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    unknown = [m for m in models if m not in CASES]
    if unknown:
        parser.error(f"no case for {', '.join(unknown)}; cases: {', '.join(CASES)}")
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for model in models:
            formats = [".binary", ".bsdf"] if get_model(model).isotropic else [".bsdf"]
            for fmt in formats:
                row = run_case(model, fmt, Path(tmp), args.metric)
                rows.append(row)
                print(
                    f"{row['model']:<18} {row['format']:<8} {row['points']:>7} pts  {row['seconds']:>7.2f} s  "
                    f"{row['evaluations']:>4} evals  residual {row['residual']}  "
                    f"max param error {row['max_param_error']} ({row['worst_param']})  "
                    f"{'met' if row['met'] else 'MISSED'}",
                    flush=True,
                )
    csv_path = args.out / "fit.csv"
    with open(csv_path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print("\n| model | file | points | fit s | evaluations | residual | max parameter error | ≤ 2 % |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['model']} | {r['format']} | {r['points']} | {r['seconds']:.2f} | {r['evaluations']} | "
            f"{r['residual']} | {r['max_param_error']} ({r['worst_param']}) | {'met' if r['met'] else 'missed'} |"
        )
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 4))
        labels = [f"{r['model']}\n{r['format']}" for r in rows]
        ax.bar(
            range(len(rows)), [r["seconds"] for r in rows], color=["C0" if r["met"] else "C3" for r in rows]
        )
        ax.set_xticks(range(len(rows)), labels, rotation=60, fontsize=7)
        ax.set_ylabel("fit time (s)")
        ax.set_title(f"Fit time per model ({args.metric} metric); red: parameters not within 2 %")
        fig.tight_layout()
        fig.savefig(args.out / "fit.png", dpi=120)
        print(f"wrote {csv_path}, {args.out / 'fit.png'}")
    except ImportError:
        print(f"wrote {csv_path}")
    return 0 if all(r["met"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
