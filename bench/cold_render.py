"""Seconds from an empty table cache to a finished small render of the demo scene: both adaptive modes against uniform.

    .venv/bin/python bench/cold_render.py [--spp 4] [--size 288x192] [--out results/bench] [--keep DIR]

Each render is ``brdf-studio render --demo --sampler S`` in a new process, timed whole (what a user waits
for), with a private table cache (``$BRDF_STUDIO_CACHE``). Per sampler: first a 32 x 24 render with a
throwaway table cache, so that numba's kernels are compiled if setup did not compile them (they have their own
cache; not counted); then the render twice with one fresh cache folder: ``cold`` builds the table of every
material of the scene (the adaptive sampler makes a material's whole table at once, on all cores), ``warm``
loads them from disk. ``uniform`` has no tables: its two runs are the baseline of process start, loading and
tracing. The breakdown comes from the render's JSON sidecar: preparation (geometry, kernels, tables) and
tracing seconds, and the tables' build seconds summed over the materials. ``--keep DIR`` uses ``DIR`` as the
adaptive sampler's table cache and leaves it filled (to warm the app's cache, pass its folder).

Prints a table, writes ``cold_render.csv``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SAMPLERS = ("adaptive_warp", "adaptive_exact", "uniform")


def render(sampler: str, cache: Path, spp: int, width: int, height: int, out_exr: Path) -> dict[str, Any]:
    """One render in a new process: its wall-clock seconds and the breakdown its sidecar records."""
    env = {**os.environ, "BRDF_STUDIO_CACHE": str(cache)}
    cmd = [sys.executable, "-m", "app.cli", "render", "--demo", "--sampler", sampler, "--spp", str(spp)]
    cmd += ["--width", str(width), "--height", str(height), "-o", str(out_exr), "--quiet"]
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    info = json.loads(out_exr.with_suffix(".json").read_text())
    prep = info["prepare"]
    materials = prep.get("materials", {}).values()
    return {
        "wall_s": wall,
        "prepare_s": prep["seconds"],
        "tables_build_s": sum(m.get("build_seconds", 0.0) for m in materials if not m.get("from_cache")),
        "tables_loaded": sum(1 for m in materials if m.get("from_cache")),
        "render_s": info["render_seconds"],
    }  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--size", default="288x192", help="WIDTHxHEIGHT")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    ap.add_argument(
        "--keep", type=Path, help="adaptive table cache folder to fill and keep (default: a temporary one)"
    )
    a = ap.parse_args(argv)
    try:
        width, height = (int(v) for v in a.size.lower().split("x"))
    except ValueError:
        ap.error(f"--size must be WIDTHxHEIGHT, got {a.size!r}")
    if a.spp < 1 or width < 1 or height < 1:
        ap.error("--spp and the size must be positive")
    if a.keep is not None and a.keep.exists() and any(a.keep.glob("*/*.npz")):
        ap.error(f"{a.keep} already holds tables: the first run would not be cold")
    rows = []
    print("sampler       case   wall s  prepare s  tables s  loaded  render s")
    with tempfile.TemporaryDirectory(prefix="bench-cold-") as tmp_name:
        tmp = Path(tmp_name)
        for sampler in SAMPLERS:
            kernels = render(sampler, tmp / f"throwaway-{sampler}", 1, 32, 24, tmp / "kernels.exr")
            print(
                f"{sampler:<13} (kernels compiled or loaded, not counted: {kernels['wall_s']:.1f} s)",
                flush=True,
            )
            keep = a.keep is not None and sampler == "adaptive_exact"
            cache = a.keep if keep else tmp / f"tables-{sampler}"
            for case in ("cold", "warm"):
                r = render(sampler, cache, a.spp, width, height, tmp / f"{sampler}-{case}.exr")
                rows.append(
                    {"sampler": sampler, "case": case, "spp": a.spp, "size": f"{width}x{height}", **r}
                )
                print(f"{sampler:<13} {case:<5} {r['wall_s']:7.2f} {r['prepare_s']:10.2f} "
                      f"{r['tables_build_s']:9.2f} {r['tables_loaded']:7d} {r['render_s']:9.2f}",
                      flush=True)  # fmt: skip
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "cold_render.csv"
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
