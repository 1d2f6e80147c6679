"""Variance per sample at equal sample count: every sampler, every model, three kinds of lighting.

    .venv/bin/python bench/variance.py [--models phong,ward] [--n 262144] [--rotations 64] [--out results/bench]

For the estimator ``Y = f L cos / p`` of the reflected radiance ``L_r(wo) = int f L cos dw`` (luminance), the
variance per sample of every registered sampler with density ``p`` is

    Var_p = int (f cos L)^2 / p dw - L_r^2,

computed here from each sampler's exact ``pdf(wo, wi)`` on one common set of directions drawn from the density
``q = f cos / I`` (the adaptive sampler's): ``int (f cos L)^2 / p dw = E_q[I f cos L^2 / p]`` and
``L_r = E_q[I L]``. Common directions make ties exact (two samplers with the same density get the same number)
and differences far less noisy than independent runs; the same ``f cos / I`` density covers the support of
every integrand, so the estimates are unbiased.

Lighting: the **furnace** (``L = 1``: the quantity a BRDF sampler is designed for); a fixed **sky** (the
gradient-plus-sun environment of ``bench/adaptive.py``); and the **rotation average** of that sky over
``--rotations`` uniformly random rotations. Averaged over all rotations, ``E[L^2]`` is the same in every
direction, so the mean variance is ``c int (f cos)^2 / p dw - const``, which by Cauchy-Schwarz is smallest for
``p = f cos / I``: the adaptive sampler is optimal for the average environment and for the furnace, while for
one fixed environment a density that happens to follow ``L`` can beat it. Prints a table, writes
``variance.csv`` and ``variance.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from core.brdf import LUMINANCE, all_models  # noqa: E402
from core.geometry import degrees_to_dir  # noqa: E402
from core.sampling import applicable_samplers, make_sampler  # noqa: E402

THETAS = (30.0, 60.0, 80.0)
SUN = np.array([0.35, 0.2, 1.0]) / np.linalg.norm([0.35, 0.2, 1.0])
LIGHTINGS = ("furnace", "sky", "rotated_sky")
TIE = 1e-4
"""Relative tolerance for a tie (two samplers with the same density up to the normalizer's accuracy)."""


def sky(w: np.ndarray) -> np.ndarray:
    """The environment of ``bench/adaptive.py`` (defined on the whole sphere)."""
    return 0.3 + 0.7 * np.maximum(w[:, 2], 0.0) + 4.0 * np.exp(-12.0 * (1.0 - w @ SUN))


def variances(brdf, wo: np.ndarray, n: int, rotations: np.ndarray, seed: int) -> dict[str, dict[str, float]]:
    """``{sampler: {lighting: variance per sample}}`` at one ``wo`` (``inf`` where a sampler misses f)."""
    q = make_sampler("adaptive_exact", brdf)
    drawn = q.sample(wo, n, seed)
    wi, q_pdf = drawn.wi, drawn.pdf
    wos = np.broadcast_to(wo, wi.shape)
    fcos = (drawn.f @ LUMINANCE) * wi[:, 2]
    norm = float(np.median(fcos / q_pdf))  # I(wo): f cos / q is the same for every sample
    lights = {"furnace": np.ones((1, n)), "sky": sky(wi)[None, :]}
    lights["rotated_sky"] = np.stack([sky(wi @ r.T) for r in rotations])
    out: dict[str, dict[str, float]] = {}
    for name in applicable_samplers(brdf):
        s = q if name == "adaptive_exact" else make_sampler(name, brdf)
        p = q_pdf if name == "adaptive_exact" else s.pdf(wos, wi)
        row = {}
        for lighting, L in lights.items():
            mean = (norm * L).mean(axis=1)  # L_r per lighting instance
            if np.any((p <= 0.0) & (fcos > 0.0)):
                row[lighting] = math.inf
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                m2 = np.where(p > 0.0, norm * fcos * L**2 / p, 0.0).mean(axis=1)
            row[lighting] = float(np.mean(m2 - mean**2))
        out[name] = row
    return out


def run(models: list[str] | None, n: int, n_rot: int, out: Path) -> list[dict]:
    rotations = Rotation.random(n_rot, random_state=12345).as_matrix()
    rows = []
    for model in all_models():
        if models and model.name not in models:
            continue
        brdf = model.bind()
        total: dict[str, dict[str, float]] = {}
        for t in THETAS:
            for name, row in variances(brdf, degrees_to_dir(t, 20.0), n, rotations, seed=7).items():
                acc = total.setdefault(name, dict.fromkeys(LIGHTINGS, 0.0))
                for k in LIGHTINGS:
                    acc[k] += row[k]
        record: dict = {"model": model.name}
        line = f"{model.name:<18}"
        for k in LIGHTINGS:
            others = {s: v[k] for s, v in total.items() if s != "adaptive_exact"}
            best = min(others, key=others.get)
            ad = total["adaptive_exact"][k]
            ratio = ad / others[best] if others[best] > 0 else (1.0 if ad == 0 else math.inf)
            # ties within TIE: the adaptive pdf's normalizer is interpolated to ~1e-6 relative
            met = ad <= others[best] * (1.0 + TIE) or abs(ad) <= 1e-9 * max(abs(others[best]), 1.0)
            record.update(
                {
                    f"{k}_adaptive": ad,
                    f"{k}_best": best,
                    f"{k}_best_variance": others[best],
                    f"{k}_ratio": ratio,
                    f"{k}_met": met,
                }
            )
            for s, v in total.items():
                record[f"{k}_{s}"] = v[k]
            line += f" | {k}: {ad:9.3g} vs {best} {others[best]:9.3g} ({'met' if met else f'x{ratio:.3f}'})"
        rows.append(record)
        print(line, flush=True)
    out.mkdir(parents=True, exist_ok=True)
    keys = sorted({k for r in rows for k in r}, key=lambda k: (k != "model", k))
    with open(out / "variance.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    plot(rows, out / "variance.png")
    print(f"wrote {out / 'variance.csv'} and {out / 'variance.png'}")
    return rows


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(11, 4), layout="constrained")
    x = np.arange(len(rows))
    for j, k in enumerate(LIGHTINGS[1:]):
        ratios = [max(r[f"{k}_ratio"], 1e-3) for r in rows]
        ax.bar(x + (j - 0.5) * 0.4, ratios, width=0.4, label=k.replace("_", " "))
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(x, [r["model"] for r in rows], rotation=60, ha="right")
    ax.set_ylabel("adaptive variance / best other sampler's")
    ax.set_title("Equal samples, sum over theta_o in {30, 60, 80} deg (furnace: adaptive = 0, not drawn)")
    ax.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", default="", help="comma-separated model names (default: all)")
    ap.add_argument("--n", type=int, default=1 << 18, help="common directions per incident angle")
    ap.add_argument("--rotations", type=int, default=64, help="random rotations of the sky to average")
    ap.add_argument("--out", type=Path, default=Path("results/bench"))
    a = ap.parse_args(argv)
    models = [m for m in a.models.split(",") if m]
    unknown = sorted(set(models) - {m.name for m in all_models()})
    if unknown:
        ap.error(f"unknown model(s): {', '.join(unknown)}")
    if a.n <= 0 or a.rotations <= 0:
        ap.error("--n and --rotations must be positive")
    run(models or None, a.n, a.rotations, a.out)


if __name__ == "__main__":
    main()
