"""Desktop-app responsiveness: parameter edit -> redraw time, and event-loop stalls while a render runs.

    .venv/bin/python bench/app_latency.py [--edits 15] [--render-seconds 8] [--models ggx,phong,...]

1. For each analytic model: after a warm-up (kernel compilation excluded), ``--edits`` edits of one float
   parameter; for each, the time from the edit to the redrawn 3D lobe (synchronous), to the redrawn quadtree
   view (built in a worker, drawn on the GUI thread), and to everything (lobe, polar slice, lit sphere, tree).
   Target: lobe + quadtree <= 100 ms.
2. A 10 ms ``QTimer`` probe on the GUI thread while the render panel renders the demo scene (two strategies,
   equal time): the stall is the largest delay of a tick beyond its interval. Target: <= 50 ms.

Prints tables; writes ``results/bench/app_latency.csv`` and ``results/bench/app_stall.csv``. Runs under Xvfb
when there is no display. The machine's load average is printed: other processes inflate the numbers.
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _display import ensure_display  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_MODELS = "lambert,phong,blinn,lewis,ggx,cook_torrance,ward,ashikhmin_shirley,oren_nayar,lafortune"


def pick_param(model):
    """A float parameter to sweep (the first declared float; log-scale ones are the interesting lobes)."""
    floats = [p for p in model.params if p.kind == "float" and p.hi > p.lo]
    logs = [p for p in floats if p.log]
    return (logs or floats or [None])[0]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edits", type=int, default=15)
    parser.add_argument("--render-seconds", type=float, default=8.0)
    parser.add_argument("--models", default=DEFAULT_MODELS)
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    args = parser.parse_args()
    ensure_display()
    os.environ.setdefault("BRDF_STUDIO_CONFIG_DIR", tempfile.mkdtemp(prefix="brdf-studio-bench-"))

    from PySide6.QtCore import QElapsedTimer, QTimer
    from PySide6.QtWidgets import QApplication

    from app.main_window import MainWindow, demo_scene_path
    from core.model import get_model

    app = QApplication.instance() or QApplication([])
    window = MainWindow(warm_up=False)
    window.ask_unsaved = lambda: "discard"
    window.resize(1400, 900)
    window.show()
    window.sampling_always = True  # redraw the sampler view on every edit, as if both were on screen
    app.processEvents()
    doc = window.document

    def wait_sampling(timeout=600.0) -> None:
        end = time.monotonic() + timeout
        while not window.jobs_idle("sampling") and time.monotonic() < end:
            app.processEvents()
            time.sleep(0.0005)
        app.processEvents()

    rows = []
    print(f"load average at start: {os.getloadavg()[0]:.2f} (2 cores)")
    print(
        f"{'model':<20} {'param':<8} {'lobe ms':>9} {'tree ms':>9} {'lobe+tree':>10} {'all views':>10}  (median / max)"
    )
    for name in [m.strip() for m in args.models.split(",") if m.strip()]:
        try:
            model = get_model(name)
        except Exception as exc:  # a model not in this build
            print(f"{name:<20} skipped: {exc}")
            continue
        param = pick_param(model)
        if param is None:
            continue
        mat = doc.add_material(name, name=f"bench-{name}")
        doc.select_material(mat)
        window.refresh_now()
        wait_sampling()
        lo, hi = param.lo, param.hi
        values = (
            [lo + (hi - lo) * f for f in (0.3, 0.6)]
            if not param.log
            else [(lo * hi) ** 0.5, (lo * hi) ** 0.5 * 1.5]
        )
        values = [min(max(v, lo), hi) for v in values]
        doc.set_param(param.name, values[1])  # warm-up: compile what this model needs
        window.refresh_now()
        wait_sampling()
        lobe, tree, both, total = [], [], [], []
        for k in range(args.edits):
            t0 = time.perf_counter()
            doc.set_param(param.name, values[k % 2])
            doc.end_merge()
            window.refresh_now()
            t_sync = time.perf_counter()
            wait_sampling()
            t_done = time.perf_counter()
            lobe_ms = window.timings["lobe"] * 1e3
            tree_ms = window.timings["sampling"] * 1e3  # from the request to the drawn tree
            lobe.append(lobe_ms)
            tree.append(tree_ms)
            both.append(lobe_ms + tree_ms)
            total.append((t_done - t0) * 1e3)
            rows.append({"model": name, "param": param.name, "edit": k, "lobe_ms": round(lobe_ms, 2),
                         "tree_ms": round(tree_ms, 2), "sync_ms": round((t_sync - t0) * 1e3, 2),
                         "total_ms": round((t_done - t0) * 1e3, 2)})  # fmt: skip
        med = lambda x: f"{statistics.median(x):5.0f}/{max(x):<4.0f}"  # noqa: E731
        print(f"{name:<20} {param.name:<8} {med(lobe):>9} {med(tree):>9} {med(both):>10} {med(total):>10}")

    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "app_latency.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    # ---- event-loop stall probe while rendering ---------------------------------------------------------
    stall = {"baseline": [], "render": []}
    clock = QElapsedTimer()
    state = {"last": None, "phase": "baseline"}
    interval_ms = 10

    def tick() -> None:
        now = clock.nsecsElapsed() / 1e6
        if state["last"] is not None:
            stall[state["phase"]].append(now - state["last"] - interval_ms)
        state["last"] = now

    def run_for(seconds: float, until=None) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end and not (until is not None and until()):
            app.processEvents()
            time.sleep(0.001)

    window.sampling_always = False
    window.open_project(demo_scene_path(), confirm=False, remember=False)
    window.tabs.setCurrentWidget(window.render_panel)
    panel = window.render_view
    panel.width_box.setValue(192)
    panel.height_box.setValue(128)
    panel.mode.setCurrentIndex(panel.mode.findData("time"))
    panel.seconds.setValue(args.render_seconds)
    panel.strategy_a.setCurrentText("uniform")
    panel.strategy_b.setCurrentText("cosine")
    timer = QTimer()
    timer.setInterval(interval_ms)
    timer.timeout.connect(tick)
    clock.start()
    timer.start()
    run_for(2.0)
    state["phase"], state["last"] = "render", None
    t0 = time.monotonic()
    panel.start()
    run_for(args.render_seconds * 4 + 300, until=lambda: not panel.running)
    render_wall = time.monotonic() - t0
    timer.stop()
    frames = {n: f["spp"] for n, f in panel.frames.items()}
    print(f"\nrender of the demo scene ({panel.width_box.value()}x{panel.height_box.value()}, equal time "
          f"{args.render_seconds:g} s each, preparation included): {render_wall:.1f} s wall, spp {frames}")  # fmt: skip
    print(f"{'phase':<10} {'ticks':>6} {'median ms':>10} {'p99 ms':>8} {'max stall ms':>13}")
    out_rows = []
    for phase, gaps in stall.items():
        if not gaps:
            continue
        gaps_sorted = sorted(gaps)
        p99 = gaps_sorted[int(0.99 * (len(gaps_sorted) - 1))]
        print(f"{phase:<10} {len(gaps):>6} {statistics.median(gaps):>10.1f} {p99:>8.1f} {max(gaps):>13.1f}")
        out_rows += [{"phase": phase, "tick": i, "stall_ms": round(g, 3)} for i, g in enumerate(gaps)]
    with open(args.out / "app_stall.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["phase", "tick", "stall_ms"])
        w.writeheader()
        w.writerows(out_rows)
    print(f"load average at end: {os.getloadavg()[0]:.2f}; CSV in {args.out}")
    window.close()
    from app.workers import exit_if_abandoned

    return exit_if_abandoned(0)


if __name__ == "__main__":
    sys.exit(main())
