"""Projects and files for the main window: new, open, save, import meshes and model files, load MERL files,
drops, the crash-recovery autosave. Dialogs and questions go through the window (``ask_unsaved``,
``ask_restore``, ``ask_trust``, ``show_error``) so that tests answer them without modal dialogs.

Autosave: unsaved edits are written (atomically, to the config folder, never over the project file)
:data:`AUTOSAVE_AFTER_EDIT_MS` after the last edit, and by the window's periodic timer while edits go on
without a pause (a long slider drag); the next launch after a crash offers them (:meth:`restore_autosave`).
"""

from __future__ import annotations

import itertools
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PySide6.QtCore import QTimer

from app import settings
from app.document import default_scene
from app.project import load_project, save_project, scene_from_autosave
from core.errors import BrdfStudioError
from core.model_files import SUFFIXES as MODEL_SUFFIXES
from core.scene import MESH_FORMATS

if TYPE_CHECKING:
    from app.main_window import MainWindow

MESH_FILTER = "Meshes (" + " ".join(f"*{s}" for s in MESH_FORMATS) + ")"
PROJECT_FILTER = "Projects (*.json)"
MODEL_FILTER = "Model files (" + " ".join(f"*{s}" for s in MODEL_SUFFIXES) + ")"
_IMPORTS = itertools.count()
AUTOSAVE_AFTER_EDIT_MS = 2000
"""Quiet time after an edit before it is autosaved (an edit burst is written once)."""


class FileManager:
    def __init__(self, window: MainWindow):
        self.window = window
        self.document = window.document
        self.autosaved_revision = self.document.revision
        self.autosave_soon = QTimer(window)
        self.autosave_soon.setSingleShot(True)
        self.autosave_soon.setInterval(AUTOSAVE_AFTER_EDIT_MS)
        self.autosave_soon.timeout.connect(self.autosave)
        self.document.history_changed.connect(self._history_changed)

    def _history_changed(self) -> None:
        if self.document.revision != self.autosaved_revision:
            self.autosave_soon.start()  # (re)started: written once the edits pause

    def _status(self, text: str, ms: int = 4000) -> None:
        self.window.statusBar().showMessage(text, ms)

    def dialog_path(self, save: bool, title: str, filter_: str) -> Path | None:
        from PySide6.QtWidgets import QFileDialog

        start = str(self.document.path.parent) if self.document.path else str(Path.cwd())
        fn = QFileDialog.getSaveFileName if save else QFileDialog.getOpenFileName
        chosen, _ = fn(self.window, title, start, filter_)
        return Path(chosen) if chosen else None

    # ---- projects -----------------------------------------------------------------------------------
    def maybe_save(self) -> bool:
        """Before the document is replaced: True when it is safe to go on (saved, discarded or clean)."""
        if not self.document.dirty:
            return True
        answer = self.window.ask_unsaved()
        if answer == "save":
            return self.save_project()
        return answer == "discard"

    def new_project(self) -> None:
        if self.maybe_save():
            self.document.replace(default_scene(), None)
            # as when a project is opened: the edits just saved or discarded must not be offered after a crash
            settings.clear_autosave()
            self.autosaved_revision = self.document.revision

    def open_project(
        self, path: Path | str | None = None, confirm: bool = True, remember: bool = True
    ) -> bool:
        if confirm and not self.maybe_save():
            return False
        if path is None:
            path = self.dialog_path(False, "Open project", PROJECT_FILTER)
            if path is None:
                return False
        path = Path(path)
        notes: list[str] = []
        try:
            scene = load_project(path, self.document.parts, self._model_opener(notes))
        except BrdfStudioError as exc:
            self.window.show_error("Cannot open the project", str(exc))
            return False
        finally:
            self._tell_model_notes(notes)
        self.document.replace(scene, path.resolve())
        if remember:
            settings.add_recent(path)
        settings.clear_autosave()
        self.autosaved_revision = self.document.revision
        self._status(f"Opened {path}")
        return True

    def save_project(self) -> bool:
        if self.document.path is None:
            return self.save_project_as()
        return self._save_to(self.document.path)

    def save_project_as(self, path: Path | str | None = None) -> bool:
        if path is None:
            path = self.dialog_path(True, "Save project", PROJECT_FILTER)
            if path is None:
                return False
        path = Path(path)
        return self._save_to(path if path.suffix.lower() == ".json" else path.with_suffix(".json"))

    def _save_to(self, path: Path) -> bool:
        try:
            save_project(self.document.scene, path)
        except BrdfStudioError as exc:
            self.window.show_error("Cannot save the project", str(exc))
            return False
        self.document.set_path(path.resolve())
        self.document.mark_clean()
        settings.add_recent(path)
        settings.clear_autosave()
        self.autosaved_revision = self.document.revision
        self._status(f"Saved {path}")
        return True

    def fill_recent(self, menu) -> None:
        menu.clear()
        recent = settings.recent_files()
        if not recent:
            menu.addAction("(none)").setEnabled(False)
        for p in recent:
            menu.addAction(str(p), lambda p=p: self.open_project(p))

    # ---- files into the project ---------------------------------------------------------------------
    def import_mesh(self, paths: list[Path | str] | Path | str | None = None) -> list[str]:
        """Add the meshes of one or more files (one object per group); the view frames the scene and that
        view becomes the camera, in the same undo step. Errors are shown; nothing is lost."""
        if paths is None:
            chosen = self.dialog_path(False, "Import mesh", MESH_FILTER)
            if chosen is None:
                return []
            paths = [chosen]
        if isinstance(paths, str | Path):
            paths = [paths]
        key = ("import", next(_IMPORTS))
        names: list[str] = []
        for p in paths:
            try:
                names += self.document.add_mesh(Path(p), f"Import {len(paths)} file(s)", merge_key=key)
            except BrdfStudioError as exc:
                self.window.show_error("Cannot import the mesh", str(exc))
        if names:
            viewport = self.window.viewport
            viewport.plotter.reset_camera()
            self.document.set_camera(viewport.camera(), join_last=True)  # the import's own undo step
            viewport.plotter.render()
            self.document.end_merge()
            self._status(f"Imported {', '.join(names)}")
        return names

    def import_model(self, path: Path | str | None = None) -> bool:
        """Open a model file (``.brdf``, ``.py``) as the current material's model (a new material's when the
        project has none); the app watches it from now on. A bad file shows why; nothing changes."""
        if path is None:
            path = self.dialog_path(False, "Import model", MODEL_FILTER)
            if path is None:
                return False
        full = str(Path(path).resolve())
        doc = self.document
        try:
            model = self.window.model_files.open(full)
            if doc.current_material is None:
                doc.add_material(full, name=Path(full).stem)
            else:
                doc.set_model(full)
        except BrdfStudioError as exc:
            self.window.show_error("Cannot import the model", str(exc))
            return False
        self._status(f"Imported {model.label} from {full}; saving the file reloads it", 6000)
        return True

    def _model_opener(self, notes: list[str]):
        """The :data:`app.project.ModelOpener` of a project being opened: asks before it runs a ``.py`` file
        (``window.ask_trust``), opens the file in the app's library, and notes each material left on the
        built-in fallback and why."""
        from app.model_library import FALLBACK_MODEL

        library = self.window.model_files

        def open_model(path: Path, material: str) -> bool:
            fallback = f"material '{material}' uses the built-in model '{FALLBACK_MODEL}' instead"
            if not library.allowed(path, self.window.ask_trust):
                notes.append(f"{path}: not loaded (running a Python model file was declined): {fallback}")
                return False
            try:
                library.open(path)
            except BrdfStudioError as exc:
                notes.append(f"{exc}: {fallback}")
                return False
            return True

        return open_model

    def _tell_model_notes(self, notes: list[str]) -> None:
        if notes:
            self.window.show_error("Model files", "\n".join(dict.fromkeys(notes)))

    def load_measured(self, path: Path | str | None = None) -> bool:
        """Make the current material measured from a MERL file (a bad file shows why; nothing changes)."""
        if path is None:
            path = self.dialog_path(False, "Load measured BRDF", "Measured BRDF (*.binary *.bsdf)")
            if path is None:
                return False
        try:
            self.document.set_measured(str(Path(path).resolve()))
        except BrdfStudioError as exc:
            self.window.show_error("Cannot load the measured BRDF", str(exc))
            return False
        return True

    def open_dropped(self, paths: list[Path]) -> None:
        """Projects open, meshes import, MERL files load into the current material, model files become its
        model."""
        meshes = [p for p in paths if p.suffix.lower() in MESH_FORMATS]
        for p in paths:
            if p.suffix.lower() == ".json":
                self.open_project(p)
            elif p.suffix.lower() in (".binary", ".bsdf"):
                self.load_measured(p)
            elif p.suffix.lower() in MODEL_SUFFIXES:
                self.import_model(p)
            elif p not in meshes:
                self.window.show_error(
                    "Cannot open the file", f"'{p.name}' is not a project, mesh, MERL or model file"
                )
        if meshes:
            self.import_mesh(meshes)

    # ---- files out -----------------------------------------------------------------------------------
    def export_render(self, kind: str, path: Path | str | None = None) -> list[Path]:
        if path is None:
            filters = {
                "exr": "OpenEXR (*.exr);;PNG (*.png)",
                "composite": "PNG (*.png)",
                "errors": "CSV (*.csv)",
            }
            path = self.dialog_path(True, "Export render", filters.get(kind, "*"))
            if path is None:
                return []
            if kind == "exr" and path.suffix.lower() == ".png":
                kind = "png"
        try:
            return self.window.render_view.export(kind, path)
        except BrdfStudioError as exc:
            self.window.show_error("Export", str(exc))
            return []

    def export_samples(self, path: Path | str | None = None, n: int | None = None) -> Path | None:
        """The current material's samples for the current direction, from the sampler view's strategy."""
        from app.exports import sample_set, write_sample_set
        from app.sampling_data import ADAPTIVE_SAMPLERS

        if path is None:
            path = self.dialog_path(
                True, "Export sample set", "CSV (*.csv);;NumPy (*.npy);;PLY point cloud (*.ply)"
            )
            if path is None:
                return None
        opts = self.window.sampling_view.options()
        name = opts["ratio_sampler"]
        extra = {"n_max": opts["n_max"]} if name in ADAPTIVE_SAMPLERS.values() else {}
        try:
            rows = sample_set(
                self.document.brdf(), np.array(self.document.wo()), name, n or opts["n_samples"], 0, **extra
            )
            out = write_sample_set(path, rows)
        except BrdfStudioError as exc:
            self.window.show_error("Export", str(exc))
            return None
        self._status(f"Wrote {len(rows)} samples ({name}) to {out}", 5000)
        return out

    def export_plots(self, folder: Path | str | None = None, fmt: str = "png") -> list[Path]:
        """Polar slice, albedo curve and sampler view as ``<folder>/<material>_<plot>.<fmt>``."""
        from PySide6.QtWidgets import QFileDialog

        if folder is None:
            folder = QFileDialog.getExistingDirectory(self.window, "Export plots to folder")
            if not folder:
                return []
        stem = (self.document.current_material or "material").replace("/", "_")
        self.window.redraw.draw_hidden_views()  # the plots of the current material, whatever tab is shown
        out = []
        try:
            for label, view in (
                ("polar", self.window.polar_view),
                ("albedo", self.window.albedo_view),
                ("sampling", self.window.sampling_view),
            ):
                out.append(view.export(Path(folder) / f"{stem}_{label}.{fmt}"))
        except BrdfStudioError as exc:
            self.window.show_error("Export", str(exc))
        return out

    # ---- crash recovery ------------------------------------------------------------------------------
    def autosave(self) -> None:
        """Write unsaved edits for crash recovery (only when something changed since the last write)."""
        self.autosave_soon.stop()
        doc = self.document
        if doc.revision == self.autosaved_revision:
            return
        if not doc.dirty:
            settings.clear_autosave()
            self.autosaved_revision = doc.revision
            return
        try:
            settings.write_autosave(doc.to_dict(), doc.path)
        except (BrdfStudioError, OSError) as exc:  # retried at the next edit or tick
            self._status(f"Autosave failed: {exc}", 8000)
            return
        self.autosaved_revision = doc.revision

    def restore_autosave(self, ask: bool = True) -> bool:
        """Offer the newest autosave of a session that died; True when edits were restored. The restored
        edits are autosaved by this session before the old file is removed (a crash in between loses
        nothing); an autosave that cannot be read is set aside in the config folder, not deleted."""
        for path in settings.orphaned_autosaves():
            notes: list[str] = []
            try:
                payload = settings.read_autosave(path)
                scene = scene_from_autosave(
                    payload["document"], self.document.parts, self._model_opener(notes)
                )
            except (ValueError, KeyError, TypeError, BrdfStudioError) as exc:
                kept = settings.set_aside(path)
                self.window.show_error("Cannot restore", f"{exc} (kept as {kept})")
                continue
            finally:
                self._tell_model_notes(notes)
            when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(payload.get("time", 0)))
            if ask and not self.window.ask_restore(when):
                path.unlink(missing_ok=True)
                return False
            project = Path(payload["project"]) if payload.get("project") else None
            self.document.replace(scene, project)
            self.document.mark_unsaved()
            self.autosave()
            if self.autosaved_revision == self.document.revision:  # our own copy is on disk
                path.unlink(missing_ok=True)
            self._status(f"Restored unsaved edits from {when}", 8000)
            return True
        return False
