"""Compilation cost of the per-model kernel drivers in a new process: cold (empty kernel cache) vs warm.

    .venv/bin/python bench/kernel_cache.py [--out results/bench]

Each measurement is a fresh Python process that imports the library and runs the batch ``eval`` drivers
(serial and threaded) of every registered model once on 1000 direction pairs; the first uses an empty
``$BRDF_STUDIO_KERNEL_CACHE`` folder (everything compiled), the second the folder the first one filled
(``core.specialize`` modules loaded from numba's disk cache). Prints a table, writes ``kernel_cache.csv``.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = """
import time
import numpy as np
from core import kernels
from core.model import all_models
wi = np.random.default_rng(0).normal(size=(1000, 3))
wi[:, 2] = np.abs(wi[:, 2])
wi /= np.linalg.norm(wi, axis=1)[:, None]
t = time.perf_counter()
for m in all_models():
    b = m.bind()
    kernels.eval_batch(b.model, wi, wi, b.params)
    kernels.eval_batch(b.model, wi, wi, b.params, threads=True)
print(time.perf_counter() - t, len(all_models()))
"""


def measure(folder: str) -> tuple[float, int]:
    env = {**os.environ, "BRDF_STUDIO_KERNEL_CACHE": folder}
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, cwd=ROOT, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"the measurement process failed:\n{out.stderr}")
    seconds, models = out.stdout.split()
    return float(seconds), int(models)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("results/bench"))
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench-kernels-") as folder:
        cold, models = measure(folder)
        warm, _ = measure(folder)
    print(f"eval drivers of {models} models (serial + threaded), new process:")
    print(f"  cold (empty kernel cache): {cold:6.2f} s")
    print(f"  warm (cache from the run before): {warm:6.2f} s")
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "kernel_cache.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["models", "cold_s", "warm_s"])
        w.writerow([models, f"{cold:.3f}", f"{warm:.3f}"])
    print(f"wrote {a.out / 'kernel_cache.csv'}")


if __name__ == "__main__":
    main()
