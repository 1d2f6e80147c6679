"""Soak of the desktop app: start and cancel a render many times in a row; no crash, and memory that stays flat.

    xvfb-run -a -s "-screen 0 1600x1000x24" .venv/bin/python bench/app_soak.py [--cycles 100] [--warm-up 10]
        [--strategies uniform,adaptive_warp] [--size 256x192] [--seed 0]

The main window of the app (the one ``brdf-studio open`` shows, with its kernel warm-up) on the bundled demo
scene, Render tab. Each cycle presses *Render* (a budget of 100 000 spp, so it never ends by itself) and then
*Cancel*, in turn:

- ``frames``: cancelled once every strategy has shown a frame (the cancel arrives between passes);
- ``early``: cancelled after a random 0-300 ms (while the render process prepares: geometry, kernels, sampler
  tables);
- ``restart``: *Render* again once every strategy has shown a frame (the running render is cancelled and a new
  one starts; if the old one does not stop within the server's grace time, the process is replaced), then
  cancelled once the new one has shown its frames;

and waits until the render process acknowledges the cancel (its ``cancelled`` event) before the next cycle.

After each cycle it records the resident set size (RSS) of the GUI process and of the render process (a
separate, long-lived process: :mod:`app.render_process`), the GUI process's native and Python threads, open
file descriptors and child processes, the render process's pid (a new pid: a process replaced by a restart
whose cancel did not stop in time, or a crash) and the time from *Cancel* to the acknowledgement.

Method for the growth: the first ``--warm-up`` cycles are left out (the first renders compile kernels, build
and cache sampler tables and fill allocator pools: one-time costs); growth = mean RSS of the last 5 cycles /
mean RSS of the 5 cycles right after the warm-up - 1, for each process; the least-squares slope over the
cycles after the warm-up is printed beside it (KiB a cycle). A restart can replace the render process
(its cancel did not stop within the server's grace time): a new process starts from nothing, so the render
process's growth is taken within each process's own cycles (leaving out its first 2, which load kernels and
build tables), for every process that served at least 10 cycles after the warm-up. Target: growth <= 5 % for
the GUI process and every render process, no crash, no error shown, no thread, descriptor or process left over.

Prints a table; writes ``results/bench/app_soak.csv`` (one row a cycle) and ``results/bench/app_soak.png``.
Runs under Xvfb when there is no display. ``--from-csv FILE`` prints the table of an earlier run's CSV again
(no app is started).
"""

from __future__ import annotations

import argparse
import csv
import os
import random
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _display import ensure_display  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TARGET_GROWTH = 0.05
WINDOW = 5  # cycles averaged at each end


def growth(values: list[float], warm_up: int) -> tuple[float, float]:
    """``(relative growth, slope per cycle)`` of ``values`` after ``warm_up`` cycles (see the docstring)."""
    import numpy as np

    tail = np.asarray(values[warm_up:], dtype=float)
    if len(tail) < 2 * WINDOW:
        raise SystemExit(
            f"need at least {warm_up + 2 * WINDOW} cycles for a growth over {WINDOW}-cycle means"
        )
    start, end = tail[:WINDOW].mean(), tail[-WINDOW:].mean()
    slope = float(np.polyfit(np.arange(len(tail)), tail, 1)[0])
    return float(end / start - 1.0), slope


def render_processes(rows: list[dict], warm_up: int) -> list[tuple[int, int, int, float, float]]:
    """``(pid, first cycle, last cycle, growth, slope)`` of each render process that served at least
    ``2 * WINDOW`` cycles after the warm-up (and after its own first 2 cycles), in order."""
    out = []
    start = 0
    for i in range(1, len(rows) + 1):
        if i < len(rows) and rows[i]["render_pid"] == rows[start]["render_pid"]:
            continue
        own = [r for r in rows[start:i] if r["cycle"] >= max(warm_up, rows[start]["cycle"] + 2)]
        if len(own) >= 2 * WINDOW:
            g, slope = growth([r["render_rss_mib"] for r in own], 0)
            out.append((rows[start]["render_pid"], own[0]["cycle"] + 1, own[-1]["cycle"] + 1, g, slope))
        start = i
    return out


def report(rows: list[dict], warm_up: int) -> bool:
    """Print the growth table of ``rows`` (one dict a cycle, as in the CSV); True when the target is met."""
    after, last = rows[warm_up], rows[-1]
    gui_growth, gui_slope = growth([r["gui_rss_mib"] for r in rows], warm_up)
    print(f"growth over cycles {warm_up + 1}-{len(rows)}, mean of {WINDOW} cycles at each end (the render "
          "process: within each process)")  # fmt: skip
    print(
        f"{'process':<26} {'RSS after warm-up':>18} {'RSS at the end':>15} {'growth':>8} {'slope':>14} {'target':>7}"
    )
    lines = [("GUI", after["gui_rss_mib"], last["gui_rss_mib"], gui_growth, gui_slope)]
    for pid, first, end, g, slope in render_processes(rows, warm_up):
        rss = {r["cycle"] + 1: r["render_rss_mib"] for r in rows}
        lines.append((f"render {pid} (cycles {first}-{end})", rss[first], rss[end], g, slope))
    for label, start, end, g, slope in lines:
        met = "met" if g <= TARGET_GROWTH else "MISSED"
        print(
            f"{label:<26} {start:>14.1f} MiB {end:>11.1f} MiB {100 * g:>7.2f}% {1024 * slope:>8.1f} KiB/c {met:>7}"
        )
    for key in ("gui_threads", "python_threads", "open_fds", "child_processes"):
        print(
            f"{key:<16} after warm-up {after[key]:>4}, at the end {last[key]:>4}, max {max(r[key] for r in rows)}"
        )
    return len(lines) > 1 and all(g <= TARGET_GROWTH for *_, g, _ in lines)


def read_rows(path: Path) -> list[dict]:
    """The rows of a CSV this script wrote, with numbers as numbers."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for key, value in r.items():
            if key != "cancel" and value != "":
                r[key] = float(value) if "." in value else int(value)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=100)
    parser.add_argument("--warm-up", type=int, default=10, help="cycles left out of the growth")
    parser.add_argument("--strategies", default="uniform,adaptive_warp", help="A,B of the render panel")
    parser.add_argument("--size", default="256x192", help="image width x height (the panel's default)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the early cancels' delays")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--from-csv", type=Path, help="print the table of an earlier run's CSV (no app)")
    args = parser.parse_args()
    if args.from_csv is not None:
        return 0 if report(read_rows(args.from_csv), args.warm_up) else 1
    width, height = (int(v) for v in args.size.lower().split("x"))
    strategy_a, strategy_b = ([*args.strategies.split(","), "(none)"])[:2]
    ensure_display()
    os.environ.setdefault("BRDF_STUDIO_CONFIG_DIR", tempfile.mkdtemp(prefix="brdf-studio-soak-"))

    import numpy as np
    import psutil
    from PySide6.QtCore import QEventLoop
    from PySide6.QtWidgets import QApplication

    from app.main_window import MainWindow, demo_scene_path

    _app = QApplication.instance() or QApplication([])  # kept referenced for the whole run
    events = QEventLoop()  # see bench/app_latency.py: QEventLoop.processEvents, not QCoreApplication's

    def run_for(seconds: float, until=None) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if until is not None and until():
                return True
            events.processEvents()
            time.sleep(0.002)
        return until is None or bool(until())

    t_start = time.monotonic()
    window = MainWindow()  # with the kernel warm-up, as the app starts
    window.ask_unsaved = lambda: "discard"
    window.resize(1400, 900)
    window.show()
    window.open_project(demo_scene_path(), confirm=False, remember=False)
    window.tabs.setCurrentWidget(window.render_panel)
    panel = window.render_view
    panel.width_box.setValue(width)
    panel.height_box.setValue(height)
    panel.mode.setCurrentIndex(panel.mode.findData("spp"))
    panel.spp.setValue(100_000)
    panel.strategy_a.setCurrentText(strategy_a)
    panel.strategy_b.setCurrentText(strategy_b)
    names = panel.strategies()
    run_for(600.0, until=lambda: window.jobs_idle("warm_up") and panel.server.pid is not None)
    print(f"window up, kernels warm, render process {panel.server.pid} in {time.monotonic() - t_start:.1f} s")

    gui = psutil.Process()
    rss_before = gui.memory_info().rss / 2**20, psutil.Process(panel.server.pid).memory_info().rss / 2**20
    crashes: list[str] = []
    panel.server.events_received.connect(
        lambda batch: crashes.extend(e["text"] for e in batch if e["kind"] == "crashed")
    )
    rng = random.Random(args.seed)
    rows = []
    for cycle in range(args.cycles):
        how = ("frames", "early", "restart")[cycle % 3]
        delay = rng.uniform(0.0, 0.3)
        t0 = time.monotonic()
        window.start_render()
        if how == "early":
            run_for(delay)
        else:
            for attempt in range(2 if how == "restart" else 1):
                if attempt == 1:
                    window.start_render()  # Restart: cancels the running render, starts a new one
                ok = run_for(600.0, until=lambda: all(n in panel.frames for n in names) or not panel.running)
                if not ok or not panel.running:
                    crashes.append(f"cycle {cycle}: the render ended by itself ({panel.status_text})")
        t_cancel = time.monotonic()
        window.cancel_render()
        acknowledged = run_for(60.0, until=lambda: not panel.server.busy)
        t_ack = time.monotonic()
        run_for(0.05)  # let deferred deletions and queued signals run, as the idle event loop would
        render_pid = panel.server.pid
        try:
            render_rss = psutil.Process(render_pid).memory_info().rss if render_pid else 0
        except psutil.NoSuchProcess:
            render_rss = 0
        rows.append({
            "cycle": cycle,
            "cancel": how,
            "frames_shown": len(panel.frames),
            "render_s": round(t_cancel - t0, 4),
            "cancel_ack_s": round(t_ack - t_cancel, 4) if acknowledged else "",
            "gui_rss_mib": round(gui.memory_info().rss / 2**20, 2),
            "render_rss_mib": round(render_rss / 2**20, 2),
            "render_pid": render_pid or "",
            "gui_threads": gui.num_threads(),
            "python_threads": threading.active_count(),
            "open_fds": gui.num_fds(),
            "child_processes": len([c for c in gui.children(recursive=True) if c.status() != "zombie"]),
        })  # fmt: skip
        if not acknowledged:
            crashes.append(f"cycle {cycle}: the cancel was not acknowledged in 60 s")
        if cycle % 10 == 9 or cycle == 0:
            r = rows[-1]
            print(f"cycle {cycle + 1:>4}: GUI {r['gui_rss_mib']:8.1f} MiB, render {r['render_rss_mib']:8.1f} MiB, "
                  f"threads {r['gui_threads']}, fds {r['open_fds']}, children {r['child_processes']}, "
                  f"cancel ack {r['cancel_ack_s']} s", flush=True)  # fmt: skip
    wall = time.monotonic() - t_start
    errors = list(window.errors)
    pids = {r["render_pid"] for r in rows}
    restarts = panel.server.restarts
    window.close()

    head = (
        f"{args.cycles} render start/cancel cycles ({' vs '.join(names)}, {width}x{height}, demo scene) in "
        f"{wall:.0f} s; load average {os.getloadavg()[0]:.1f}"
    )
    acks = [r["cancel_ack_s"] for r in rows if r["cancel_ack_s"] != ""]
    print(f"\n{head}")
    met = report(rows, args.warm_up)
    print(f"(before the first render: GUI {rss_before[0]:.1f} MiB; the render process, still importing, "
          f"{rss_before[1]:.1f} MiB)")  # fmt: skip
    print(f"cancel acknowledged in median {1000 * np.median(acks):.0f} ms, max {1000 * max(acks):.0f} ms; "
          f"render processes used: {len(pids)} ({restarts} replaced by a restart); "
          f"crashes/errors: {len(crashes) + len(errors)}")  # fmt: skip
    for text in crashes + errors:
        print(f"  {text}")

    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "app_soak.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_mem, ax_res) = plt.subplots(1, 2, figsize=(11, 4))
    cycles = [r["cycle"] + 1 for r in rows]
    ax_mem.plot(cycles, [r["gui_rss_mib"] for r in rows], label="GUI process")
    ax_mem.plot(cycles, [r["render_rss_mib"] for r in rows], label="render process")
    ax_mem.axvline(args.warm_up + 0.5, color="grey", ls=":", label="end of warm-up")
    ax_mem.set(xlabel="cycle", ylabel="RSS (MiB)", title="Memory after each start/cancel")
    ax_mem.legend()
    for key in ("gui_threads", "python_threads", "open_fds", "child_processes"):
        ax_res.plot(cycles, [r[key] for r in rows], label=key)
    ax_res.set(xlabel="cycle", ylabel="count", title="Threads, descriptors, processes")
    ax_res.legend()
    fig.tight_layout()
    fig.savefig(args.out / "app_soak.png", dpi=110)
    print(f"wrote {args.out / 'app_soak.csv'} and {args.out / 'app_soak.png'}")
    ok = not crashes and not errors and met
    from app.workers import exit_if_abandoned

    return exit_if_abandoned(0 if ok else 1)


if __name__ == "__main__":
    sys.exit(main())
