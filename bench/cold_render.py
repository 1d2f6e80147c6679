"""A render of the demo scene with the adaptive sampler, from empty tables (cold) and again (warm).

    .venv/bin/python bench/cold_render.py [--spp 4] [--size 288x192] [--out results/bench] [--keep DIR]

Runs ``brdf-studio render --demo --sampler adaptive`` in new processes with a private table cache
(``$BRDF_STUDIO_CACHE``): first a 32 x 24 render with a throwaway table cache, so that the models' kernels
are compiled (they have their own cache) and compilation is not counted; then the render itself twice: the
first run builds every tree the scene meets (the warm-up pre-pass's bins, then those the passes meet), the
second loads them from disk. Wall-clock time of each whole process. The demo's anisotropic brushed steel
dominates the cold run: its grazing bins are the most expensive trees we build. ``--keep DIR`` uses ``DIR``
as the table cache and leaves it filled (to warm the app's cache, pass its folder).

Prints a table, writes ``cold_render.csv``.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(cache: Path, spp: int, width: int, height: int, out_exr: Path) -> float:
    env = {**os.environ, "BRDF_STUDIO_CACHE": str(cache)}
    cmd = [sys.executable, "-m", "app.cli", "render", "--demo", "--sampler", "adaptive", "--spp", str(spp)]
    cmd += ["--width", str(width), "--height", str(height), "-o", str(out_exr), "--quiet"]
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--size", default="288x192", help="WIDTHxHEIGHT")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    ap.add_argument(
        "--keep", type=Path, help="table cache folder to fill and keep (default: a temporary one)"
    )
    a = ap.parse_args(argv)
    width, height = (int(v) for v in a.size.lower().split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        cache = a.keep if a.keep is not None else Path(tmp) / "tables"
        if cache.exists() and any(cache.glob("*/bin*.npz")):
            print(f"{cache} already holds tables: the first run would not be cold", file=sys.stderr)
            return 2
        seconds = run(Path(tmp) / "throwaway", 1, 32, 24, Path(tmp) / "kernels.exr")
        print(f"kernels (compiled or loaded, not counted): {seconds:.1f} s", flush=True)
        rows = []
        for case in ("cold", "warm"):
            seconds = run(cache, a.spp, width, height, Path(tmp) / f"{case}.exr")
            rows.append(
                {"case": case, "spp": a.spp, "size": f"{width}x{height}", "seconds": round(seconds, 1)}
            )
            print(f"{case:<5} {a.spp} spp {width}x{height}: {seconds:7.1f} s", flush=True)
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "cold_render.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
