"""Bounded memory at the largest sizes (issue 18): a 16384x16384 render and ``sample -n 10^9``.

    .venv/bin/python bench/big_render.py [--parts render,sample] [--side 16384] [--spp 1] [--sampler cosine]
                                         [--samples 1e9] [--out results/bench]

Each request runs as ``python -m app ...`` in a new process; its peak resident memory is the ``ru_maxrss``
that ``os.wait4`` reports for that one child (the kernel's high-water mark of the process, not a sampled
estimate), its time the wall-clock seconds from start to exit (imports and preparation included).

- ``render``: ``render --demo --sampler S --spp N --width SIDE --height SIDE``. At 16384^2 the whole film needs
  more memory than the budget allows (``renderer.render.render_memory``), so the render runs in bands of rows
  streamed to the EXR and PNG (``renderer/bands.py``); the row reports the bands the sidecar records.
- ``sample``: ``sample --model phong --sampler cosine --theta 30 -n N -o s.npy`` (streamed in chunks of 2^20
  directions; the ``.npy`` file, 40 bytes a direction, is deleted afterwards).

Prints a table, writes ``big_render.csv`` (one row per request; earlier rows of other parts are kept).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIELDS = ["request", "size", "peak_bytes", "seconds", "exit", "detail", "command"]


def measure(argv: list[str], cwd: Path) -> tuple[int, float, int, str]:
    """Peak resident bytes, seconds, exit code and the last stderr line of ``python -m app ARGV``."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(
            [sys.executable, "-m", "app", *argv], cwd=cwd, stdout=subprocess.DEVNULL, stderr=err,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )  # fmt: skip
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        seconds = time.perf_counter() - t0
        err.seek(0)
        lines = [x for x in err.read().splitlines() if x.strip()]
    return int(usage.ru_maxrss) * 1024, seconds, proc.returncode, lines[-1] if lines else ""


def render(work: Path, side: int, spp: int, sampler: str) -> dict:
    out = work / "big.exr"
    argv = ["render", "--demo", "--sampler", sampler, "--spp", str(spp), "--width", str(side),
            "--height", str(side), "-o", str(out), "--quiet"]  # fmt: skip
    rss, sec, code, last = measure(argv, work)
    detail = last
    if code == 0:
        info = json.loads(out.with_suffix(".json").read_text())
        bands = info.get("bands")
        exr, png = out.stat().st_size, out.with_suffix(".png").stat().st_size
        detail = (
            f"{bands['count']} bands of {bands['rows']} rows; " if bands else "whole film; "
        ) + f"render {info['render_seconds']:.0f} s; EXR {exr / 2**20:.0f} MiB, PNG {png / 2**20:.0f} MiB"
    for ext in (".exr", ".png", ".json"):
        out.with_suffix(ext).unlink(missing_ok=True)
    return {"request": "render", "size": side * side, "peak_bytes": rss, "seconds": round(sec, 1),
            "exit": code, "detail": detail, "command": "brdf-studio " + " ".join(argv[:-3])}  # fmt: skip


def sample(work: Path, n: int) -> dict:
    out = work / "s.npy"
    argv = [
        "sample",
        "--model",
        "phong",
        "--sampler",
        "cosine",
        "--theta",
        "30",
        "-n",
        str(n),
        "-o",
        str(out),
    ]
    need = 40 * n + (1 << 30)
    if shutil.disk_usage(work).free < need:
        raise SystemExit(f"sample -n {n:.0e} needs {need / 2**30:.0f} GiB of disk in {work}; use --work")
    rss, sec, code, last = measure(argv, work)
    size = out.stat().st_size if out.exists() else 0
    out.unlink(missing_ok=True)
    return {"request": "sample", "size": n, "peak_bytes": rss, "seconds": round(sec, 1), "exit": code,
            "detail": f"{size / 2**30:.1f} GiB written" if code == 0 else last,
            "command": "brdf-studio " + " ".join(argv[:-2]) + " -o s.npy"}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--parts", default="render,sample")
    ap.add_argument("--side", type=int, default=16384, help="render width and height")
    ap.add_argument("--spp", type=int, default=1)
    ap.add_argument("--sampler", default="cosine")
    ap.add_argument("--samples", type=float, default=1e9, help="'sample -n'")
    ap.add_argument("--work", type=Path, default=None, help="folder for the outputs (deleted after)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="big-", dir=args.work))
    rows = []
    parts = args.parts.split(",")
    try:
        if "render" in parts:
            rows.append(render(work, args.side, args.spp, args.sampler))
        if "sample" in parts:
            rows.append(sample(work, int(args.samples)))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    path = args.out / "big_render.csv"
    kept = []
    if path.is_file():  # rows of the parts not run now stay
        with open(path, newline="") as fh:
            kept = [r for r in csv.DictReader(fh) if r["request"] not in {r2["request"] for r2 in rows}]
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(kept + rows)
    print(f"{'request':<9}{'size':>10}{'peak MiB':>10}{'seconds':>9}{'exit':>6}  detail")
    for r in kept + rows:
        print(f"{r['request']:<9}{float(r['size']):>10.3g}{int(r['peak_bytes']) / 2**20:>10.0f}"
              f"{float(r['seconds']):>9.1f}{r['exit']:>6}  {r['detail']}")  # fmt: skip
    for r in rows:
        print(f"  {r['command']}")
    print(f"written: {path}")
    return 0 if all(int(r["exit"]) == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
