"""Compilation cost of the per-model kernels in a new process: cold (empty kernel cache) vs warm.

    .venv/bin/python bench/kernel_cache.py [--out results/bench]

Two cases, each measured in a fresh Python process twice: first with an empty ``$BRDF_STUDIO_KERNEL_CACHE``
folder (everything compiled), then with the folder the first one filled (``core.specialize`` modules loaded
from numba's disk cache):

- ``eval``: the batch ``eval`` drivers (serial and threaded) of every registered model, once on 1000
  direction pairs;
- ``adaptive``: the first adaptive tree of one model (Phong; construction kernels) and 1000 samples from it
  (sampling kernels), with a private table cache so the tree is really built.

Prints a table, writes ``kernel_cache.csv``.
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
SCRIPT_EVAL = """
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

SCRIPT_ADAPTIVE = """
import tempfile
import time
import numpy as np
from core.model import make_brdf
from core.sampler import make_sampler
t = time.perf_counter()
s = make_sampler("adaptive", make_brdf("phong"), cache=tempfile.mkdtemp())
s.sample(np.array([0.5, 0.0, 0.75 ** 0.5]), 1000, 1)
print(time.perf_counter() - t, 1)
"""
CASES = {
    "eval": ("eval drivers of every model (serial + threaded)", SCRIPT_EVAL),
    "adaptive": ("first adaptive tree and 1000 samples (Phong)", SCRIPT_ADAPTIVE),
}


def measure(folder: str, script: str) -> tuple[float, int]:
    env = {**os.environ, "BRDF_STUDIO_KERNEL_CACHE": folder}
    out = subprocess.run([sys.executable, "-c", script], env=env, cwd=ROOT, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"the measurement process failed:\n{out.stderr}")
    seconds, models = out.stdout.split()
    return float(seconds), int(models)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("results/bench"))
    a = ap.parse_args(argv)
    rows = []
    print("new process, seconds: cold (empty kernel cache) / warm (the cache the cold run filled)")
    for key, (label, script) in CASES.items():
        with tempfile.TemporaryDirectory(prefix="bench-kernels-") as folder:
            cold, models = measure(folder, script)
            warm, _ = measure(folder, script)
        rows.append([key, models, f"{cold:.3f}", f"{warm:.3f}"])
        print(f"  {label:<50} {cold:7.2f} / {warm:6.2f}")
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "kernel_cache.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["case", "models", "cold_s", "warm_s"])
        w.writerows(rows)
    print(f"wrote {a.out / 'kernel_cache.csv'}")


if __name__ == "__main__":
    main()
