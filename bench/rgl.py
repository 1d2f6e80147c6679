"""RGL ``.bsdf`` files written from analytic models: export cost, size, lookup accuracy, agreement with
Mitsuba 3's ``measured`` plugin, and the luminance warp's weights.

    .venv/bin/python bench/rgl.py [--models phong,ward] [--out results/bench]

Per model (default export resolution, ``core.rgl.export.ExportOptions()``):

* export seconds (``tabulate``, compile excluded: a warm-up export runs first) and file size;
* at the export's nodes (``node_pairs``): the largest relative error of the lookup against the analytic ``f``
  (float32 storage is the only difference);
* between nodes: median and 95th percentile relative error over 20 000 random pairs (``theta_o < 80`` deg,
  ``wi.z > 0.1``, ``f`` above 1 % of its maximum, green channel) — the table's resolution;
* Mitsuba 3 (``scalar_rgb``, an independent float32 reader of the same file): the largest relative difference
  of ``f cos`` and of the sampling density over 300 random pairs;
* relative standard deviation of the weight ``f cos / pdf`` at ``theta_o = 30`` deg for the file's own
  luminance warp (``analytic`` sampler of a ``.bsdf`` material) and for cosine sampling.

Prints a table, writes ``rgl.csv``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from core.brdf import LUMINANCE, make_brdf  # noqa: E402
from core.geometry import degrees_to_dir  # noqa: E402
from core.io import write_csv_rows  # noqa: E402
from core.rgl.export import eval_table, node_pairs, tabulate  # noqa: E402
from core.rgl.material import kernel_vector, rgl_brdf, write_bsdf  # noqa: E402
from core.sampling import make_sampler  # noqa: E402

MODELS = {
    "lambert": {"kd": 0.8},
    "phong": {"n": 100.0},
    "ggx": {"alpha": 0.2},
    "cook_torrance": {},
    "ward": {"sx": 0.05, "sy": 0.25},
    "ashikhmin_shirley": {"nu": 10.0, "nv": 200.0},
}


def _pairs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    def dirs() -> np.ndarray:
        v = rng.normal(size=(4 * n, 3))
        v[:, 2] = np.abs(v[:, 2])
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    wi, wo = dirs(), dirs()
    keep = (wi[:, 2] > 0.1) & (np.degrees(np.arccos(wo[:, 2])) < 80.0)
    return wi[keep][:n], wo[keep][:n]


def _mitsuba(path: Path, brdf, rng: np.random.Generator) -> tuple[float, float]:
    try:
        import mitsuba as mi
    except ImportError:
        return float("nan"), float("nan")
    mi.set_variant("scalar_rgb")
    bsdf = mi.load_dict({"type": "measured", "filename": str(path)})
    ctx = mi.BSDFContext()
    wi, wo = _pairs(rng, 300)
    ours = brdf.eval(wo, wi) * wi[:, 2:]
    ours_pdf = make_sampler("analytic", brdf).pdf(wo, wi)
    theirs, theirs_pdf = [], []
    for a, c in zip(wi, wo, strict=True):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*c)
        v = bsdf.eval(ctx, si, mi.Vector3f(*a))
        theirs.append([v[0], v[1], v[2]])
        theirs_pdf.append(bsdf.pdf(ctx, si, mi.Vector3f(*a)))
    theirs, theirs_pdf = np.array(theirs), np.array(theirs_pdf)
    e = np.max(np.abs(ours - theirs) / np.maximum(np.abs(theirs), 1e-3 * theirs.max()))
    p = np.max(np.abs(ours_pdf - theirs_pdf) / np.maximum(theirs_pdf, 1e-3 * theirs_pdf.max()))
    return float(e), float(p)


def _weight_std(sampler, wo: np.ndarray) -> float:
    d = sampler.sample(wo, 200_000, seed=3)
    ok = d.pdf > 0.0
    w = (d.f[ok] @ LUMINANCE) * np.maximum(d.wi[ok, 2], 0.0) / d.pdf[ok]
    return float(w.std() / w.mean())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--out", type=Path, default=Path("results/bench"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    tabulate(make_brdf("lambert"))  # compile the exporter's loops once
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.models.split(","):
            rng = np.random.default_rng(7)
            brdf = make_brdf(name, MODELS[name])
            t0 = time.perf_counter()
            table = tabulate(brdf)
            seconds = time.perf_counter() - t0
            path = Path(tmp) / f"{name}.bsdf"
            write_bsdf(path, table)
            p = kernel_vector(table)
            wi, wo, _ = node_pairs(table)
            keep = wi[:, 2] > 0.05
            f, g = brdf.eval(wo[keep], wi[keep]), eval_table(p, wi[keep], wo[keep])
            big = f > 1e-3 * f.max()
            node_err = float(np.max(np.abs(g[big] - f[big]) / f[big]))
            wi, wo = _pairs(rng, 20_000)
            f, g = brdf.eval(wo, wi)[:, 1], eval_table(p, wi, wo)[:, 1]
            big = f > 1e-2 * f.max()
            rel = np.abs(g[big] - f[big]) / f[big]
            material = rgl_brdf(path)
            mi_eval, mi_pdf = _mitsuba(path, material, rng)
            wo30 = degrees_to_dir(30.0, 20.0)
            row = {
                "model": name,
                "slices": f"{table.phi_i.size}x{table.theta_i.size}",
                "export_s": round(seconds, 2),
                "file_MB": round(path.stat().st_size / 1e6, 2),
                "node_max_rel": f"{node_err:.1e}",
                "median_rel": f"{np.median(rel):.4f}",
                "p95_rel": f"{np.percentile(rel, 95):.3f}",
                "mitsuba_eval_max_rel": f"{mi_eval:.1e}",
                "mitsuba_pdf_max_rel": f"{mi_pdf:.1e}",
                "weight_std_warp": round(_weight_std(make_sampler("analytic", material), wo30), 3),
                "weight_std_cosine": round(_weight_std(make_sampler("cosine", brdf), wo30), 3),
            }
            rows.append(row)
            print(row, flush=True)
    print("\n| " + " | ".join(rows[0]) + " |")
    print("|" + "---|" * len(rows[0]))
    for r in rows:
        print("| " + " | ".join(str(v) for v in r.values()) + " |")
    write_csv_rows(args.out / "rgl.csv", rows)
    print(f"wrote {args.out / 'rgl.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
