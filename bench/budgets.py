"""Resource budgets and bad inputs (issue 18): peak memory per unit of work, and the bad-input sweep.

    .venv/bin/python bench/budgets.py [--parts memory,sweep,interrupts,app-signals] [--max-samples 1e8] [--runs 20]
                                      [--requests sample,check,render] [--out results/bench]

``memory``: each request runs in a new process (``app.cli.main`` in-process there), which reports its peak
resident memory (``ru_maxrss``):

- ``sample -n N`` (cosine sampler, ``.npy``) for N = 1e6 ... ``--max-samples``: streamed in chunks of 2^20, so
  the peak must not grow with N;
- ``check --samples N`` (Lambert, cosine) for N = 1e5 ... 4e6: the slope is the bytes per sample the command's
  budget assumes (``app/commands/check.py: BYTES_PER_SAMPLE``);
- ``render --demo --sampler cosine --spp 1`` at 128^2 ... 768^2 pixels, and at 256^2 with ``--ris M``: the
  slopes are the bytes per path and per RIS candidate the render's budget assumes
  (``renderer/render.py: BYTES_PER_PATH, BYTES_PER_RIS_CANDIDATE``).

``sweep``: the bad-input corpus of ``tests/app/test_cli_inputs.py`` (every command's options, the environment
variables, endless devices, oversized files and cluster options of ``corpus_last_inputs``, generated broken
scenes, MERL headers and mesh files) run in one process: cases, exit codes, answers that are not one clear line,
non-finite images, seconds.

``interrupts``: ``--runs`` renders of the small test scene interrupted by SIGINT at a random moment (during the
imports, the preparation or the passes): exit codes, tracebacks or "Exception ignored" reports, outputs saved.

``app-signals`` (not in the default parts): the desktop app, edited, signalled ``--runs`` times (Ctrl-C to its
process group and SIGTERM to it, in turn) a random moment after the edit: seconds from the signal to the exit,
exit codes, stderr, whether the edit was autosaved.

Prints tables, writes ``budgets_memory.csv``, ``budgets_sweep.csv``, ``budgets_interrupts.csv`` and ``budgets_app_signals.csv``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CHILD = (
    "import resource, sys\n"
    "from app.cli import main\n"
    "code = main(sys.argv[1:])\n"
    "print('PEAK_RSS', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, 'CODE', code, file=sys.stderr)\n"
)


def peak_rss(argv: list[str], cwd: Path) -> tuple[int, float]:
    """Peak resident bytes and seconds of ``brdf-studio ARGV`` in a new process."""
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, *argv], cwd=cwd, capture_output=True, text=True, env={**os.environ}
    )
    seconds = time.perf_counter() - t0
    line = [x for x in proc.stderr.splitlines() if x.startswith("PEAK_RSS")]
    if not line or not line[-1].endswith("CODE 0"):
        raise SystemExit(f"{' '.join(argv)} failed: {proc.stderr[-800:]}")
    return int(line[-1].split()[1]), seconds


def slope(xs: list[float], ys: list[float]) -> float:
    return float(np.polyfit(np.asarray(xs, dtype=float), np.asarray(ys, dtype=float), 1)[0])


def memory(out: Path, max_samples: float, requests: set[str]) -> list[dict]:
    rows: list[dict] = []
    work = Path(tempfile.mkdtemp(prefix="budgets-"))
    n = 10**6
    while "sample" in requests and n <= max_samples:
        f = work / "s.npy"
        rss, sec = peak_rss(["sample", "--model", "phong", "--sampler", "cosine", "--theta", "30", "-n", str(n),
                             "-o", str(f)], work)  # fmt: skip
        rows.append({"request": "sample", "size": n, "peak_bytes": rss, "seconds": sec})
        f.unlink(missing_ok=True)
        n *= 10
    for n in (100_000, 1_000_000, 2_000_000, 4_000_000) if "check" in requests else ():
        rss, sec = peak_rss(["check", "--model", "lambert", "--sampler", "cosine", "--theta", "30", "--samples",
                             str(n)], work)  # fmt: skip
        rows.append({"request": "check", "size": n, "peak_bytes": rss, "seconds": sec})
    for side in (128, 256, 512, 768) if "render" in requests else ():
        rss, sec = peak_rss(["render", "--demo", "--sampler", "cosine", "--spp", "1", "--width", str(side),
                             "--height", str(side), "-o", str(work / "r.exr"), "--quiet"], work)  # fmt: skip
        rows.append({"request": "render", "size": side * side, "peak_bytes": rss, "seconds": sec})
    for m in (1, 16, 64) if "render" in requests else ():
        rss, sec = peak_rss(["render", "--demo", "--sampler", "cosine", "--spp", "1", "--width", "256",
                             "--height", "256", "--ris", str(m), "-o", str(work / "r.exr"), "--quiet"], work)  # fmt: skip
        rows.append({"request": "render_ris_256", "size": m, "peak_bytes": rss, "seconds": sec})
    with open(out / "budgets_memory.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"{'request':<16}{'size':>12}{'peak MiB':>11}{'seconds':>9}")
    for r in rows:
        print(f"{r['request']:<16}{r['size']:>12.3g}{r['peak_bytes'] / 2**20:>11.1f}{r['seconds']:>9.1f}")

    def fit(name: str) -> float:
        sel = [r for r in rows if r["request"] == name]
        return (
            slope([r["size"] for r in sel], [r["peak_bytes"] for r in sel]) if len(sel) > 1 else float("nan")
        )

    from app.commands.check import BYTES_PER_SAMPLE
    from renderer.render import BYTES_PER_PATH, BYTES_PER_PIXEL, BYTES_PER_RIS_CANDIDATE

    samples = [r for r in rows if r["request"] == "sample"] or [{"peak_bytes": float("nan")}]
    print(f"sample: peak {min(r['peak_bytes'] for r in samples) / 2**20:.0f}-"
          f"{max(r['peak_bytes'] for r in samples) / 2**20:.0f} MiB over N = 1e6..{max_samples:.0e} (streamed)")  # fmt: skip
    print(f"check: {fit('check'):.0f} bytes/sample measured; budget assumes {BYTES_PER_SAMPLE}")
    print(
        f"render: {fit('render'):.0f} bytes/pixel measured; budget assumes {BYTES_PER_PATH + BYTES_PER_PIXEL}"
    )
    print(f"render --ris: {fit('render_ris_256') / 65536:.0f} bytes/candidate/path measured; budget assumes "
          f"{BYTES_PER_RIS_CANDIDATE}")  # fmt: skip
    return rows


def sweep(out: Path) -> list[dict]:
    """The test suite's corpus, run in this process, with counts and seconds per command."""
    import contextlib
    import io

    from hypothesis import HealthCheck, given, settings

    from app.cli import main
    from tests.app import test_cli_inputs as t

    # The test suite's machine (tests/app/test_cli_inputs.py: _machine_of_4_gib): the budget cases are refusals
    # there; on a machine with more memory one may be a valid request, and render for minutes.
    os.environ["BRDF_STUDIO_MEMORY"] = str(4 << 30)
    work = Path(tempfile.mkdtemp(prefix="sweep-"))
    (work / "scene").mkdir()
    scene_dir = t.write_scene_dir(work / "scene")
    rows: list[dict] = []

    def run(command: str, argv: list[str], image: Path | None = None) -> dict:
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
        finite = True
        if code == 0 and image is not None:
            from renderer.image_io import read_exr

            try:
                finite = bool(np.all(np.isfinite(read_exr(image))))
            except Exception:
                finite = False
        clear = code == 0 or t.problem(command, code, err.getvalue()) is None
        if not clear or not finite:
            text = (
                Path(argv[1]).read_text()[:400] if command == "render" and argv[1].endswith(".json") else ""
            )
            print(f"NOT CLEAR: {argv}: exit {code}: {err.getvalue().strip()[:400]} {text}")
        return {"command": command, "code": code, "clear": clear, "finite": finite}

    def tally(label: str, results: list[dict], seconds: float) -> None:
        codes: dict[int, int] = {}
        for r in results:
            codes[r["code"]] = codes.get(r["code"], 0) + 1
        rows.append({
            "corpus": label, "cases": len(results), "exit_0": codes.get(0, 0), "exit_2": codes.get(2, 0),
            "other_exits": sum(v for k, v in codes.items() if k not in (0, 2)),
            "unclear_answers": sum(not r["clear"] for r in results),
            "nonfinite_images": sum(not r["finite"] for r in results), "seconds": round(seconds, 1),
        })  # fmt: skip

    for command, build in t.CORPORA.items():
        t0 = time.perf_counter()
        results = [run(command, argv) for argv in build(work)]
        tally(command, results, time.perf_counter() - t0)
    t0 = time.perf_counter()
    results = [run("render", argv) for argv in t.corpus_render(work, scene_dir)]
    tally("render arguments", results, time.perf_counter() - t0)
    t0 = time.perf_counter()
    results = []
    for command, argv, env in t.corpus_last_inputs(work, scene_dir):
        saved = {k: os.environ.get(k) for k in env}
        os.environ.update(env)
        try:
            results.append(run(command, argv))
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
    tally("env, files, bench", results, time.perf_counter() - t0)

    generated: list[dict] = []
    image = scene_dir / "out.exr"

    @settings(max_examples=400, **t.SWEEP_SETTINGS)
    @given(scene=t.broken_scenes())
    def scenes(scene):  # type: ignore[no-untyped-def]
        image.unlink(missing_ok=True)
        (scene_dir / "broken.json").write_text(json.dumps(scene))
        generated.append(run("render", ["render", str(scene_dir / "broken.json"), "--quiet", "-o", str(image),
                                        "--spp", "1"], image))  # fmt: skip

    t0 = time.perf_counter()
    scenes()
    tally("generated scenes", generated, time.perf_counter() - t0)
    del HealthCheck
    with open(out / "budgets_sweep.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(
        f"{'corpus':<18}{'cases':>7}{'exit 0':>8}{'exit 2':>8}{'other':>7}{'unclear':>9}{'non-finite':>11}{'s':>7}"
    )
    for r in rows:
        print(f"{r['corpus']:<18}{r['cases']:>7}{r['exit_0']:>8}{r['exit_2']:>8}{r['other_exits']:>7}"
              f"{r['unclear_answers']:>9}{r['nonfinite_images']:>11}{r['seconds']:>7}")  # fmt: skip
    total = sum(r["cases"] for r in rows)
    print(f"total: {total} cases in {sum(r['seconds'] for r in rows):.0f} s")
    return rows


def interrupts(out: Path, runs: int) -> list[dict]:
    from tests.app import test_cli_inputs as t

    work = Path(tempfile.mkdtemp(prefix="interrupts-"))
    scene_dir = t.write_scene_dir(work)
    rng = random.Random(18)
    rows = []
    for k in range(runs):
        delay = rng.uniform(0.5, 12.0)
        exr = work / f"o{k}.exr"
        proc = subprocess.Popen(
            [sys.executable, "-m", "app", "render", str(scene_dir / "scene.json"), "--until-cancelled",
             "--width", "64", "--height", "48", "-o", str(exr), "--quiet"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=120)
            code = proc.returncode
        except subprocess.TimeoutExpired:  # the interrupt was lost: a failure of this benchmark's target
            proc.kill()
            _, err = proc.communicate()
            code = "hung"
        rows.append({
            "run": k, "delay_s": round(delay, 2), "exit": code,
            "traceback": "Traceback" in err or "Exception ignored" in err, "saved": exr.is_file(),
        })  # fmt: skip
    with open(out / "budgets_interrupts.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    codes: dict[object, int] = {}
    for r in rows:
        codes[r["exit"]] = codes.get(r["exit"], 0) + 1
    print(f"{runs} interrupted renders: exit codes {codes}; tracebacks {sum(r['traceback'] for r in rows)}; "
          f"outputs saved {sum(r['saved'] for r in rows)} (the others were interrupted before a pass ended)")  # fmt: skip
    return rows


def app_signals(out: Path, runs: int) -> list[dict]:
    """The desktop app, edited, then signalled (Ctrl-C to its process group and SIGTERM to it, in turn) a
    uniform 0-5 s after the edit (while the window finishes opening the project and its views' background
    work): seconds from the signal to the app's exit, exit codes, stderr, the autosave."""
    sys.path.insert(0, str(ROOT / "bench"))
    from _display import ensure_display

    ensure_display()
    import psutil

    from app.document import default_scene
    from core.scene import Mesh, save_scene
    from tests.app.autosave_app import EDIT
    from tests.app.meshes import write_obj

    work = Path(tempfile.mkdtemp(prefix="app-signals-"))
    write_obj(work / "cubes.obj", {"a": (0, 0, 0), "b": (2, 0, 0)})
    scene = default_scene()
    scene.meshes = [Mesh(path="cubes.obj", name="cubes", material="ggx")]
    project = work / "scene.json"
    save_scene(scene, project)
    rng = random.Random(38)
    rows = []
    for k in range(runs):
        signum = (signal.SIGINT, signal.SIGTERM)[k % 2]
        config, report = work / f"config{k}", work / f"report{k}.json"
        config.mkdir()
        stderr = work / f"stderr{k}.txt"
        with open(stderr, "w") as fh:  # a file: a pipe would stay open until the helper processes have gone
            app = subprocess.Popen(
                [sys.executable, "-m", "tests.app.autosave_app", "hold", str(project), str(report)],
                cwd=ROOT, env={**os.environ, "BRDF_STUDIO_CONFIG_DIR": str(config)}, stdout=subprocess.DEVNULL,
                stderr=fh, start_new_session=True,
            )  # fmt: skip
        end = time.monotonic() + 300
        while not report.exists() and app.poll() is None and time.monotonic() < end:
            time.sleep(0.05)
        delay = rng.uniform(0.0, 5.0)
        time.sleep(delay)
        children = psutil.Process(app.pid).children(recursive=True)
        t0 = time.monotonic()
        if signum == signal.SIGINT:
            os.killpg(app.pid, signum)
        else:
            os.kill(app.pid, signum)
        try:
            code: object = app.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(app.pid, signal.SIGKILL)
            app.wait()
            code = "hung"
        closed = time.monotonic() - t0
        _, alive = psutil.wait_procs(children, timeout=30)
        helpers = time.monotonic() - t0
        err = stderr.read_text()
        try:
            doc = json.loads((config / f"autosave-{app.pid}.json").read_text())["document"]
            kept = EDIT["added"] in {m["name"] for m in doc["materials"]}
        except (OSError, ValueError, KeyError):
            kept = False
        rows.append({
            "run": k, "signal": signal.Signals(signum).name, "after_edit_s": round(delay, 2), "exit": code,
            "close_s": round(closed, 3), "helpers_gone_s": None if alive else round(helpers, 3), "stderr_lines": len(err.strip().splitlines()),
            "traceback": "Traceback" in err or "Exception ignored" in err, "autosave": kept,
        })  # fmt: skip
        print(rows[-1])
    with open(out / "budgets_app_signals.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    for name in ("SIGINT", "SIGTERM"):
        mine = [r for r in rows if r["signal"] == name]
        if mine:
            times = sorted(r["close_s"] for r in mine)
            print(f"{name}: {len(mine)} runs, exits {sorted({str(r['exit']) for r in mine})}, close "
                  f"median {times[len(times) // 2]:.2f} s, max {times[-1]:.2f} s; helpers gone by "
                  f"{max(r['helpers_gone_s'] or float('inf') for r in mine):.2f} s; tracebacks "
                  f"{sum(r['traceback'] for r in mine)}; autosave kept {sum(r['autosave'] for r in mine)}; "
                  f"stderr lines max {max(r['stderr_lines'] for r in mine)}")  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--parts", default="memory,sweep,interrupts")
    ap.add_argument("--max-samples", type=float, default=1e8, help="largest 'sample -n' measured")
    ap.add_argument("--requests", default="sample,check,render", help="what 'memory' measures")
    ap.add_argument("--runs", type=int, default=20, help="interrupted renders, signalled apps")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    parts = args.parts.split(",")
    if "memory" in parts:
        memory(args.out, args.max_samples, set(args.requests.split(",")))
    if "sweep" in parts:
        sweep(args.out)
    if "interrupts" in parts:
        interrupts(args.out, args.runs)
    if "app-signals" in parts:
        app_signals(args.out, args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
