"""Seconds numba spends compiling after setup, in new processes: the adaptive sampler, an adaptive render.

    .venv/bin/python bench/compile.py [--skip-setup] [--out results/bench]

Setup first, as ``make setup`` runs it (``python -m core.warmup``, then ``python -m renderer.tracer_warmup``; each
compiles what is missing from numba's disk cache and loads the rest; ``--skip-setup`` when it has just run).
Then each case runs in a new Python process (this script with ``--case NAME``) that listens to numba's
``numba:compile`` event, which fires only when a function is really compiled (a function loaded from the disk
cache does not fire it; nested compiles of callees are counted once, inside their caller's):

- ``adaptive phong`` and ``adaptive ward``: a Phong table and an anisotropic Ward table (``sx = 0.05,
  sy = 0.25``) built with the sampler's defaults (no disk cache), then both modes' draws, densities,
  normalizer and acceptance on a batch of views;
- ``render adaptive``: a 32 x 24, 1 spp render of the demo scene with ``sampler="adaptive_exact"`` through
  :func:`renderer.render.render`, the table cache (``$BRDF_STUDIO_CACHE``) a fresh temporary folder, so
  every table the scene needs is built in the process.

Target: no process compiles for more than 1 s after setup. Prints a table (the slowest compiled functions
named) and writes ``compile.csv``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numba.core import event

ROOT = Path(__file__).resolve().parents[1]
TARGET_S = 1.0
"""The most a process may spend compiling after setup."""


class OutermostTimer(event.Listener):
    """The outermost events of one kind, per thread: a callee compiled while its caller is typed fires a
    nested ``numba:compile``, and the compiler lock is re-entrant; counting only the outermost counts each
    second once."""

    def __init__(self) -> None:
        self.depth: dict[int, int] = {}
        self.started: dict[int, float] = {}
        self.intervals: list[tuple[str, float, float]] = []
        """``(function, start, end)`` of every outermost event, in order."""
        self.events = 0
        """Every event, nested ones included."""

    def on_start(self, ev: event.Event) -> None:
        tid = threading.get_ident()
        depth = self.depth.get(tid, 0)
        if depth == 0:
            self.started[tid] = time.perf_counter()
        self.depth[tid] = depth + 1
        self.events += 1

    def on_end(self, ev: event.Event) -> None:
        tid = threading.get_ident()
        self.depth[tid] -= 1
        if self.depth[tid] == 0:
            self.intervals.append((_function_name(ev.data), self.started[tid], time.perf_counter()))

    @property
    def compiled(self) -> list[tuple[str, float]]:
        """``(function, seconds)`` of the outermost events."""
        return [(name, end - start) for name, start, end in self.intervals]

    @property
    def busy_seconds(self) -> float:
        """Seconds during which some thread was inside an event (overlaps between threads counted once:
        threads waiting for the compiler lock overlap the one holding it)."""
        total = 0.0
        reach = -math.inf
        for _, start, end in sorted(self.intervals, key=lambda i: i[1]):
            if end > reach:
                total += end - max(start, reach)
                reach = end
        return total


def _function_name(data: Any) -> str:
    dispatcher = data.get("dispatcher") if isinstance(data, dict) else None
    func = getattr(dispatcher, "py_func", None)
    if func is None:
        return repr(dispatcher)
    return f"{func.__module__}.{func.__qualname__}"


# ------------------------------------------------------------------------------------------ the cases
def _adaptive(model: str, params: dict[str, Any]) -> None:
    from core.brdf import make_brdf
    from core.sampling import make_sampler
    from core.sampling.adaptive import AdaptiveSampler

    brdf = make_brdf(model, params)
    wo = np.random.default_rng(3).normal(size=(4096, 3))
    wo[:, 2] = np.abs(wo[:, 2])
    wo /= np.linalg.norm(wo, axis=1)[:, None]
    for name in ("adaptive_exact", "adaptive_warp"):
        sampler = make_sampler(name, brdf, cache=False)
        assert isinstance(sampler, AdaptiveSampler)
        sampler.preload()
        drawn = sampler.sample_each(wo, seed=1)
        sampler.eval_pdf(wo, drawn.wi)
        sampler.normalizer(wo)
        sampler.acceptance(wo)


def _render_adaptive() -> None:
    from importlib.resources import files

    from core.scene import load_scene
    from renderer.render import render

    scene = load_scene(str(files("resources") / "scenes" / "demo" / "demo.json"))
    render(scene, spp=1, width=32, height=24, sampler="adaptive_exact")


CASES: dict[str, Callable[[], None]] = {
    "adaptive phong": lambda: _adaptive("phong", {}),
    "adaptive ward": lambda: _adaptive("ward", {"sx": 0.05, "sy": 0.25}),
    "render adaptive": _render_adaptive,
}


def measure_here(case: str) -> dict[str, Any]:
    """Run ``case`` in this process with the compile timer listening (what ``--case`` prints as JSON)."""
    compiles = OutermostTimer()
    lock = OutermostTimer()
    t0 = time.perf_counter()
    with (
        event.install_listener("numba:compile", compiles),
        event.install_listener("numba:compiler_lock", lock),
    ):
        CASES[case]()
    wall = time.perf_counter() - t0
    slowest = sorted(compiles.compiled, key=lambda c: -c[1])[:3]
    return {"case": case, "wall_s": wall, "compile_s": compiles.busy_seconds,
            "compiles": len(compiles.intervals), "compile_events": compiles.events,
            "lock_s": lock.busy_seconds, "slowest": slowest}  # fmt: skip


# ------------------------------------------------------------------------------------------ the parent
@dataclass
class Measurement:
    case: str
    process_s: float
    """The whole process, start-up and imports included."""
    wall_s: float
    """The case itself."""
    compile_s: float
    compiles: int
    compile_events: int
    lock_s: float
    """Seconds the compiler lock was taken or waited for: compiles and loads from numba's disk cache."""
    slowest: list[tuple[str, float]] = field(default_factory=list)


def setup() -> float:
    """Run the setup's warm-ups (what ``make setup`` runs) and return their seconds."""
    t0 = time.perf_counter()
    for module in ("core.warmup", "renderer.tracer_warmup"):
        done = subprocess.run([sys.executable, "-m", module], cwd=ROOT, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"python -m {module} failed:\n{done.stderr}")
        total = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else "(no output)"
        print(f"setup: python -m {module}: {total.strip()}", flush=True)
    return time.perf_counter() - t0


def measure(case: str) -> Measurement:
    """``case`` in a new process, with a fresh table cache."""
    with tempfile.TemporaryDirectory(prefix="bench-compile-") as cache:
        env = {**os.environ, "BRDF_STUDIO_CACHE": cache}
        t0 = time.perf_counter()
        cmd = [sys.executable, __file__, "--case", case]
        done = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"the process of case '{case}' failed:\n{done.stderr}")
    process = time.perf_counter() - t0
    data = json.loads(done.stdout.strip().splitlines()[-1])
    data["process_s"] = process
    data["slowest"] = [tuple(s) for s in data["slowest"]]
    return Measurement(**data)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--skip-setup", action="store_true", help="the warm-ups have just run: do not run them")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench", help="folder for the CSV")
    ap.add_argument("--case", choices=sorted(CASES), help=argparse.SUPPRESS)  # a measurement process
    a = ap.parse_args(argv)
    if a.case:
        print(json.dumps(measure_here(a.case)))
        return 0
    if not a.skip_setup:
        setup()
    rows = [measure(case) for case in CASES]
    print(f"\nnumba compilation in a new process after setup (target: at most {TARGET_S:g} s per process)")
    width = max(len(c) for c in CASES)
    print(
        f"{'case':<{width}}  process s  case s  compile s  compiled  met  lock s  slowest compiled functions"
    )
    for m in rows:
        met = "yes" if m.compile_s <= TARGET_S else "NO"
        slowest = ", ".join(f"{name.rsplit('.', 1)[-1]} {s:.2f} s" for name, s in m.slowest) or "-"
        print(f"{m.case:<{width}}  {m.process_s:9.2f}  {m.wall_s:6.2f}  {m.compile_s:9.2f}  {m.compiles:8d}  "
              f"{met:>3}  {m.lock_s:6.2f}  {slowest}")  # fmt: skip
    print("(process s: start-up and imports included; lock s: numba's compiler lock taken or waited for, by")
    print(" compiles and by loads from its disk cache)")
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "compile.csv"
    records = [
        {"case": m.case, "process_s": round(m.process_s, 3), "case_s": round(m.wall_s, 3),
         "compile_s": round(m.compile_s, 3), "compiles": m.compiles, "compile_events": m.compile_events,
         "lock_s": round(m.lock_s, 3), "target_s": TARGET_S, "met": m.compile_s <= TARGET_S,
         "slowest": "; ".join(f"{n} {s:.3f}" for n, s in m.slowest)}
        for m in rows
    ]  # fmt: skip
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(records[0]))
        w.writeheader()
        w.writerows(records)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
