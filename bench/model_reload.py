"""A model file in the desktop app: from File > Import model to its first lobe on screen, and from a save of
the file to the views redrawn with the new version.

    .venv/bin/python bench/model_reload.py [MODEL_FILE ...] [--saves 10] [--out docs/results]

Each ``MODEL_FILE`` is a ``.brdf`` or ``.py`` model file (e.g. BRDF Explorer's ``disney.brdf``), measured in
an app process of its own; by default our own fixture ``tests/core/glsl/fixtures/principled.brdf`` when it
exists, else ``resources/models/blinn_phong.py``. Each file is copied to a temporary folder (it is edited
there).

1. ``import cold``: a fresh app process (its window up, the demo scene's lobe drawn, no model file loaded
   yet: the shader translator, LLVM and the kernels that probe a model are not loaded), then
   ``window.import_model(copy)`` with a text no process has compiled (a comment with a new number makes it
   new, so that no compile cache of the model's own code, numba's on disk for a ``.py``, is warm); seconds
   until the lobe of the file's model is on screen (the window's next flush after the lobe's VTK render).
2. ``import warm``: in the same process, the material switched to a built-in model and the same file
   imported again: its compiled code is in the process's cache of loaded models (the same path and text).
3. ``import new text``: a second copy of the file (another name, another new text): what the first import
   loaded is warm (the translator, LLVM, the probing kernels), the model itself is compiled anew.
4. ``save -> redraw``: then ``--saves`` saves of that copy, each a new version whose values are the
   previous version's times a new factor (the file's ``BRDF``/``eval`` wrapped); seconds from the write
   until the lobe of the new version is on screen, through the app's own file watcher.

Targets (issue 37): cold <= 5 s, warm <= 0.5 s, save -> redraw <= 2 s. Prints a table; writes
``model_import.csv`` to ``--out``. Runs under Xvfb when there is no display.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _display import ensure_display  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIXTURE = ROOT / "tests" / "core" / "glsl" / "fixtures" / "principled.brdf"
EXAMPLE = ROOT / "resources" / "models" / "blinn_phong.py"
TARGETS_S = {"import cold": 5.0, "import warm": 0.5, "import new text": None, "save -> redraw": 2.0}


def default_model() -> Path:
    return FIXTURE if FIXTURE.is_file() else EXAMPLE


def comment(path: Path, text: str) -> str:
    """A comment line in the file's language."""
    return f"// {text}" if path.suffix.lower() == ".brdf" else f"# {text}"


def with_nonce(path: Path, text: str, nonce: str) -> str:
    """``text`` made new (another content digest) by a comment: in a ``.brdf``, inside its shader block."""
    if path.suffix.lower() == ".brdf":
        return re.sub(
            r"(::begin shader[^\n]*\n)", lambda m: m.group(1) + comment(path, nonce) + "\n", text, count=1
        )
    return text + f"\n{comment(path, nonce)}\n"


def scaled(path: Path, text: str, factor: float) -> str:
    """A version of the model whose values are ``factor`` times the original's: the file's ``BRDF`` (or
    ``eval``) wrapped by one that scales it."""
    if path.suffix.lower() == ".brdf":
        shader = re.sub(r"\bBRDF\s*\(", "BRDF_unscaled(", text)
        wrapper = (
            "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n"
            f"    return {factor!r} * BRDF_unscaled(L, V, N, X, Y);\n}}\n"
        )
        return re.sub(r"(\n::end shader)", lambda m: "\n" + wrapper + m.group(1), shader, count=1)
    return text + (
        "\n\nfrom numba import njit as _bench_njit\n\n"
        "_bench_eval = eval if hasattr(eval, 'py_func') else _bench_njit(eval)\n\n\n"
        "@_bench_njit\ndef eval(wi, wo, p):\n"
        "    r, g, b = _bench_eval(wi, wo, p)\n"
        f"    return {factor!r} * r, {factor!r} * g, {factor!r} * b\n"
    )


# ---- in the app process --------------------------------------------------------------------------------


class LobeClock:
    """When the lobe of a model version reached the screen: the window's first flush after the first VTK
    render of the lobe view that followed ``show_lobe`` of a BRDF of that content digest."""

    def __init__(self, window) -> None:
        self.shown: list[tuple[float, str]] = []
        self.renders: list[float] = []
        self.flushes: list[float] = []
        view = window.lobe_view
        view.plotter.ren_win.AddObserver("EndEvent", lambda *_: self.renders.append(time.perf_counter()))
        if hasattr(view.plotter, "frameSwapped"):
            view.plotter.frameSwapped.connect(lambda: self.flushes.append(time.perf_counter()))
        show = view.show_lobe

        def show_lobe(brdf, wo):
            source = brdf.model.source
            if source is not None:
                self.shown.append((time.perf_counter(), source.digest))
            return show(brdf, wo)

        view.show_lobe = show_lobe

    def on_screen(self, digest: str, after: float) -> float | None:
        """When the lobe of ``digest`` first reached the screen after ``after`` (None: not yet)."""
        shown = next((t for t, d in self.shown if d == digest and t >= after), None)
        if shown is None:
            return None
        render = next((t for t in self.renders if t >= shown), None)
        if render is None or not self.flushes:
            return render
        return next((t for t in self.flushes if t >= render), None)


def run_app(first: Path, second: Path, saves: int) -> dict:
    """In a new main window: import ``first`` (cold), again (warm), then ``second`` (a new text), then save
    new versions of ``second`` ``saves`` times; the seconds measured, as a dict."""
    import hashlib

    from PySide6.QtCore import QEventLoop
    from PySide6.QtWidgets import QApplication

    from app.main_window import MainWindow
    from core.model_files import read_text

    _app = QApplication.instance() or QApplication([])  # kept referenced for the whole run
    events = QEventLoop()  # (QEventLoop.processEvents: see bench/app_latency.py)
    window = MainWindow(warm_up=False)
    window.ask_unsaved = lambda: "discard"
    window.resize(1400, 900)
    window.show()
    clock = LobeClock(window)

    def run_until(done, timeout: float = 60.0) -> bool:
        end = time.monotonic() + timeout
        while not done() and time.monotonic() < end:
            events.processEvents()
            time.sleep(0.0005)
        events.processEvents()
        return bool(done())

    def digest(text: str) -> str:
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    window.start(None, empty=False, restore="no")
    window.refresh_now()
    run_until(lambda: clock.renders and (not clock.flushes or clock.flushes[-1] > clock.renders[0]), 30.0)
    run_until(lambda: False, 1.0)  # the window settled (first paints, the snapshot process's start)

    def import_until_shown(path: Path) -> dict:
        version = digest(read_text(path))
        t0 = time.perf_counter()
        if not window.import_model(path):
            raise RuntimeError(window.errors[-1] if window.errors else "import failed")
        loaded = time.perf_counter() - t0
        if not run_until(lambda: clock.on_screen(version, t0) is not None):
            raise RuntimeError(f"{path.name}: the imported model's lobe never reached the screen")
        run_until(lambda: False, 1.0)  # its slow jobs started, the GUI thread free again
        return {"import_s": clock.on_screen(version, t0) - t0, "load_s": loaded}  # type: ignore[operator]

    out: dict = {"saves": []}
    try:
        out["cold"] = import_until_shown(first)
        out["label"] = window.document.brdf().model.label
        window.document.set_model("phong")  # away from it, then back: the same text, compiled before
        window.refresh_now()
        run_until(lambda: False, 1.0)
        out["warm"] = import_until_shown(first)
        out["new text"] = import_until_shown(second)
    except RuntimeError as exc:
        return {"error": str(exc)}
    text = read_text(second)
    for k in range(saves):
        new = scaled(second, text, 1.5 + 0.25 * k)
        version = digest(new)
        run_until(lambda: False, 0.3)  # apart from the previous save (and its slow jobs' start)
        t0 = time.perf_counter()
        second.write_text(new, encoding="utf-8")
        if not run_until(lambda v=version, t=t0: clock.on_screen(v, t) is not None, 30.0):
            entry = window.model_files.get(second)
            out["saves"].append({"error": entry.problem if entry is not None else "not reloaded"})
            continue
        out["saves"].append({"redraw_s": clock.on_screen(version, t0) - t0})  # type: ignore[operator]
    window.shutdown()
    return out


# ---- the orchestrating process -------------------------------------------------------------------------


def child(first: Path, second: Path, saves: int, config: Path) -> dict:
    """:func:`run_app` in a fresh process (with app settings of its own)."""
    env = {**os.environ, "BRDF_STUDIO_CONFIG_DIR": str(config)}
    script = str(Path(__file__).resolve())
    cmd = [sys.executable, script, "--child", str(first), str(second), "--saves", str(saves)]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)
    for line in reversed(done.stdout.splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    return {"error": f"the app process failed (exit {done.returncode}): {done.stderr.strip()[-800:]}"}


def measure(source: Path, saves: int) -> tuple[list[dict], list[str]]:
    """The rows of one model file (its copies imported in a fresh app process) and the saves not redrawn."""
    work = Path(tempfile.mkdtemp(prefix="brdf-studio-model-reload-"))
    config = work / "config"
    config.mkdir()
    text = source.read_text(encoding="utf-8")
    first, second = work / source.name, work / f"{source.stem}_2{source.suffix}"
    for copy in (first, second):
        copy.write_text(with_nonce(source, text, uuid.uuid4().hex), encoding="utf-8")
    print(f"model file: {source} (imported as {first.name}, then {second.name}, in {work})")
    print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    result = child(first, second, saves, config)
    if "error" in result:
        return [], [result["error"]]
    redraws = [s["redraw_s"] for s in result["saves"] if "redraw_s" in s]
    failures = [s["error"] for s in result["saves"] if "error" in s]
    rows = [
        {"measure": f"import {name}", "model": source.name, "label": result["label"], "n": 1,
         "median_s": result[name]["import_s"], "max_s": result[name]["import_s"], "load_s": result[name]["load_s"]}
        for name in ("cold", "warm", "new text")
    ]  # fmt: skip
    if redraws:
        rows.append({"measure": "save -> redraw", "model": source.name, "label": result["label"], "n": len(redraws),
                     "median_s": statistics.median(redraws), "max_s": max(redraws), "load_s": ""})  # fmt: skip
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")
    return rows, failures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("models", nargs="*", type=Path, help="model files (.brdf, .py); one app process each")
    parser.add_argument("--saves", type=int, default=10)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "results")
    parser.add_argument("--child", type=Path, nargs=2, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    ensure_display()
    if args.child is not None:
        print(json.dumps(run_app(args.child[0], args.child[1], args.saves)), flush=True)
        return 0
    sources = [m.resolve() for m in args.models] or [default_model()]
    for source in sources:
        if not source.is_file():
            parser.error(f"{source}: no such model file")
    rows, failures = [], []
    for source in sources:
        more, failed = measure(source, args.saves)
        rows += more
        failures += [f"{source.name}: {f}" for f in failed]
    print("\nseconds until the lobe is on screen")
    print(
        f"{'model':<20} {'measure':<16} {'n':>3} {'median s':>9} {'max s':>7} {'target s':>9}  {'(load s)':>8}"
    )
    for r in rows:
        load = f"{r['load_s']:.3f}" if r["load_s"] != "" else ""
        target = TARGETS_S[r["measure"]]
        ok = "" if target is None else "ok" if r["max_s"] <= target else "MISSED"
        print(f"{r['model']:<20} {r['measure']:<16} {r['n']:>3} {r['median_s']:>9.3f} {r['max_s']:>7.3f} "
              f"{'' if target is None else f'{target:.1f}':>9}  {load:>8}  {ok}")  # fmt: skip
    for f in failures:
        print(f"failed: {f}")
    print(
        "(load s: window.import_model itself: reading, compiling and probing the file, the material switched)"
    )
    args.out.mkdir(parents=True, exist_ok=True)
    fields = ["model", "label", "measure", "n", "median_s", "max_s", "load_s", "target_s"]
    with open(args.out / "model_import.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for r in rows:
            writer.writerow({**{k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()},
                             "target_s": TARGETS_S[r["measure"]]})  # fmt: skip
    print(f"wrote {args.out / 'model_import.csv'}")
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main())
