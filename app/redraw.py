"""Keeping the material views current: the lobe, polar slice and lit sphere redrawn on the GUI thread, the
sampler view's snapshot, the albedo curve and the adaptive table's facts computed as background jobs.

Redraws are coalesced: document events mark views stale and a zero-delay timer redraws them once per
event-loop turn (a slider drag never queues redraws up), or just before the window's next paint if that comes
first, so that the views and the editor's widgets reach the screen in one flush. Views on a hidden tab stay
stale until shown. The albedo quadrature and the table facts (seconds of
work) start once edits pause for :data:`SLOW_JOB_DELAY_MS`, so a drag keeps the CPU for the lobe and tree.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QEvent, QObject, QTimer

from app import snapshot_process
from app.jobs import Job, Lane
from app.view_data import albedo_line
from app.views.albedo import ALBEDO_THETAS_DEG
from core.errors import BrdfStudioError

if TYPE_CHECKING:
    from app.main_window import MainWindow

SLOW_JOB_DELAY_MS = 300
FOLLOW_UP_MS = 250
"""The sampler view shows a new material's first fit (or coarse table) while its full table is built in the
snapshot process, and asks again every this many ms for the full table's picture. It does not wait there:
the process does one request at a time, and a drag's next value would queue behind the wait."""


class Redrawer(QObject):
    def __init__(self, window: MainWindow):
        super().__init__(window)
        self.window = window
        self.document = window.document
        self.timings: dict[str, float] = {}
        """Seconds the last redraw of each view took."""
        self.sampling_always = False
        """Redraw the sampler view on every edit even when its tab is hidden (the latency benchmark)."""
        self._pending: set[str] = set()
        self._sampling_stale = True
        self._sampling_requested = 0.0
        self._sampling_ident: tuple = ()
        """What the last snapshot asked for was of (material, direction, view options)."""
        self._timer = QTimer(window)
        self._timer.setSingleShot(True)
        self._timer.setInterval(0)
        self._timer.timeout.connect(self.refresh_now)
        self._stale: set[str] = set()
        """The Explore tab's views whose picture is out of date: ``lobe``, ``polar``, ``sphere``."""
        window.installEventFilter(self)
        self.slow_timer = QTimer(window)
        self.slow_timer.setSingleShot(True)
        self.slow_timer.setInterval(SLOW_JOB_DELAY_MS)
        self.slow_timer.timeout.connect(self._start_slow_jobs)
        self.follow_up_timer = QTimer(window)
        self.follow_up_timer.setSingleShot(True)
        self.follow_up_timer.setInterval(FOLLOW_UP_MS)
        self.follow_up_timer.timeout.connect(lambda: self.schedule("follow-up"))
        jobs = window.jobs
        self.sampling_lane = jobs.lane("sampling", self._sampling_started)
        self.albedo_lane = jobs.lane("albedo")
        self.adaptive_lane = jobs.lane("adaptive")
        doc = self.document
        doc.events.materials.connect(self._materials_changed)
        doc.selection_changed.connect(lambda: self.schedule("brdf"))
        doc.direction_changed.connect(lambda: self.schedule("direction"))
        doc.preview_light_changed.connect(lambda: self.schedule("light"))

    def _materials_changed(self, items: Any) -> None:
        names = self.document.material_names()
        current = self.document.current_material
        if items is None or (current in names and names.index(current) in items):
            self.schedule("brdf")

    def schedule(self, *kinds: str) -> None:
        self._pending.update(kinds)
        self._timer.start()

    def stop(self) -> None:
        self.follow_up_timer.stop()
        self._timer.stop()
        self.slow_timer.stop()

    def refresh_now(self) -> None:
        """Redraw what is stale, now (tests and benchmarks call this instead of waiting for the timer)."""
        self._refresh()

    def eventFilter(self, obj: Any, event: QEvent) -> bool:  # noqa: N802 (Qt name)
        """Redraw stale views just before the window's next paint, so that they are composed with it: a
        parameter edit also repaints the editor's widgets, and the window would otherwise be flushed once for
        them and again for the views (each flush composes the whole window through OpenGL: tens of ms under
        a software renderer)."""
        if event.type() == QEvent.Type.UpdateRequest and self._pending:
            self._refresh()
        return False

    def _explore_shown(self) -> bool:
        """The Explore tab's views can be seen (or the window is not shown at all: tests draw offscreen)."""
        w = self.window
        return not w.isVisible() or w.tabs.currentWidget() is w.explore

    def _refresh(self) -> None:
        self._timer.stop()
        pending, self._pending = self._pending, set()
        w, doc = self.window, self.document
        if not pending or doc.current_material is None:
            return
        try:
            brdf = doc.brdf()
        except BrdfStudioError as exc:
            w.show_error("Material", str(exc))
            return
        wo = np.array(doc.wo())
        # The sampler view's tree is made in another process: ask first so it runs while this thread draws.
        if pending & {"brdf", "direction", "sampling", "tab", "follow-up"}:
            self._sampling_stale = True
        if "brdf" in pending:  # the snapshot process's slow facts of the previous value are not wanted now
            snapshot_process.interrupt()
        if self._sampling_stale and (self.sampling_always or w.tabs.currentWidget() is w.sampling_panel):
            self._sampling_stale = False
            view_opts = w.sampling_view.options()
            # A new material shows a first tree at once; a follow-up (only after such a snapshot, with nothing
            # else changed) asks for the full table's picture only (see FOLLOW_UP_MS).
            follow_up = pending == {"follow-up"}
            if not follow_up:  # a new material or direction: the process's waits for older ones give up
                self.follow_up_timer.stop()
                snapshot_process.interrupt()
            opts = {
                **view_opts,
                "progressive": True,
                "only_complete": follow_up,
                "asked_at": snapshot_process.generation(),
            }
            mat = doc.material()
            spec = snapshot_process.spec_of(mat.model or "", mat.measured, mat.params)
            self._sampling_requested = time.perf_counter()
            self._sampling_ident = (brdf.key(), doc.theta_deg, doc.phi_deg, tuple(sorted(view_opts.items())))
            self.sampling_lane.submit(Job(
                snapshot_process.snapshot, (spec, doc.theta_deg, doc.phi_deg), opts,
                key=(*self._sampling_ident, follow_up),
                done=self._sampling_done, failed=w.sampling_view.show_message,
            ))  # fmt: skip
        if pending & {"brdf", "direction"}:
            self._stale |= {"lobe", "polar"}
        if pending & {"brdf", "light"}:
            self._stale.add("sphere")
        # Views on a hidden tab stay stale until it is shown (a tab change schedules a refresh): an edit made
        # on the Sampling tab does not pay for the lobe, the slice and the sphere nobody sees.
        if self._stale and self._explore_shown():
            self._draw_stale(brdf, wo)
        if "brdf" in pending:
            self.slow_timer.start()  # restarts: the quadrature waits until edits pause

    def _draw_stale(self, brdf: Any, wo: np.ndarray) -> None:
        w = self.window
        for view, draw, args in (
            ("lobe", w.lobe_view.show_lobe, (brdf, wo)),
            ("polar", w.polar_view.show_slice, (brdf, wo)),
            ("sphere", w.sphere_view.show_material, (brdf, self.document.light_dir)),
        ):
            if view in self._stale:
                self._stale.discard(view)
                self._timed(view, draw, *args)

    def draw_hidden_views(self) -> None:
        """Bring the Explore tab's views up to date even while hidden (an export reads them)."""
        self.refresh_now()
        doc = self.document
        if not self._stale or doc.current_material is None:
            return
        try:
            brdf = doc.brdf()
        except BrdfStudioError:
            return
        self._draw_stale(brdf, np.array(doc.wo()))

    def _timed(self, name: str, fn: Any, *args: Any) -> None:
        t0 = time.perf_counter()
        fn(*args)
        self.timings[name] = time.perf_counter() - t0

    def _sampling_started(self, lane: Lane) -> None:
        if self.window.sampling_view.snapshot is None:
            self.window.sampling_view.show_message(
                "Making the adaptive sampler's table (the first time for a model also compiles its kernels) ..."
            )

    @property
    def follow_up_pending(self) -> bool:
        """Whether the sampler view will ask again for the full table's picture (its timer runs, or it is
        scheduled and not asked yet)."""
        return self.follow_up_timer.isActive() or "follow-up" in self._pending

    def _sampling_done(self, snapshot: Any) -> None:
        if snapshot is None:  # a follow-up: the full table is not made yet
            self.follow_up_timer.start()
            return
        self._timed("sampling_draw", self.window.sampling_view.show_snapshot, snapshot)
        self.timings["sampling"] = time.perf_counter() - self._sampling_requested
        table = snapshot.table
        if not table.get("complete", True) and table.get("full_pending", False):
            self.follow_up_timer.start()

    def _start_slow_jobs(self) -> None:
        self._ask_slow("albedo")
        self._ask_slow("adaptive")

    def _ask_slow(self, kind: str) -> None:
        """A slow fact of the current material, from the snapshot process: the albedo curve (``albedo``) or
        the adaptive table's facts (``adaptive``). Asked again a moment later when it gave way to a newer
        request there (None)."""
        w = self.window
        try:
            brdf = self.document.brdf()
        except (BrdfStudioError, KeyError):
            return
        name = self.document.current_material or ""
        mat = self.document.material()
        spec = snapshot_process.spec_of(mat.model or "", mat.measured, mat.params)
        asked_at = snapshot_process.generation()
        if kind == "albedo":
            lane, fn, args = self.albedo_lane, snapshot_process.albedo, (spec, ALBEDO_THETAS_DEG, asked_at)
            failed = w.albedo_view.show_message
        else:
            lane, fn, args = self.adaptive_lane, snapshot_process.table_facts, (spec, asked_at)
            failed = lambda message: w.material_editor.set_info("adaptive", message)  # noqa: E731

        def done(result: Any) -> None:
            if result is None:
                QTimer.singleShot(SLOW_JOB_DELAY_MS, self, lambda: self._ask_slow(kind))
            elif kind == "albedo":
                w.albedo_view.show_albedo(ALBEDO_THETAS_DEG, result, name)
                w.material_editor.set_info("albedo", albedo_line(ALBEDO_THETAS_DEG, result))
            else:
                w.material_editor.set_info("adaptive", result)

        lane.submit(Job(fn, args, key=brdf.key(), done=done, failed=failed))

    def flush_slow_jobs(self) -> None:
        """Start the delayed jobs now (tests)."""
        if self.slow_timer.isActive():
            self.slow_timer.stop()
            self._start_slow_jobs()
