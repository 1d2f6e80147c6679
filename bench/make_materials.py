"""Write a synthetic folder of measured materials for the folder study (not committed: ~300 MB).

    .venv/bin/python bench/make_materials.py --out results/materials [--small]

22 materials written from analytic models with varied parameters: 8 MERL ``.binary`` files (isotropic
models: MERL tables are isotropic) and 14 RGL ``.bsdf`` files, 5 of them anisotropic (Ward, Ashikhmin-Shirley,
Lafortune). ``--small`` writes the ``.bsdf`` files only (14). Existing files are overwritten.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from core.brdf import make_brdf  # noqa: E402
from core.measured import load_measured, write_measured  # noqa: E402

MATERIALS: list[tuple[str, str, dict]] = [
    # (file name, model, parameters)
    ("lambert_grey.binary", "lambert", {"kd": 0.5}),
    ("phong_30.binary", "phong", {"n": 30.0, "ks": 0.3, "kd": 0.5}),
    ("phong_300.binary", "phong", {"n": 300.0, "ks": 0.5, "kd": 0.2}),
    ("blinn_80.binary", "blinn", {"n": 80.0, "ks": 0.6, "kd": (0.4, 0.2, 0.1)}),
    ("ggx_010.binary", "ggx", {"alpha": 0.1}),
    ("cook_torrance_030.binary", "cook_torrance", {"m": 0.3}),
    ("oren_nayar_030.binary", "oren_nayar", {"sigma": 0.3, "rho": (0.8, 0.6, 0.4)}),
    ("lewis_50.binary", "lewis", {"n": 50.0, "ks": 0.7, "kd": 0.2}),
    ("lambert_warm.bsdf", "lambert", {"kd": (0.7, 0.5, 0.3)}),
    ("phong_100.bsdf", "phong", {"n": 100.0}),
    ("blinn_20.bsdf", "blinn", {"n": 20.0, "ks": 0.4, "kd": 0.4}),
    ("ggx_030.bsdf", "ggx", {"alpha": 0.3}),
    ("ggx_005.bsdf", "ggx", {"alpha": 0.05, "kd": (0.1, 0.1, 0.2)}),
    ("cook_torrance_015.bsdf", "cook_torrance", {"m": 0.15}),
    ("oren_nayar_050.bsdf", "oren_nayar", {"sigma": 0.5}),
    ("beard_maxwell.bsdf", "beard_maxwell", {}),
    ("strauss.bsdf", "strauss", {}),
    ("ward_005_025.bsdf", "ward", {"sx": 0.05, "sy": 0.25}),
    ("ward_030_010.bsdf", "ward", {"sx": 0.3, "sy": 0.1, "kd": (0.3, 0.3, 0.5)}),
    ("ashikhmin_shirley_10_200.bsdf", "ashikhmin_shirley", {"nu": 10.0, "nv": 200.0}),
    ("ashikhmin_shirley_100_20.bsdf", "ashikhmin_shirley", {"nu": 100.0, "nv": 20.0}),
    ("lafortune.bsdf", "lafortune", {"kd": 0.2}),
]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("results/materials"))
    parser.add_argument("--small", action="store_true", help="the .bsdf files only")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, model, params in MATERIALS:
        if args.small and not name.endswith(".bsdf"):
            continue
        t0 = time.perf_counter()
        path = args.out / name
        write_measured(path, make_brdf(model, params))
        brdf = load_measured(path)
        print(
            f"{name:<32} {brdf.model.name:<16} {path.stat().st_size / 1e6:7.1f} MB  {time.perf_counter() - t0:5.1f} s"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
