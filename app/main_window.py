"""The main window: BRDF exploration of the current material, the sampler on the disk, the scene and the
render panel, around one :class:`app.state.Document`.

Redraws are coalesced: document events mark views stale and a zero-delay timer redraws them once per
event-loop turn (a slider drag never queues up redraws). Work that may take long (albedo quadrature,
adaptive tables, renders) runs in :mod:`app.workers` threads; the window only draws their results.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QAction, QCloseEvent, QKeySequence
from PySide6.QtWidgets import (
    QDockWidget,
    QGridLayout,
    QMainWindow,
    QMessageBox,
    QScrollArea,
    QSplitter,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from app.capabilities import albedo_available, directional_albedo
from app.editors.material import MaterialEditor
from app.state import Document, default_document
from app.view_data import adaptive_line, albedo_line
from app.views.albedo import ALBEDO_THETAS_DEG, AlbedoView
from app.views.direction import DirectionEditor
from app.views.lobe import LobeView
from app.views.placeholder import UnavailablePanel
from app.views.polar import PolarView
from app.views.sphere import SphereView
from app.workers import GeneratorWorker, WorkerPool
from core.errors import BrdfStudioError
from core.model import all_models

APP_NAME = "BRDF Studio"


def _warm_up_kernels():
    """Compile every model's batch evaluation once (numba), yielding each model's label."""
    wo = np.array([[0.0, 0.0, 1.0]])
    for m in all_models():
        m.bind().eval(wo, wo)
        yield m.label


class MainWindow(QMainWindow):
    def __init__(self, document: Document | None = None, warm_up: bool = True):
        super().__init__()
        self.document = document if document is not None else default_document()
        self.workers = WorkerPool()
        self.errors: list[str] = []
        """Every error shown to the user, in order (tests read it; dialogs never block)."""
        self.timings: dict[str, float] = {}
        """Seconds the last redraw of each view took."""
        self._pending: set[str] = set()
        self._refresh_timer = QTimer(self)
        self._refresh_timer.setSingleShot(True)
        self._refresh_timer.setInterval(0)
        self._refresh_timer.timeout.connect(self.refresh_now)
        self._async_jobs: dict[str, dict[str, Any]] = {}

        self.setWindowTitle(APP_NAME)
        self.resize(1400, 900)
        self._build_explore()
        self.tabs = QTabWidget()
        self.tabs.addTab(self.explore, "Explore")
        self.sampling_panel = self._build_sampling()
        self.tabs.addTab(self.sampling_panel, "Sampling")
        self.scene_panel = self._build_scene()
        self.tabs.addTab(self.scene_panel, "Scene")
        self.render_panel = self._build_render()
        self.tabs.addTab(self.render_panel, "Render")
        self.tabs.currentChanged.connect(lambda _: self.schedule("tab"))
        self.setCentralWidget(self.tabs)

        self.material_editor = MaterialEditor(self.document)
        self.material_editor.error.connect(lambda msg: self.show_error("Material", msg))
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(self.material_editor)
        self.material_dock = QDockWidget("Material", self)
        self.material_dock.setObjectName("material_dock")
        self.material_dock.setWidget(scroll)
        self.material_dock.setMinimumWidth(380)
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.material_dock)

        self._build_actions()
        ev = self.document.events
        ev.material_changed.connect(
            lambda name: self.schedule("brdf") if name == self.document.current_material else None
        )
        ev.selection_changed.connect(lambda: self.schedule("brdf"))
        ev.direction_changed.connect(lambda: self.schedule("direction"))
        ev.light_changed.connect(lambda: self.schedule("light"))
        ev.history_changed.connect(self._history_changed)
        ev.path_changed.connect(self._update_title)
        self.statusBar().showMessage("Ready")
        self._update_title()
        self.schedule("brdf")
        if warm_up:
            w = GeneratorWorker(_warm_up_kernels)
            w.yielded.connect(lambda label: self.statusBar().showMessage(f"Compiled kernels: {label}", 1500))
            self.warm_up_worker = self.workers.start(w)
        else:
            self.warm_up_worker = None

    # ---- layout ----------------------------------------------------------------------------------
    def _build_explore(self) -> None:
        self.lobe_view = LobeView()
        self.polar_view = PolarView()
        self.albedo_view = AlbedoView()
        self.sphere_view = SphereView()
        self.direction_editor = DirectionEditor(self.document)
        self.sphere_view.light_dragged.connect(lambda x, y, z: self.document.set_light((x, y, z)))
        left = QWidget()
        lv = QVBoxLayout(left)
        lv.setContentsMargins(0, 0, 0, 0)
        lv.addWidget(self.lobe_view, 1)
        lv.addWidget(self.direction_editor)
        right = QWidget()
        grid = QGridLayout(right)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.addWidget(self.polar_view, 0, 0)
        grid.addWidget(self.albedo_view, 1, 0)
        grid.addWidget(self.sphere_view, 2, 0)
        split = QSplitter(Qt.Orientation.Horizontal)
        split.addWidget(left)
        split.addWidget(right)
        split.setSizes([700, 360])
        self.explore = split

    def _build_sampling(self) -> QWidget:
        return UnavailablePanel("Adaptive sampler on the disk", "the quadtree sampler (core/quadtree.py).")

    def _build_scene(self) -> QWidget:
        return UnavailablePanel("Scene", "scene editing lands in a later step.")

    def _build_render(self) -> QWidget:
        return UnavailablePanel("Render", "the path tracer (renderer/).")

    def _build_actions(self) -> None:
        doc = self.document
        menu = self.menuBar()
        self.file_menu = menu.addMenu("&File")
        self.edit_menu = menu.addMenu("&Edit")
        self.undo_action = QAction("&Undo", self, shortcut=QKeySequence.StandardKey.Undo, triggered=doc.undo)
        self.redo_action = QAction("&Redo", self, shortcut=QKeySequence.StandardKey.Redo, triggered=doc.redo)
        self.edit_menu.addAction(self.undo_action)
        self.edit_menu.addAction(self.redo_action)
        self.edit_menu.addSeparator()
        self.new_material_action = QAction(
            "New &material", self, shortcut="Ctrl+M", triggered=self.material_editor.new_material
        )
        self.edit_menu.addAction(self.new_material_action)
        self.quit_action = QAction(
            "&Quit", self, shortcut=QKeySequence.StandardKey.Quit, triggered=self.close
        )
        self.view_menu = menu.addMenu("&View")
        for i, name in enumerate(("Explore", "Sampling", "Scene", "Render")):
            act = QAction(name, self, shortcut=f"Ctrl+{i + 1}")
            act.triggered.connect(lambda _=False, k=i: self.tabs.setCurrentIndex(k))
            self.view_menu.addAction(act)
        self._history_changed()

    # ---- redraw scheduling ------------------------------------------------------------------------
    def schedule(self, *kinds: str) -> None:
        self._pending.update(kinds)
        self._refresh_timer.start()

    def refresh_now(self) -> None:
        """Redraw what is stale, now (tests and benchmarks call this instead of waiting for the timer)."""
        self._refresh_timer.stop()
        pending, self._pending = self._pending, set()
        if not pending or self.document.current_material is None:
            return
        try:
            brdf = self.document.brdf()
        except BrdfStudioError as exc:
            self.show_error("Material", str(exc))
            return
        wo = np.array(self.document.wo())
        if pending & {"brdf", "direction"}:
            self._timed("lobe", self.lobe_view.show_lobe, brdf, wo)
            self._timed("polar", self.polar_view.show_slice, brdf, wo)
            self.refresh_direction_views(brdf, wo)
        if pending & {"brdf", "light"}:
            self._timed("sphere", self.sphere_view.show_material, brdf, self.document.light_dir)
        if "brdf" in pending:
            self._start_job("albedo", self._albedo_job, brdf)
            self._start_job("adaptive", adaptive_line, brdf)

    def refresh_direction_views(self, brdf, wo) -> None:
        """Hook for views that depend on the material and the direction (the sampler view)."""

    def _timed(self, name: str, fn, *args) -> None:
        t0 = time.perf_counter()
        fn(*args)
        self.timings[name] = time.perf_counter() - t0

    # ---- background jobs (one per kind at a time; the latest request wins) -------------------------
    def _albedo_job(self, brdf):
        return ALBEDO_THETAS_DEG, directional_albedo(brdf, list(ALBEDO_THETAS_DEG))

    def _start_job(self, kind: str, fn, brdf) -> None:
        if kind == "albedo" and not albedo_available():
            message = "Not available yet: the albedo quadrature (core.analysis)."
            self.albedo_view.show_message(message)
            self.material_editor.set_info("albedo", f"Albedo: {message}")
            return
        job = self._async_jobs.setdefault(kind, {"worker": None, "next": None})
        job["next"] = (fn, brdf)
        if job["worker"] is None:
            self._launch_job(kind)

    def _launch_job(self, kind: str) -> None:
        job = self._async_jobs[kind]
        if job["next"] is None:
            job["worker"] = None
            return
        fn, brdf = job["next"]
        job["next"] = None
        worker = GeneratorWorker(fn, brdf)
        key = brdf.key()
        worker.returned.connect(lambda result, k=key: self._job_done(kind, k, result))
        worker.failed.connect(lambda msg: self._job_failed(kind, msg))
        worker.finished.connect(lambda: self._launch_job(kind))
        job["worker"] = worker
        self.workers.start(worker)

    def _job_done(self, kind: str, key: str, result) -> None:
        if self._async_jobs[kind]["next"] is not None:
            return  # a newer request is queued: this result is stale
        try:
            if self.document.brdf().key() != key:
                return
        except (BrdfStudioError, KeyError):
            return
        if kind == "albedo":
            thetas, values = result
            self.albedo_view.show_albedo(thetas, values, self.document.current_material or "")
            self.material_editor.set_info("albedo", albedo_line(thetas, values))
        elif kind == "adaptive":
            self.material_editor.set_info("adaptive", result)

    def _job_failed(self, kind: str, message: str) -> None:
        if kind == "albedo":
            self.albedo_view.show_message(message)
        self.material_editor.set_info(kind, message)

    def jobs_idle(self) -> bool:
        return all(j["worker"] is None and j["next"] is None for j in self._async_jobs.values())

    def start(self, path: Path | None = None, empty: bool = False) -> None:
        """What happens once the window is shown: open ``path`` if given."""

    # ---- window state ------------------------------------------------------------------------------
    def _history_changed(self) -> None:
        doc = self.document
        self.undo_action.setEnabled(doc.can_undo)
        self.redo_action.setEnabled(doc.can_redo)
        self.undo_action.setText(f"&Undo {doc.undo_text()}".strip())
        self.redo_action.setText(f"&Redo {doc.redo_text()}".strip())
        self._update_title()

    def _update_title(self) -> None:
        name = self.document.path.name if self.document.path else "untitled"
        self.setWindowTitle(f"{name}[*] - {APP_NAME}")
        self.setWindowModified(self.document.dirty)

    def show_error(self, title: str, message: str) -> None:
        """Tell the user what went wrong, without blocking (the box is window-modal, opened async)."""
        self.errors.append(message)
        self.statusBar().showMessage(message, 8000)
        box = QMessageBox(QMessageBox.Icon.Warning, title, message, QMessageBox.StandardButton.Ok, self)
        box.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        box.open()
        self.last_error_box = box

    def closeEvent(self, event: QCloseEvent) -> None:  # noqa: N802
        self.shutdown()
        super().closeEvent(event)

    def shutdown(self) -> None:
        """Stop workers and release the 3D views (safe to call twice)."""
        self.workers.shutdown()
        if not getattr(self, "_closed", False):
            self._closed = True
            self.lobe_view.close_view()
