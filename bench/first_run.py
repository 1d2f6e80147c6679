"""Seconds from ``pip install .`` to the first demo image, with empty caches: what a new user waits for.

    .venv/bin/python bench/first_run.py [--venv DIR | --keep-venv DIR] [--wheels with-kernels,without-kernels]
                                        [--runs 2] [--kernels] [--out results/bench]

By default the benchmark makes a virtual environment in a temporary folder and installs the project into it
(``pip install .``, timed, the wheel's build included; the dependencies come from pip's own cache when it has
them). ``--wheels`` names the wheels to install, each into its own new environment, in turn:
``with-kernels`` is what ``pip install .`` builds (:mod:`core._wheel_kernels` compiles the kernels into the
wheel), ``without-kernels`` the same build with ``BRDF_STUDIO_PREBUILD=0`` (every kernel compiles at first
use). With ``--venv DIR`` it uses
an environment that has the project installed already (this checkout's ``.venv``, say) and skips the
install. Then, ``--runs`` times, in a new process each with its own empty numba cache
(``$BRDF_STUDIO_NUMBA_CACHE``) and table cache (``$BRDF_STUDIO_CACHE``), it runs the installed command

    brdf-studio render --demo --spp 4 --width 160 --height 120 -o OUT.exr

and times it whole, then the same command again with the caches it filled (the second run of a user). The
command's own report gives the split: its compile notice (``compiled N kernels in S s``), the render's
preparation and tracing seconds from the sidecar JSON. ``--kernels`` then runs it once more with empty caches
in that environment's Python, listening to numba's compile events, and lists the kernels it compiled with
their seconds (``first_run_kernels.csv``).

Target (issue 38): the first run within 30 s. Prints a table and writes ``first_run.csv``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from core.io import write_csv_rows

ROOT = Path(__file__).resolve().parents[1]
COMMAND = ["render", "--demo", "--spp", "4", "--width", "160", "--height", "120"]
TARGET_S = 30.0
COMPILED = re.compile(r"compiled (\d+) kernels? in (\d+) s")


WHEELS = {"with-kernels": "1", "without-kernels": "0"}
"""The wheels ``--wheels`` can install: the default build, which compiles the kernels into the
wheel, and the same build without them (``BRDF_STUDIO_PREBUILD=0``): every kernel compiles at first use."""


def make_venv(folder: Path, wheel: str) -> float:
    """A new environment in ``folder`` with the project installed from a ``wheel`` (a key of
    :data:`WHEELS`) built from this checkout; returns the install's seconds (build included)."""
    subprocess.run([sys.executable, "-m", "venv", str(folder)], check=True)
    env = {**os.environ, "BRDF_STUDIO_PREBUILD": WHEELS[wheel]}
    t0 = time.perf_counter()
    subprocess.run(
        [str(folder / "bin" / "python"), "-m", "pip", "install", "--quiet", str(ROOT)],
        check=True,
        cwd=folder,
        env=env,
    )
    return time.perf_counter() - t0


def kernels_mb(venv: Path) -> float:
    """Megabytes of compiled kernels the installed package carries (``core/_kernels``)."""
    found = list(venv.glob("lib/python*/site-packages/core/_kernels"))
    return round(sum(f.stat().st_size for d in found for f in d.rglob("*") if f.is_file()) / 1e6, 1)


def run_once(venv: Path, caches: Path, out: Path) -> dict[str, Any]:
    """The command in a new process with the caches under ``caches``: wall seconds and its own report."""
    env = {
        **os.environ,
        "BRDF_STUDIO_NUMBA_CACHE": str(caches / "numba"),
        "BRDF_STUDIO_CACHE": str(caches / "tables"),
    }
    for name in ("numba", "tables"):
        (caches / name).mkdir(parents=True, exist_ok=True)
    exe = venv / "bin" / "brdf-studio"
    t0 = time.perf_counter()
    done = subprocess.run(
        [str(exe), *COMMAND, "-o", str(out)], env=env, cwd=caches, capture_output=True, text=True
    )
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"the render failed (exit {done.returncode}):\n{done.stderr[-2000:]}")
    m = COMPILED.search(done.stderr)
    info = json.loads(out.with_suffix(".json").read_text())
    return {
        "wall_s": round(wall, 2),
        "compiled_kernels": int(m.group(1)) if m else 0,
        "compile_s": float(m.group(2)) if m else 0.0,
        "prepare_s": info["prepare"]["seconds"],
        "render_s": info["render_seconds"],
    }


def kernels_child(report: Path) -> int:
    """In the measured environment's Python: the command in this process, every outermost numba compile
    (a callee compiled inside its caller counts in the caller) written to ``report`` as JSON rows."""
    import threading

    from numba.core import event

    rows: list[tuple[str, float]] = []
    open_: dict[int, list[tuple[str, float]]] = {}

    class Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            d = ev.data.get("dispatcher")
            name = d.py_func.__module__ + "." + d.py_func.__qualname__ if d is not None else "?"
            open_.setdefault(threading.get_ident(), []).append((name, time.perf_counter()))

        def on_end(self, ev: Any) -> None:
            stack = open_[threading.get_ident()]
            name, t0 = stack.pop()
            if not stack:
                rows.append((name, time.perf_counter() - t0))

    event.register("numba:compile", Listener())
    from app.cli import main as cli

    code = cli([*COMMAND, "-o", str(report.with_suffix(".exr")), "--quiet"])
    report.write_text(json.dumps(rows))
    return code


def kernels(venv: Path, caches: Path, top: int = 12) -> list[tuple[str, float]]:
    """The command with empty caches in ``venv``'s Python, through :func:`kernels_child`: the kernels it
    compiled and their seconds, slowest first (the ``top`` first printed)."""
    report = caches / "kernels.json"
    env = {
        **os.environ,
        "BRDF_STUDIO_NUMBA_CACHE": str(caches / "numba"),
        "BRDF_STUDIO_CACHE": str(caches / "tables"),
    }
    code = f"import sys; sys.path.insert(0, {str(ROOT / 'bench')!r}); import first_run; "
    code += f"sys.exit(first_run.kernels_child(__import__('pathlib').Path({str(report)!r})))"
    subprocess.run([str(venv / "bin" / "python"), "-c", code], env=env, cwd=caches, check=True)
    rows = sorted(((n, s) for n, s in json.loads(report.read_text())), key=lambda r: -r[1])
    total = sum(s for _, s in rows)
    print(f"{len(rows)} kernels compiled in {total:.0f} s; the slowest:")
    for name, seconds in rows[:top]:
        print(f"{seconds:8.1f} s  {name}")
    return rows


def _span(values: list[float]) -> str:
    """``best–worst`` seconds, or one number when they agree."""
    lo, hi = min(values), max(values)
    return f"{lo:.1f}" if lo == hi else f"{lo:.1f}–{hi:.1f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--venv", type=Path, help="an environment with the project installed (no install)")
    where.add_argument("--keep-venv", type=Path, help="make the new environment here and keep it")
    ap.add_argument("--runs", type=int, default=2, help="first runs, each with new empty caches")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    ap.add_argument(
        "--wheels",
        default="with-kernels",
        help="with a new environment: the wheels to install, in turn, comma-separated: "
        + ", ".join(WHEELS)
        + " (default: with-kernels)",
    )
    ap.add_argument(
        "--kernels", action="store_true", help="also list the kernels a first run compiles and their seconds"
    )
    a = ap.parse_args(argv)
    if a.runs < 1:
        ap.error("--runs must be at least 1")
    if a.venv is not None and not (a.venv / "bin" / "brdf-studio").is_file():
        ap.error(f"{a.venv} has no bin/brdf-studio: install the project into it, or leave --venv out")
    if a.keep_venv is not None and a.keep_venv.exists():
        ap.error(f"{a.keep_venv} exists already: name a new folder")
    wheels = [w.strip() for w in a.wheels.split(",") if w.strip()]
    unknown = [w for w in wheels if w not in WHEELS]
    if unknown or not wheels:
        ap.error(f"--wheels takes {', '.join(WHEELS)}, comma-separated (got {a.wheels!r})")
    if a.venv is not None:
        wheels = ["installed"]
    rows: list[dict[str, Any]] = []
    compiled: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="bench-first-run-") as tmp_name:
        tmp = Path(tmp_name)
        for wheel in wheels:
            install_s = None
            if a.venv is not None:
                venv = a.venv.resolve()
            else:
                venv = ((a.keep_venv / wheel) if a.keep_venv is not None else tmp / f"venv-{wheel}").resolve()
                print(f"pip install . ({wheel}) into a new environment ({venv}) ...", flush=True)
                install_s = round(make_venv(venv, wheel), 1)
                print(f"installed in {install_s:.1f} s", flush=True)
            size = kernels_mb(venv)
            for k in range(a.runs):
                caches = tmp / f"caches-{wheel}-{k}"
                for case in ("first", "second"):
                    row = {
                        "wheel": wheel,
                        "run": k + 1,
                        "case": case,
                        "install_s": install_s,
                        "kernels_mb": size,
                        **run_once(venv, caches, tmp / "out.exr"),
                    }
                    rows.append(row)
                    print(
                        f"{wheel} run {k + 1} {case:<6}: {row['wall_s']:7.1f} s whole, "
                        f"{row['compile_s']:5.0f} s compiling ({row['compiled_kernels']} kernels), "
                        f"preparation {row['prepare_s']:.1f} s, tracing {row['render_s']:.2f} s",
                        flush=True,
                    )
            if a.kernels:
                caches = tmp / f"caches-kernels-{wheel}"
                for name in ("numba", "tables"):
                    (caches / name).mkdir(parents=True, exist_ok=True)
                compiled += [
                    {"wheel": wheel, "kernel": n, "compile_s": round(sec, 2)}
                    for n, sec in kernels(venv, caches)
                ]
            if a.venv is None and a.keep_venv is None:
                shutil.rmtree(venv, ignore_errors=True)
    print()
    print(f"brdf-studio {' '.join(COMMAND)}, empty caches, {a.runs} run(s) each")
    print(f"{'wheel':<17}{'pip install s':>14}{'kernels MB':>11}{'first run s':>13}{'second run s':>14}")
    met = True
    for wheel in wheels:
        mine = [r for r in rows if r["wheel"] == wheel]
        firsts = [r["wall_s"] for r in mine if r["case"] == "first"]
        seconds = [r["wall_s"] for r in mine if r["case"] == "second"]
        install = mine[0]["install_s"]
        print(
            f"{wheel:<17}{'-' if install is None else f'{install:.1f}':>14}{mine[0]['kernels_mb']:>11.1f}"
            f"{_span(firsts):>13}{_span(seconds):>14}"
        )
        if wheel in ("with-kernels", "installed"):
            met = met and max(firsts) <= TARGET_S
    if any(w in ("with-kernels", "installed") for w in wheels):
        print(f"target: first run within {TARGET_S:.0f} s: {'met' if met else 'not met'}")
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "first_run.csv"
    write_csv_rows(path, rows)
    if a.kernels:
        write_csv_rows(a.out / "first_run_kernels.csv", compiled)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
