"""Desktop-app responsiveness: parameter edit -> redraw time, and event-loop stalls while a render runs.

    .venv/bin/python bench/app_latency.py [--edits 15] [--render-seconds 8] [--models ggx,phong,...]
        [--parts latency,stall,first] [--fresh] [--strategy-b adaptive_warp] [--reference-spp 64] [--lead 3]

1. ``latency``: for each analytic model, after a warm-up (kernel compilation excluded) and once the slow
   background jobs (albedo quadrature, adaptive-table facts) are done, ``--edits`` edits of one float
   parameter. For each edit, wall-clock time from the edit (``Document.set_param``) until the view is *on
   screen*: the first flush of the window (``frameSwapped`` of the 3D view's OpenGL widget: the window is
   composed through OpenGL) after the view painted its new content:
   - ``lobe``: after the 3D lobe rendered (a VTK render that started after the edit);
   - ``tree``: after the sampler view's canvas painted the snapshot of this edit (the adaptive sampler's tree
     for ``wo``, its samples and the ratio map, computed in the snapshot process and drawn on the GUI thread;
     ``tree draw``: the drawing alone, on the GUI thread);
   - ``lobe+tree``: until both are on screen (the later of the two: the GUI thread draws the lobe while the
     worker builds the tree). Target: <= 100 ms.
   - ``all``: until lobe, tree, polar slice and lit sphere are all on screen.
   The redraw runs as after a user's edit, from the app's own zero-delay timer (the lobe painted at once, the
   polar slice and the lit sphere in the next event-loop turn).
   By default the edits alternate between two values, so after the first two edits the adaptive tables come
   from the sampler's in-memory cache (the app's case for undo/redo or a slider going back); ``--fresh``
   gives every edit a new value, so every edit makes a new table (the case of a slider drag: a whole table,
   every node's tree, made by ``core.sampling.adaptive.table``). The run has a table cache of its own, so
   tables stored by an earlier run are not reused. A new material's first tree comes from its coarse table
   (the full one follows from the background build: ``app.redraw``); ``tree`` times the first tree shown, and
   the ``coarse`` column counts the edits whose first tree was a coarse table's.
2. ``stall``: a 10 ms ``QTimer`` probe on the GUI thread while the render panel renders the demo scene
   (uniform against ``--strategy-b``, equal time), in three phases: ``start`` (from the click until both
   strategies have shown a frame: process start, preparation, compilation), ``render`` (until done) and
   ``cancel`` (a second render cancelled after its first frames, and the two seconds after). A tick's stall is
   its delay beyond the interval; target: p99 <= 50 ms in every phase. First, *Make reference* renders a
   ``--reference-spp`` reference (not timed), so that the panel plots RMSE and relMSE live as it does in use.
   ``--render-seconds 0`` skips it (as does leaving it out of ``--parts``).
   ``--stacks MS``: a watchdog thread samples the GUI thread's Python stack every 5 ms while no tick has come
   for ``MS`` ms, and prints, for each of the longest stalls, where the GUI thread was (the innermost frames
   seen most often): what to make faster or move off the GUI thread.

3. ``first`` (only when asked for): the demo scene in the Render tab, A = uniform, B = ``adaptive_warp``, then
   B = ``adaptive_exact``, 256x192, equal spp; for each pair a new render process with a new, empty table
   cache, started ``--lead`` seconds before the click (the panel starts it when the Render tab is shown);
   seconds from the click (``RenderPanel.start``) until each strategy's first frame is drawn
   (``RenderPanel._show_frame``). Target: <= 5 s. Then where the seconds went: the render process's time
   stamps (``app.render_session.Timeline``: process start, imports, the idle kernel loading, the job's
   arrival, each strategy's preparation and first pass, with numba's compile seconds so far) and each
   first frame's way to the screen (sent, read by the app, on the GUI thread, drawn), on one clock
   (``time.monotonic()``); and the seconds numba spent compiling in each process (target: <= 1 s).

Prints tables; writes ``results/bench/app_latency.csv`` and ``results/bench/app_stall.csv`` (and, for
``first``, ``app_first_image.csv`` and ``app_first_image_steps.csv``). Runs under Xvfb
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
PARTS = ("latency", "stall")
FIRST_TARGET_S = 5.0


def pick_param(model):
    """A float parameter to sweep (the first declared float; log-scale ones are the interesting lobes)."""
    floats = [p for p in model.params if p.kind == "float" and p.hi > p.lo]
    logs = [p for p in floats if p.log]
    return (logs or floats or [None])[0]


def edit_values(param, edits: int, fresh: bool) -> tuple[list[float], list[float]]:
    """``(warm_up, timed)``: the values set before the clock starts, then by the timed edits in order. Two
    alternating values (both set during the warm-up), or (``fresh``) a value never set before at every edit."""
    lo, hi = param.lo, param.hi
    if param.log:
        base = [(lo * hi) ** 0.5, (lo * hi) ** 0.5 * 1.5]
    else:
        base = [lo + (hi - lo) * f for f in (0.3, 0.6)]
    timed = [base[k % 2] * (1.0 + 0.003 * (k + 1) if fresh else 1.0) for k in range(edits)]
    warm_up = [base[1]] if fresh else [base[0], base[1]]
    clip = lambda vs: [min(max(v, lo), hi) for v in vs]  # noqa: E731
    return clip(warm_up), clip(timed)


class ScreenClock:
    """Time stamps of what reached the screen: window flushes, 3D renders, widget paints, snapshots shown.

    It watches the window from outside (signals, VTK observers, an event filter, a wrapped method), so it
    measures any version of the views the same way."""

    def __init__(self, window) -> None:
        from PySide6.QtCore import QEvent, QObject, QTimer

        self.flushes: list[float] = []
        self.renders: list[float] = []
        self.paints: dict[str, list[float]] = {"tree": [], "polar": [], "sphere": []}
        self.shown: list[float] = []
        self.shown_coarse: list[bool] = []
        """Whether each snapshot shown was of a coarse table (a new material's first tree, see app.redraw)."""
        plotter = window.lobe_view.plotter
        self.has_flush = hasattr(plotter, "frameSwapped")
        if self.has_flush:  # a QOpenGLWidget: every flush of the window composes it and emits this
            plotter.frameSwapped.connect(lambda: self.flushes.append(time.perf_counter()))
        plotter.ren_win.AddObserver("EndEvent", lambda *_: self.renders.append(time.perf_counter()))
        widgets = {
            window.sampling_view.figure_view.canvas: "tree",
            window.polar_view.canvas: "polar",
            window.sphere_view: "sphere",
        }
        paints = self.paints

        class PaintFilter(QObject):
            def eventFilter(self, obj, event):  # noqa: N802 (Qt name)
                if event.type() == QEvent.Type.Paint and obj in widgets:
                    what = widgets[obj]
                    if what == "tree":  # its own window: painted and flushed when the event loop comes back
                        QTimer.singleShot(0, lambda: paints["tree"].append(time.perf_counter()))
                    else:
                        paints[what].append(time.perf_counter())
                return False

        self._filter = PaintFilter()
        for w in widgets:
            w.installEventFilter(self._filter)
        view = window.sampling_view
        show = view.show_snapshot

        def show_snapshot(snap):
            self.shown.append(time.perf_counter())
            self.shown_coarse.append(not snap.table.get("complete", True))
            return show(snap)

        view.show_snapshot = show_snapshot

    @staticmethod
    def _first(times: list[float], after: float) -> float | None:
        return next((t for t in times if t >= after), None)

    def first_tree_coarse(self, t0: float) -> bool:
        """Whether the first snapshot shown after ``t0`` was of a coarse table."""
        return next((c for t, c in zip(self.shown, self.shown_coarse, strict=True) if t >= t0), False)

    def on_screen(self, what: str, t0: float) -> float | None:
        """When ``what`` (lobe, tree, polar, sphere) first reached the screen after ``t0`` (None: not yet)."""
        if what == "lobe":
            painted = self._first(self.renders, t0)
        elif what == "tree":
            shown = self._first(self.shown, t0)
            painted = None if shown is None else self._first(self.paints["tree"], shown)
        else:
            painted = self._first(self.paints[what], t0)
        if painted is None or not self.has_flush or what == "tree":
            return painted
        return self._first(self.flushes, painted)


def latency_part(events, window, models: list[str], edits: int, fresh: bool) -> list[dict]:
    from core.brdf import get_model

    doc = window.document
    clock = ScreenClock(window)

    def run_until(done, timeout=600.0) -> bool:
        end = time.monotonic() + timeout
        while not done() and time.monotonic() < end:
            events.processEvents()
            time.sleep(0.0005)
        events.processEvents()
        return done()

    rows = []
    print(f"load average at start: {os.getloadavg()[0]:.2f} (2 cores)")
    mode = (
        "a new value every edit (a new table each time)"
        if fresh
        else "two values alternating (tables cached)"
    )
    print(f"edits: {mode}; ms from the edit until on screen")
    print(
        f"{'model':<20} {'param':<8} {'lobe ms':>9} {'tree ms':>9} {'lobe+tree':>10} {'all views':>10} {'tree draw':>10} "
        f"{'coarse':>6}  (median / max; coarse: edits whose first tree was the coarse table's)"
    )
    views = ("lobe", "tree", "polar", "sphere")
    for name in models:
        try:
            model = get_model(name)
        except Exception as exc:  # a model not in this build
            print(f"{name:<20} skipped: {exc}")
            continue
        param = pick_param(model)
        if param is None:
            print(f"{name:<20} skipped: no float parameter")
            continue
        mat = doc.add_material(name, name=f"bench-{name}")
        doc.select_material(mat)
        window.refresh_now()
        run_until(lambda: window.jobs_idle("sampling"))
        warm_up, values = edit_values(param, edits, fresh)
        for v in warm_up:  # compile what this model needs (and, unless fresh, build both trees)
            doc.set_param(param.name, v)
            doc.end_merge()
            window.refresh_now()
            run_until(lambda: window.jobs_idle("sampling"))
        window.flush_slow_jobs()  # the albedo quadrature must not run during the timed edits
        run_until(window.jobs_idle, timeout=120.0)
        per_view: dict[str, list[float]] = {v: [] for v in (*views, "both", "all", "draw")}
        coarse = 0
        for k in range(edits):
            t0 = time.perf_counter()
            doc.set_param(param.name, values[k])
            doc.end_merge()  # the app's own zero-delay timer redraws, as after a user's edit
            t_sync = time.perf_counter()
            ok = run_until(
                lambda t0=t0: all(clock.on_screen(v, t0) is not None for v in views), timeout=120.0
            )
            if not ok:
                late = [v for v in views if clock.on_screen(v, t0) is None]
                print(f"{name}: edit {k}: not redrawn within 120 s: {', '.join(late)}")
                continue
            ms = {v: (clock.on_screen(v, t0) - t0) * 1e3 for v in views}
            ms["both"] = max(ms["lobe"], ms["tree"])
            ms["all"] = max(ms[v] for v in views)
            ms["draw"] = window.timings.get("sampling_draw", float("nan")) * 1e3  # on the GUI thread
            coarse += clock.first_tree_coarse(t0)
            for v, x in ms.items():
                per_view[v].append(x)
            rows.append({"model": name, "param": param.name, "value": values[k], "edit": k,
                         **{f"{v}_ms": round(x, 2) for v, x in ms.items()},
                         "sync_ms": round((t_sync - t0) * 1e3, 2)})  # fmt: skip
        if not per_view["both"]:
            continue
        med = lambda x: f"{statistics.median(x):5.0f}/{max(x):<4.0f}"  # noqa: E731
        print(
            f"{name:<20} {param.name:<8} {med(per_view['lobe']):>9} {med(per_view['tree']):>9} "
            f"{med(per_view['both']):>10} {med(per_view['all']):>10} {med(per_view['draw']):>10} "
            f"{coarse:>3}/{len(per_view['both'])}"
        )
    print(f"load average after part 1: {os.getloadavg()[0]:.2f}")
    return rows


def _numba_clock():
    """The app's :class:`~app.render_session.NumbaClock` for this (the GUI) process, or a stand-in that counts
    nothing in a version of the app without one."""
    try:
        from app.render_session import NumbaClock
    except ImportError:
        from types import SimpleNamespace

        return SimpleNamespace(compile_s=float("nan"))
    return NumbaClock().install()


def first_part(events, window, lead_s: float = 3.0, timeout: float = 600.0) -> tuple[list[dict], list[dict]]:
    """Seconds from a click on Render until the first frame of each strategy is shown, and where they went;
    see the module docstring. Returns ``(rows, timeline rows)``."""
    from app.main_window import demo_scene_path

    gui_numba = _numba_clock()  # kernels this (the GUI) process loads or compiles after the click
    window.open_project(demo_scene_path(), confirm=False, remember=False)
    window.tabs.setCurrentWidget(window.render_panel)
    panel = window.render_view
    shown: dict[str, float] = {}
    show = panel._show_frame

    def show_frame(event):
        out = show(event)
        shown.setdefault(event["strategy"], time.monotonic())
        return out

    panel._show_frame = show_frame
    received: list[tuple[float, dict]] = []  # (when the GUI thread had the batch, event)
    panel.server.events_received.connect(lambda batch: received.extend((time.monotonic(), e) for e in batch))

    def run_for(seconds: float, until=lambda: False) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end and not until():
            events.processEvents()
            time.sleep(0.001)

    rows, timeline_rows = [], []
    print(f"\nfirst image after Render (demo scene, {panel.width_box.value()}x{panel.height_box.value()}, "
          f"{panel.mode.currentText()}; the render process started {lead_s:g} s before the click, as when "
          f"the Render tab is shown; load average {os.getloadavg()[0]:.2f})")  # fmt: skip
    print(f"{'A / B':<24} {'strategy':<15} {'s to first image':>17} {'target s':>9} {'met':>4}")
    for b in ("adaptive_warp", "adaptive_exact"):
        panel.server.stop()  # a new process, with a new and empty table cache
        os.environ["BRDF_STUDIO_CACHE"] = tempfile.mkdtemp(prefix="brdf-studio-bench-first-")
        panel.server.ensure_started()
        spawned = getattr(panel.server, "started_at", None)  # (None: a version without time stamps)
        run_for(lead_s)
        panel.strategy_a.setCurrentText("uniform")
        panel.strategy_b.setCurrentText(b)
        names = panel.strategies()
        shown.clear()
        received.clear()
        gui_compile0 = gui_numba.compile_s
        t0 = time.monotonic()
        panel.start()
        job = panel.job
        run_for(timeout, until=lambda names=names: all(n in shown for n in names) or not panel.running)
        panel.cancel()
        pair = f"uniform / {b}"
        for name in names:
            secs = shown[name] - t0 if name in shown else float("nan")
            met = secs <= FIRST_TARGET_S
            ok = "yes" if met else "no"
            print(f"{pair:<24} {name:<15} {secs:>17.2f} {FIRST_TARGET_S:>9g} {ok:>4}")
            rows.append({"a": "uniform", "b": b, "strategy": name, "seconds": round(secs, 3),
                         "target_s": FIRST_TARGET_S, "met": met, "lead_s": lead_s})  # fmt: skip
        if panel.status_text:
            print(f"  status: {panel.status_text}")
        # where the seconds went: the render process's marks, then each first frame's way to the screen
        mine = [(t, e) for t, e in received if e.get("job") == job]
        timings = [e for _, e in mine if e["kind"] == "timing"]
        marks = timings[-1]["marks"] if timings else []
        steps = [("render process started (spawn)", spawned, None)]
        steps += [(m["step"], m["t"], m["compile_s"]) for m in marks]
        for name in names:
            first = next(((t, e) for t, e in mine if e["kind"] == "frame" and e["strategy"] == name), None)
            if first is not None:
                drained, event = first
                steps += [(f"frame {name}: sent", event.get("sent"), None),
                          (f"frame {name}: read by the app", event.get("received"), None),
                          (f"frame {name}: on the GUI thread", drained, None)]  # fmt: skip
            if name in shown:
                steps.append((f"frame {name}: shown", shown[name], None))
        steps.append(("click on Render", t0, None))
        steps = sorted((s for s in steps if s[1] is not None), key=lambda x: x[1])
        print(f"  {'s from click':>12} {'step s':>7}  step (render process: numba compile s so far)")
        previous = None
        for label, t, compile_s in steps:
            delta = "" if previous is None else f"{t - previous:7.2f}"
            note = "" if compile_s is None else f" (compile {compile_s:.2f})"
            print(f"  {t - t0:12.2f} {delta:>7}  {label}{note}")
            timeline_rows.append({"pair": pair, "step": label, "s_from_click": round(t - t0, 4),
                                  "compile_s": compile_s})  # fmt: skip
            previous = t
        compiled = [m["compile_s"] for m in marks if m["compile_s"] is not None]
        print(f"  numba compiling after setup: render process {max(compiled, default=0.0):.2f} s, "
              f"app (GUI) process during the render {gui_numba.compile_s - gui_compile0:.2f} s (target <= 1 s)")  # fmt: skip
    panel.server.stop()
    panel._show_frame = show
    return rows, timeline_rows


class StallStacks:
    """A watchdog thread: while the GUI thread has not ticked for ``threshold_ms``, it samples every 5 ms the
    GUI thread's Python stack (``sys._current_frames``), its scheduler state and CPU time
    (``/proc/self/task/TID/stat``: R running or waiting for a core, S sleeping, e.g. on the interpreter lock)
    and what the other Python threads are doing; :meth:`report` prints the longest stalls with what was seen
    most often during each. CPU time that grows with the stall means work on the GUI thread; a sleeping thread
    waits for a lock (the GIL held by another thread); a running one that gets no CPU time waits for a core."""

    def __init__(self, threshold_ms: float) -> None:
        import threading

        self.threshold = threshold_ms / 1e3
        self.gui = threading.get_ident()
        self.gui_native = threading.get_native_id()
        self.last = time.monotonic()
        self.phase = "baseline"
        self.stalls: list[dict] = []
        self._current: dict | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="stall-stacks")
        self._thread.start()

    def _stat(self) -> tuple[str, float]:
        """The GUI thread's scheduler state (with the kernel function it sleeps in: ``futex`` is a lock,
        the interpreter's or a GL fence; ``poll`` a socket, e.g. the X server's) and its CPU seconds."""
        task = Path(f"/proc/self/task/{self.gui_native}")
        try:
            text = (task / "stat").read_text()
            wchan = (task / "wchan").read_text().strip()
        except OSError:
            return "?", 0.0
        fields = text[text.rindex(")") + 2 :].split()
        state = fields[0] if fields[0] != "S" or wchan in ("", "0") else f"S:{wchan}"
        return state, (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def tick(self, phase: str) -> None:
        now = time.monotonic()
        current, self._current = self._current, None
        if current is not None:
            current["ms"] = (now - current["since"]) * 1e3
            current["cpu_ms"] = (self._stat()[1] - current["cpu0"]) * 1e3
            self.stalls.append(current)
        self.last, self.phase = now, phase

    @staticmethod
    def _where(frame, depth: int) -> str:
        import traceback

        stack = traceback.extract_stack(frame)[-depth:]
        return " <- ".join(f"{Path(f.filename).name}:{f.lineno} {f.name}" for f in reversed(stack))

    def _run(self) -> None:
        from collections import Counter

        idle = ("wait", "select", "_recv", "poll", "_poll", "accept", "get", "_wait_for_tstate_lock")
        while not self._stop.wait(0.005):
            since = self.last
            if time.monotonic() - since < self.threshold:
                continue
            frames = sys._current_frames()
            frame = frames.get(self.gui)
            if frame is None:
                continue
            current = self._current
            if current is None or current["since"] != since:
                cpu0 = self._stat()[1]
                current = self._current = {"since": since, "phase": self.phase, "stacks": Counter(),
                                           "states": Counter(), "others": Counter(), "cpu0": cpu0}  # fmt: skip
            current["stacks"][self._where(frame, 6)] += 1
            current["states"][self._stat()[0]] += 1
            for ident, other in frames.items():
                if ident not in (self.gui, self._thread.ident) and other.f_code.co_name not in idle:
                    current["others"][self._where(other, 3)] += 1

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()

    def report(self, top: int = 12) -> None:
        longest = sorted(self.stalls, key=lambda s: -s["ms"])[:top]
        print(f"\nthe {len(longest)} longest GUI-thread stalls (of {len(self.stalls)} over the threshold):")
        for s in longest:
            states = ", ".join(f"{k} {v}" for k, v in s["states"].most_common())
            print(
                f"  {s['ms']:7.1f} ms in {s['phase']}: GUI thread CPU {s['cpu_ms']:.0f} ms; states {states}"
            )
            for key, n in s["stacks"].most_common(2):
                print(f"      {n:3d} x {key}")
            for key, n in s["others"].most_common(2):
                print(f"      other thread {n:3d} x {key}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edits", type=int, default=15)
    parser.add_argument("--render-seconds", type=float, default=8.0)
    parser.add_argument("--models", default=DEFAULT_MODELS)
    parser.add_argument(
        "--strategy-b", default="adaptive_warp", help="the render's second strategy (stall part)"
    )
    parser.add_argument(
        "--reference-spp",
        type=int,
        default=64,
        help="make a reference first (0: none), so errors are plotted",
    )
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument(
        "--parts", default=",".join(PARTS), help="latency, stall and/or first (comma-separated)"
    )
    parser.add_argument("--fresh", action="store_true", help="a new parameter value (a new tree) every edit")
    parser.add_argument(
        "--lead",
        type=float,
        default=3.0,
        help="first part: seconds between the render process's start (the Render tab shown) and the click",
    )
    parser.add_argument(
        "--stacks",
        type=float,
        default=0.0,
        help="stall part: sample the GUI thread's stack during stalls longer than this many ms (0: off)",
    )
    args = parser.parse_args()
    parts = {p.strip() for p in args.parts.split(",") if p.strip()}
    if not parts <= {*PARTS, "first"}:
        parser.error(f"--parts: choose from {', '.join(PARTS)}, first")
    if args.render_seconds <= 0:
        parts.discard("stall")
    ensure_display()
    os.environ.setdefault("BRDF_STUDIO_CONFIG_DIR", tempfile.mkdtemp(prefix="brdf-studio-bench-"))
    # A table cache of this run's own (the snapshot process inherits it): with the shared one, a second run
    # would load the "fresh" trees the first one stored instead of building them.
    os.environ["BRDF_STUDIO_CACHE"] = tempfile.mkdtemp(prefix="brdf-studio-bench-tables-")

    from PySide6.QtCore import QElapsedTimer, QEventLoop, QTimer
    from PySide6.QtWidgets import QApplication

    from app.main_window import MainWindow, demo_scene_path

    _app = QApplication.instance() or QApplication([])  # kept referenced for the whole run
    # Spin the event loop through a QEventLoop: with PySide6 6.12 on Python 3.11, each call of
    # QCoreApplication.processEvents() from Python drops a reference to None, and a long wait ends in
    # "Fatal Python error: none_dealloc"; QEventLoop.processEvents() does not.
    events = QEventLoop()
    window = MainWindow(warm_up=False)
    window.ask_unsaved = lambda: "discard"
    window.resize(1400, 900)
    window.show()
    if "latency" in parts:
        # The lobe (Explore tab) and the sampler view (Sampling tab) on screen together: the sampler panel leaves
        # its tab for a window of its own, of the tab area's size, and redraws on every edit.
        panel = window.sampling_panel
        size = window.tabs.currentWidget().size()
        window.tabs.removeTab(window.tabs.indexOf(panel))
        panel.setParent(None)
        panel.resize(size)
        panel.show()
        window.sampling_always = True
    events.processEvents()

    args.out.mkdir(parents=True, exist_ok=True)
    if "latency" in parts:
        models = [m.strip() for m in args.models.split(",") if m.strip()]
        rows = latency_part(events, window, models, args.edits, args.fresh)
        if rows:
            with open(args.out / "app_latency.csv", "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
    if "first" in parts:
        cache = os.environ["BRDF_STUDIO_CACHE"]
        rows, timeline_rows = first_part(events, window, args.lead)
        os.environ["BRDF_STUDIO_CACHE"] = cache
        for name, table in (("app_first_image.csv", rows), ("app_first_image_steps.csv", timeline_rows)):
            with open(args.out / name, "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(table[0]))
                w.writeheader()
                w.writerows(table)
    if "stall" not in parts:
        window.close()
        from app.workers import exit_if_abandoned

        return exit_if_abandoned(0)

    # ---- event-loop stall probe: render start, render, cancel ---------------------------------------------
    stall: dict[str, list[float]] = {"baseline": [], "start": [], "render": [], "cancel": []}
    clock = QElapsedTimer()
    state = {"last": None, "phase": "baseline"}
    interval_ms = 10

    watchdog = StallStacks(args.stacks) if args.stacks > 0 else None

    def tick() -> None:
        now = clock.nsecsElapsed() / 1e6
        if state["last"] is not None:
            stall[state["phase"]].append(now - state["last"] - interval_ms)
        state["last"] = now
        if watchdog is not None:
            watchdog.tick(state["phase"])

    def run_for(seconds: float, until=None) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end and not (until is not None and until()):
            events.processEvents()
            time.sleep(0.001)

    def phase(name: str) -> None:
        state["phase"], state["last"] = name, None

    window.sampling_always = False
    if window.sampling_panel.parent() is None:
        window.sampling_panel.hide()
    window.open_project(demo_scene_path(), confirm=False, remember=False)
    window.tabs.setCurrentWidget(window.render_panel)
    panel = window.render_view
    panel.width_box.setValue(192)
    panel.height_box.setValue(128)
    panel.mode.setCurrentIndex(panel.mode.findData("time"))
    panel.seconds.setValue(args.render_seconds)
    panel.strategy_a.setCurrentText("uniform")
    panel.strategy_b.setCurrentText(args.strategy_b)
    names = panel.strategies()
    if args.reference_spp > 0:  # the panel as it is used: errors against a reference, plotted live
        from app import reference

        reference.TARGET_SPP = reference.CHUNK_SPP = args.reference_spp
        window.make_reference()
        run_for(1800.0, until=lambda: not panel.reference_runner.wanted)
        print(f"reference: {panel.reference_runner.reference.spp} spp (made in the app, before the probe)")
    timer = QTimer()
    timer.setInterval(interval_ms)
    timer.timeout.connect(tick)
    clock.start()
    timer.start()
    run_for(2.0)
    # start: from the click until both strategies have shown a frame (process start, preparation, compilation)
    phase("start")
    t0 = time.monotonic()
    panel.start()
    run_for(600.0, until=lambda: all(n in panel.frames for n in names) or not panel.running)
    first_s = time.monotonic() - t0
    phase("render")
    run_for(args.render_seconds * 4 + 300, until=lambda: not panel.running)
    render_wall = time.monotonic() - t0
    frames = {n: f["spp"] for n, f in panel.frames.items()}
    # cancel: a second render, cancelled after its first frames, and the two seconds after the cancel
    panel.seconds.setValue(max(args.render_seconds, 30.0))
    panel.start()
    run_for(600.0, until=lambda: all(n in panel.frames for n in names))
    run_for(1.0)
    phase("cancel")
    panel.cancel()
    run_for(2.0)
    timer.stop()
    if watchdog is not None:
        watchdog.stop()
        watchdog.report()
    print(f"\nrender of the demo scene ({panel.width_box.value()}x{panel.height_box.value()}, uniform vs "
          f"{args.strategy_b}, equal time {args.render_seconds:g} s each): first frames of both after "
          f"{first_s:.1f} s, done after {render_wall:.1f} s wall, spp {frames}")  # fmt: skip
    print(f"{'phase':<10} {'ticks':>6} {'median ms':>10} {'p99 ms':>8} {'max stall ms':>13} {'target':>7}")
    out_rows = []
    for name, gaps in stall.items():
        if not gaps:
            continue
        gaps_sorted = sorted(gaps)
        p99 = gaps_sorted[int(0.99 * (len(gaps_sorted) - 1))]
        met = "" if name == "baseline" else ("met" if p99 <= 50.0 else "MISSED")
        print(
            f"{name:<10} {len(gaps):>6} {statistics.median(gaps):>10.1f} {p99:>8.1f} {max(gaps):>13.1f} {met:>7}"
        )
        out_rows += [{"phase": name, "tick": i, "stall_ms": round(g, 3)} for i, g in enumerate(gaps)]
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
