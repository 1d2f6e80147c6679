"""The main window: BRDF exploration of the current material, the sampler on the disk, the scene and the
render panel, around one :class:`app.state.Document`.

Redraws are coalesced: document events mark views stale and a zero-delay timer redraws them once per
event-loop turn (a slider drag never queues up redraws). Work that may take long (albedo quadrature,
adaptive tables, renders) runs in :mod:`app.workers` threads; the window only draws their results.
"""

from __future__ import annotations

import copy
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

from app import settings, snapshot_process
from app.capabilities import ADAPTIVE_SAMPLERS, albedo_available, directional_albedo, renderer_available
from app.editors.material import MaterialEditor
from app.editors.scene_items import PropertiesStack, SceneItemEditor
from app.editors.scene_tree import SceneTree
from app.project import document_to_scene, load_project, objects_from_mesh, save_project
from app.state import Document, default_document
from app.view_data import adaptive_line, albedo_line
from app.views.albedo import ALBEDO_THETAS_DEG, AlbedoView
from app.views.direction import DirectionEditor
from app.views.lobe import LobeView
from app.views.placeholder import UnavailablePanel
from app.views.polar import PolarView
from app.views.quadtree import SamplingView
from app.views.sphere import SphereView
from app.views.viewport import SceneViewport
from app.workers import GeneratorWorker, WorkerPool
from core.errors import BrdfStudioError
from core.model import all_models
from core.scene import validate_scene

APP_NAME = "BRDF Studio"
AUTOSAVE_MS = 20_000
SLOW_JOB_DELAY_MS = 300
MESH_FILTER = "Meshes (*.obj *.ply *.stl *.off *.glb *.gltf)"
PROJECT_FILTER = "Projects (*.json)"


def demo_scene_path() -> Path | None:
    """The bundled demo scene, if this build has one."""
    from importlib.resources import files

    root = Path(str(files("resources")))
    for candidate in sorted(root.rglob("demo*.json")):
        return candidate
    return None


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
        self._slow_timer = QTimer(self)
        self._slow_timer.setSingleShot(True)
        self._slow_timer.setInterval(SLOW_JOB_DELAY_MS)
        self._slow_timer.timeout.connect(self._start_slow_jobs)
        self._sampling_stale = True
        self._sampling_requested = 0.0
        self.job_errors: dict[str, str] = {}
        """The last failure of each kind of background job (cleared when the next one starts)."""
        self.sampling_always = False
        """Redraw the sampler view on every edit even when its tab is hidden (the latency benchmark)."""

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
        self.item_editor = SceneItemEditor(self.document)  # lights, camera, environment: shown when selected
        self.item_editor.error.connect(lambda msg: self.show_error("Scene", msg))
        self.material_dock.setWidget(
            PropertiesStack(self.document, scroll, self.item_editor, self.material_dock)
        )
        self.material_dock.setMinimumWidth(460)
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.material_dock)

        self.scene_tree = SceneTree(self.document)
        self.scene_tree.error.connect(lambda msg: self.show_error("Scene", msg))
        self.tree_dock = QDockWidget("Scene", self)
        self.tree_dock.setObjectName("scene_dock")
        self.tree_dock.setWidget(self.scene_tree)
        self.addDockWidget(Qt.DockWidgetArea.LeftDockWidgetArea, self.tree_dock)
        self.material_editor.load_measured_requested.connect(lambda: self.load_measured())

        self.setAcceptDrops(True)
        self._autosaved_revision = self.document.revision
        self.autosave_timer = QTimer(self)
        self.autosave_timer.setInterval(AUTOSAVE_MS)
        self.autosave_timer.timeout.connect(self.autosave)
        self.autosave_timer.start()
        self.ask_unsaved = self._ask_unsaved
        """Asks Save / Discard / Cancel; replaceable (tests answer without a modal dialog)."""
        self.ask_restore = self._ask_restore

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
            snapshot_process.prewarm()
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
        self.sampling_view = SamplingView()
        self.sampling_view.options_changed.connect(lambda: self.schedule("sampling"))
        return self.sampling_view

    def _build_scene(self) -> QWidget:
        self.viewport = SceneViewport(self.document)
        self.viewport.object_picked.connect(lambda name: self.document.select_object(name or None))
        return self.viewport

    def _build_render(self) -> QWidget:
        if not renderer_available():
            return UnavailablePanel("Render", "the path tracer (renderer/).")
        from app.views.render import RenderPanel

        self.render_view = RenderPanel(self.render_scene, self.workers)
        self.render_view.error.connect(lambda msg: self.show_error("Render", msg))
        return self.render_view

    def render_scene(self):
        """The scene a render uses: the document as a project, seen from the viewport's camera; a scene with
        no light at all gets a white sky so that it shows something."""
        if not self.document.data.objects:
            raise BrdfStudioError("the scene has no objects: import a mesh (File > Import mesh) first")
        base = self.document.path or (Path.cwd() / "untitled.json")
        data = copy.deepcopy(self.document.data)
        data.extras["camera"] = self.viewport.camera()
        if not data.extras.get("lights") and not data.extras.get("environment"):
            data.extras["environment"] = {"type": "constant", "radiance": [1.0, 1.0, 1.0]}
        scene = document_to_scene(data, base)
        validate_scene(scene, check_files=True)
        return scene

    def _build_actions(self) -> None:
        doc = self.document
        menu = self.menuBar()
        self.file_menu = menu.addMenu("&File")
        fm = self.file_menu
        self.new_action = fm.addAction("&New project", QKeySequence.StandardKey.New, self.new_project)
        self.open_action = fm.addAction("&Open project ...", QKeySequence.StandardKey.Open, self.open_project)
        self.recent_menu = fm.addMenu("Open &recent")
        self.recent_menu.aboutToShow.connect(self._fill_recent)
        self.save_action = fm.addAction("&Save", QKeySequence.StandardKey.Save, self.save_project)
        self.save_as_action = fm.addAction("Save &as ...", QKeySequence("Ctrl+Shift+S"), self.save_project_as)
        fm.addSeparator()
        self.import_action = fm.addAction("&Import mesh ...", QKeySequence("Ctrl+I"), self.import_mesh)
        self.merl_action = fm.addAction("Load &MERL file ...", QKeySequence("Ctrl+L"), self.load_measured)
        fm.addSeparator()
        self.export_menu = fm.addMenu("&Export")
        em = self.export_menu
        em.addAction("&Sample set (CSV, NPY, PLY) ...", QKeySequence("Ctrl+E"), lambda: self.export_samples())
        em.addAction("&Plots (PNG, SVG) ...", QKeySequence("Ctrl+Shift+E"), lambda: self.export_plots())
        em.addAction("&Render images (EXR, PNG) ...", lambda: self.export_render("exr"))
        em.addAction("Render &composite (PNG) ...", lambda: self.export_render("composite"))
        em.addAction("&Error curves (CSV, PNG) ...", lambda: self.export_render("errors"))
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
        self.delete_action = self.edit_menu.addAction(
            "&Delete selected object", QKeySequence.StandardKey.Delete, self.delete_selected
        )
        self.quit_action = QAction(
            "&Quit", self, shortcut=QKeySequence.StandardKey.Quit, triggered=self.close
        )
        self.render_menu = menu.addMenu("&Render")
        self.render_action = self.render_menu.addAction(
            "&Render / restart", QKeySequence("F5"), self.start_render
        )
        self.cancel_render_action = self.render_menu.addAction(
            "&Cancel render", QKeySequence("Esc"), self.cancel_render
        )
        self.render_menu.addAction("Load &reference EXR ...", lambda: self.load_reference())
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
        # The sampler view's tree is built in a worker: start it first so it runs while this thread draws.
        if pending & {"brdf", "direction", "sampling", "tab"}:
            self._sampling_stale = True
        if self._sampling_stale and (
            self.sampling_always or self.tabs.currentWidget() is self.sampling_panel
        ):
            self._sampling_stale = False
            d = self.document
            opts = self.sampling_view.options()
            key = (brdf.key(), d.theta_deg, d.phi_deg, tuple(sorted(opts.items())))
            self._sampling_requested = time.perf_counter()
            mat = d.material()
            spec = snapshot_process.spec_of(mat.model, mat.measured, mat.params)
            self._start_job("sampling", snapshot_process.snapshot, (spec, d.theta_deg, d.phi_deg), key, opts)
        if pending & {"brdf", "direction"}:
            self._timed("lobe", self.lobe_view.show_lobe, brdf, wo)
            self._timed("polar", self.polar_view.show_slice, brdf, wo)
        if pending & {"brdf", "light"}:
            self._timed("sphere", self.sphere_view.show_material, brdf, self.document.light_dir)
        if "brdf" in pending:
            self._slow_timer.start()  # restarts: the quadrature waits until edits pause

    def _start_slow_jobs(self) -> None:
        """Albedo quadrature and adaptive-table facts: seconds of work, started once edits pause so that a
        slider drag keeps the CPU for the lobe and the tree."""
        try:
            brdf = self.document.brdf()
        except (BrdfStudioError, KeyError):
            return
        self._start_job("albedo", self._albedo_job, (brdf,), brdf.key())
        self._start_job("adaptive", adaptive_line, (brdf,), brdf.key())

    def flush_slow_jobs(self) -> None:
        """Start the delayed jobs now (tests)."""
        if self._slow_timer.isActive():
            self._slow_timer.stop()
            self._start_slow_jobs()

    def _timed(self, name: str, fn, *args) -> None:
        t0 = time.perf_counter()
        fn(*args)
        self.timings[name] = time.perf_counter() - t0

    # ---- background jobs (one per kind at a time; the latest request wins) -------------------------
    def _albedo_job(self, brdf):
        return ALBEDO_THETAS_DEG, directional_albedo(brdf, list(ALBEDO_THETAS_DEG))

    def _start_job(self, kind: str, fn, args: tuple, key, kwargs: dict | None = None) -> None:
        """Run ``fn(*args, **kwargs)`` in a worker; only the result of the latest request is shown."""
        if kind == "albedo" and not albedo_available():
            message = "Not available yet: the albedo quadrature (core.analysis)."
            self.albedo_view.show_message(message)
            self.material_editor.set_info("albedo", f"Albedo: {message}")
            return
        job = self._async_jobs.setdefault(kind, {"worker": None, "next": None, "key": None})
        job["next"] = (fn, args, kwargs or {}, key)
        job["key"] = key
        if job["worker"] is None:
            self._launch_job(kind)

    def _launch_job(self, kind: str) -> None:
        job = self._async_jobs[kind]
        if job["next"] is None or getattr(self, "_closed", False):
            job["worker"] = None
            return
        fn, args, kwargs, key = job["next"]
        job["next"] = None
        worker = GeneratorWorker(fn, *args, **kwargs)
        worker.returned.connect(lambda result, k=key: self._job_done(kind, k, result))
        worker.failed.connect(lambda msg, k=key: self._job_failed(kind, k, msg))
        worker.finished.connect(lambda: self._launch_job(kind))
        job["worker"] = worker
        self.job_errors.pop(kind, None)
        self.workers.start(worker)
        if kind == "sampling" and self.sampling_view.snapshot is None:
            self.sampling_view.show_message(
                "Making the adaptive sampler's table (the first time for a model also compiles its kernels) ..."
            )

    def _job_done(self, kind: str, key, result) -> None:
        job = self._async_jobs[kind]
        if job["next"] is not None or job["key"] != key:
            return  # a newer request is queued: this result is stale
        if kind == "albedo":
            thetas, values = result
            self.albedo_view.show_albedo(thetas, values, self.document.current_material or "")
            self.material_editor.set_info("albedo", albedo_line(thetas, values))
        elif kind == "adaptive":
            self.material_editor.set_info("adaptive", result)
        elif kind == "sampling":
            self._timed("sampling_draw", self.sampling_view.show_snapshot, result)
            self.timings["sampling"] = time.perf_counter() - self._sampling_requested

    def _job_failed(self, kind: str, key, message: str) -> None:
        if self._async_jobs[kind]["key"] != key:
            return
        self.job_errors[kind] = message
        if kind == "albedo":
            self.albedo_view.show_message(message)
        elif kind == "sampling":
            self.sampling_view.show_message(message)
        else:
            self.material_editor.set_info(kind, message)

    def jobs_idle(self, *kinds: str) -> bool:
        """No background job (of the given kinds, or of any kind) running or queued."""
        jobs = (
            [self._async_jobs[k] for k in kinds if k in self._async_jobs]
            if kinds
            else self._async_jobs.values()
        )
        return all(j["worker"] is None and j["next"] is None for j in jobs)

    def start(self, path: Path | None = None, empty: bool = False, restore: str = "ask") -> None:
        """Once the window is shown: offer to restore a crashed session's edits, then open ``path``, or the
        bundled demo scene unless ``empty``. ``restore`` is ``"ask"``, ``"yes"`` or ``"no"``."""
        if restore != "no" and self.restore_autosave(ask=restore == "ask"):
            return
        if path is not None:
            self.open_project(path, confirm=False)
        elif not empty:
            demo = demo_scene_path()
            if demo is not None:
                self.open_project(demo, confirm=False, remember=False)
                self.document.set_path(None)  # "Save" asks where: never overwrite the bundled file

    # ---- projects ------------------------------------------------------------------------------------
    def _dialog_path(self, save: bool, title: str, filter_: str) -> Path | None:
        from PySide6.QtWidgets import QFileDialog

        start = str(self.document.path.parent) if self.document.path else str(Path.cwd())
        fn = QFileDialog.getSaveFileName if save else QFileDialog.getOpenFileName
        chosen, _ = fn(self, title, start, filter_)
        return Path(chosen) if chosen else None

    def _ask_unsaved(self) -> str:
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(
            self,
            APP_NAME,
            "The project has unsaved changes. Save them first?",
            buttons.Save | buttons.Discard | buttons.Cancel,
            buttons.Save,
        )
        return {buttons.Save: "save", buttons.Discard: "discard"}.get(answer, "cancel")

    def maybe_save(self) -> bool:
        """Before the document is replaced: True when it is safe to go on (saved, discarded or clean)."""
        if not self.document.dirty:
            return True
        answer = self.ask_unsaved()
        if answer == "save":
            return self.save_project()
        return answer == "discard"

    def new_project(self) -> None:
        if not self.maybe_save():
            return
        fresh = default_document()
        self.document.replace(fresh.data, None)

    def open_project(
        self, path: Path | str | None = None, confirm: bool = True, remember: bool = True
    ) -> bool:
        if confirm and not self.maybe_save():
            return False
        if path is None:
            path = self._dialog_path(False, "Open project", PROJECT_FILTER)
            if path is None:
                return False
        path = Path(path)
        try:
            data = load_project(path)
        except BrdfStudioError as exc:
            self.show_error("Cannot open the project", str(exc))
            return False
        self.document.replace(data, path.resolve())
        self.viewport.apply_camera(data.extras.get("camera"))
        if remember:
            settings.add_recent(path)
        settings.clear_autosave()
        self._autosaved_revision = self.document.revision
        self.statusBar().showMessage(f"Opened {path}", 4000)
        return True

    def save_project(self) -> bool:
        if self.document.path is None:
            return self.save_project_as()
        return self._save_to(self.document.path)

    def save_project_as(self, path: Path | str | None = None) -> bool:
        if path is None:
            path = self._dialog_path(True, "Save project", PROJECT_FILTER)
            if path is None:
                return False
        path = Path(path)
        if path.suffix.lower() != ".json":
            path = path.with_suffix(".json")
        return self._save_to(path)

    def _save_to(self, path: Path) -> bool:
        data = self.document.data
        data.extras["camera"] = self.viewport.camera() if self.viewport.actors else data.extras.get("camera")
        if data.extras.get("camera") is None:
            data.extras.pop("camera", None)
        try:
            save_project(data, path)
        except BrdfStudioError as exc:
            self.show_error("Cannot save the project", str(exc))
            return False
        self.document.set_path(path.resolve())
        self.document.mark_clean()
        settings.add_recent(path)
        settings.clear_autosave()
        self._autosaved_revision = self.document.revision
        self.statusBar().showMessage(f"Saved {path}", 4000)
        return True

    def _fill_recent(self) -> None:
        self.recent_menu.clear()
        recent = settings.recent_files()
        if not recent:
            self.recent_menu.addAction("(none)").setEnabled(False)
        for p in recent:
            self.recent_menu.addAction(str(p), lambda p=p: self.open_project(p))

    def import_mesh(self, paths: list[Path | str] | Path | str | None = None) -> list[str]:
        """Add the meshes of one or more files as objects (one per part); errors shown, nothing lost."""
        if paths is None:
            chosen = self._dialog_path(False, "Import mesh", MESH_FILTER)
            if chosen is None:
                return []
            paths = [chosen]
        if isinstance(paths, str | Path):
            paths = [paths]
        objects = []
        for p in paths:
            try:
                objects += objects_from_mesh(Path(p).resolve(), self.document.current_material or "")
            except BrdfStudioError as exc:
                self.show_error("Cannot import the mesh", str(exc))
        names = self.document.add_objects(objects, label=f"Import {len(objects)} object(s)")
        if names:
            self.viewport.plotter.reset_camera()
            self.viewport.plotter.render()
            self.statusBar().showMessage(f"Imported {', '.join(names)}", 4000)
        return names

    def load_measured(self, path: Path | str | None = None) -> bool:
        """Make the current material measured from a MERL file (a bad file shows why; nothing changes)."""
        if path is None:
            path = self._dialog_path(False, "Load measured BRDF", "MERL BRDF (*.binary)")
            if path is None:
                return False
        try:
            self.document.set_measured(str(Path(path).resolve()))
        except BrdfStudioError as exc:
            self.show_error("Cannot load the measured BRDF", str(exc))
            return False
        return True

    def delete_selected(self) -> None:
        if self.document.selected_item is not None and self.document.selected_item[0] == "light":
            self.item_editor.delete_selected_light()
            return
        name = self.document.selected_object
        if name is None:
            self.statusBar().showMessage(
                "Select an object (in the scene tree or the viewport) to delete it", 4000
            )
            return
        try:
            self.document.remove_object(name)
        except (BrdfStudioError, KeyError) as exc:
            self.show_error("Delete", str(exc))

    # ---- render and exports ----------------------------------------------------------------------------
    def start_render(self) -> None:
        if hasattr(self, "render_view"):
            self.tabs.setCurrentWidget(self.render_panel)
            self.render_view.start()
        else:
            self.show_error("Render", "Not available yet: the path tracer (renderer/).")

    def cancel_render(self) -> None:
        if hasattr(self, "render_view"):
            self.render_view.cancel()

    def load_reference(self, path: Path | str | None = None) -> bool:
        if not hasattr(self, "render_view"):
            return False
        if path is None:
            path = self._dialog_path(False, "Reference image", "OpenEXR (*.exr)")
            if path is None:
                return False
        try:
            self.render_view.load_reference(path)
        except BrdfStudioError as exc:
            self.show_error("Cannot load the reference", str(exc))
            return False
        return True

    def export_render(self, kind: str, path: Path | str | None = None) -> list[Path]:
        if not hasattr(self, "render_view"):
            self.show_error("Export", "Not available yet: the path tracer (renderer/).")
            return []
        if path is None:
            filters = {
                "exr": "OpenEXR (*.exr);;PNG (*.png)",
                "composite": "PNG (*.png)",
                "errors": "CSV (*.csv)",
            }
            path = self._dialog_path(True, "Export render", filters.get(kind, "*"))
            if path is None:
                return []
            if kind == "exr" and path.suffix.lower() == ".png":
                kind = "png"
        try:
            return self.render_view.export(kind, path)
        except BrdfStudioError as exc:
            self.show_error("Export", str(exc))
            return []

    def export_samples(self, path: Path | str | None = None, n: int | None = None) -> Path | None:
        """The current material's samples for the current direction, from the sampler view's strategy."""
        from app.exports import sample_set, write_sample_set

        if path is None:
            path = self._dialog_path(
                True, "Export sample set", "CSV (*.csv);;NumPy (*.npy);;PLY point cloud (*.ply)"
            )
            if path is None:
                return None
        opts = self.sampling_view.options()
        name = opts["ratio_sampler"]
        extra = {"n_max": opts["n_max"]} if name in ADAPTIVE_SAMPLERS.values() else {}
        try:
            rows = sample_set(
                self.document.brdf(), np.array(self.document.wo()), name, n or opts["n_samples"], 0, **extra
            )
            out = write_sample_set(path, rows)
        except BrdfStudioError as exc:
            self.show_error("Export", str(exc))
            return None
        self.statusBar().showMessage(f"Wrote {len(rows)} samples ({name}) to {out}", 5000)
        return out

    def export_plots(self, folder: Path | str | None = None, fmt: str = "png") -> list[Path]:
        """Polar slice, albedo curve and sampler view as ``<folder>/<material>_<plot>.<fmt>``."""
        from PySide6.QtWidgets import QFileDialog

        if folder is None:
            chosen = QFileDialog.getExistingDirectory(self, "Export plots to folder")
            if not chosen:
                return []
            folder = chosen
        stem = (self.document.current_material or "material").replace("/", "_")
        out = []
        try:
            for label, view in (
                ("polar", self.polar_view),
                ("albedo", self.albedo_view),
                ("sampling", self.sampling_view),
            ):
                out.append(view.export(Path(folder) / f"{stem}_{label}.{fmt}"))
        except BrdfStudioError as exc:
            self.show_error("Export", str(exc))
        return out

    # ---- drag and drop -------------------------------------------------------------------------------
    def dragEnterEvent(self, event) -> None:  # noqa: N802
        if event.mimeData().hasUrls():
            event.acceptProposedAction()

    def dropEvent(self, event) -> None:  # noqa: N802
        self.open_dropped([Path(u.toLocalFile()) for u in event.mimeData().urls() if u.isLocalFile()])
        event.acceptProposedAction()

    def open_dropped(self, paths: list[Path]) -> None:
        """Projects open, meshes import, MERL files load into the current material."""
        meshes = [p for p in paths if p.suffix.lower() in (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")]
        for p in paths:
            if p.suffix.lower() == ".json":
                self.open_project(p)
            elif p.suffix.lower() == ".binary":
                self.load_measured(p)
            elif p not in meshes:
                self.show_error("Cannot open the file", f"'{p.name}' is not a project, mesh or MERL file")
        if meshes:
            self.import_mesh(meshes)

    # ---- crash recovery ----------------------------------------------------------------------------
    def autosave(self) -> None:
        """Write unsaved edits for crash recovery (only when something changed since the last write)."""
        doc = self.document
        if doc.revision == self._autosaved_revision:
            return
        self._autosaved_revision = doc.revision
        if not doc.dirty:
            settings.clear_autosave()
            return
        try:
            settings.write_autosave(doc.to_dict(), doc.path)
        except BrdfStudioError as exc:
            self.statusBar().showMessage(f"Autosave failed: {exc}", 8000)

    def _ask_restore(self, when: str) -> bool:
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(
            self,
            APP_NAME,
            f"BRDF Studio did not close normally. Restore the unsaved edits from {when}?",
            buttons.Yes | buttons.No,
            buttons.Yes,
        )
        return answer == buttons.Yes

    def restore_autosave(self, ask: bool = True) -> bool:
        """Offer the newest autosave of a session that died; True when edits were restored."""
        import time as _time

        for path in settings.orphaned_autosaves():
            try:
                payload = settings.read_autosave(path)
                data = Document.data_from_dict(payload["document"])
            except (ValueError, KeyError, TypeError) as exc:
                self.show_error("Cannot restore", str(exc))
                path.unlink(missing_ok=True)
                continue
            when = _time.strftime("%Y-%m-%d %H:%M:%S", _time.localtime(payload.get("time", 0)))
            if ask and not self.ask_restore(when):
                path.unlink(missing_ok=True)
                return False
            project = Path(payload["project"]) if payload.get("project") else None
            self.document.replace(data, project)
            self.document.mark_unsaved()
            self.viewport.apply_camera(data.extras.get("camera"))
            path.unlink(missing_ok=True)
            self.autosave()
            self.statusBar().showMessage(f"Restored unsaved edits from {when}", 8000)
            return True
        return False

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
        if not self.maybe_save():
            event.ignore()
            return
        settings.clear_autosave()
        self.shutdown()
        super().closeEvent(event)

    def shutdown(self) -> None:
        """Stop workers and release the 3D views (safe to call twice)."""
        already = getattr(self, "_closed", False)
        self._closed = True  # no new job starts from here on (a finished one would queue the next)
        for timer in (self._refresh_timer, self._slow_timer, self.autosave_timer):
            timer.stop()
        self.workers.shutdown()
        if not already:
            self.autosave_timer.stop()
            self.lobe_view.close_view()
            self.viewport.close_view()
