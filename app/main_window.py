"""The main window: the views and docks around one :class:`app.document.Document`.

What the window does is split by kind: menus and shortcuts are declared in :mod:`app.actions`; background
work runs through :class:`app.jobs.JobRunner`; keeping the material views current is
:class:`app.redraw.Redrawer`'s; projects and files are :class:`app.file_manager.FileManager`'s. This module
assembles them and keeps the window's own state (title, layout, errors).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtCore import QSettings, Qt, QTimer
from PySide6.QtGui import QCloseEvent
from PySide6.QtWidgets import (
    QDockWidget,
    QMainWindow,
    QMessageBox,
    QScrollArea,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from app import snapshot_process
from app.actions import install_actions
from app.document import Document
from app.editors.material import MaterialEditor
from app.editors.object_editor import ObjectEditor
from app.editors.scene_items import PropertiesStack, SceneItemEditor
from app.editors.scene_tree import SceneTree
from app.file_manager import FileManager
from app.jobs import Job, JobRunner
from app.model_library import ModelLibrary
from app.model_watcher import ModelFileWatcher
from app.redraw import Redrawer
from app.views.explore import ExplorePanel
from app.views.quadtree import SamplingView
from app.views.render import RenderPanel
from app.views.viewport import SceneViewport
from core.brdf import all_models
from core.errors import BrdfStudioError
from core.scene import Camera, ConstantEnvironment, Scene, validate_scene

APP_NAME = "BRDF Studio"
AUTOSAVE_MS = 20_000
LAYOUT_VERSION = 2
"""Bumped when the docks change, so that a stored layout of older docks is not restored."""


def demo_scene_path() -> Path:
    """The bundled demo scene."""
    from importlib.resources import files

    return Path(str(files("resources"))) / "scenes" / "demo" / "demo.json"


def _layout_settings() -> QSettings:
    """The window's layout, in the app's config folder beside recent files and autosaves (app.settings)."""
    from app.settings import config_dir

    return QSettings(str(config_dir() / "layout.ini"), QSettings.Format.IniFormat)


def _warm_up_kernels():
    """Compile every model's batch evaluation once (numba), yielding each model's label."""
    wo = np.array([[0.0, 0.0, 1.0]])
    for m in all_models():
        m.bind().eval(wo, wo)
        yield m.label


class MainWindow(QMainWindow):
    def __init__(self, document: Document | None = None, warm_up: bool = True):
        super().__init__()
        from core.model_files.shader import set_specialization

        set_specialization(
            False
        )  # the views evaluate little, and a dragged slider must not compile each step
        self.document = document if document is not None else Document()
        self.jobs = JobRunner()
        self.errors: list[str] = []
        """Every error shown to the user, in order (tests read it; dialogs never block)."""
        self.ask_unsaved = self._ask_unsaved
        """Asks Save / Discard / Cancel; replaceable (tests answer without a modal dialog)."""
        self.ask_restore = self._ask_restore
        self.ask_trust = self._ask_trust
        """Asks whether to run a Python model file a project names (``path -> bool``); replaceable."""
        self.model_files = ModelLibrary()
        """The model files opened (imports, drops, projects): each one's version in use and its problem."""
        self.resize(1400, 900)

        self.explore = ExplorePanel(self.document)
        self.lobe_view, self.polar_view = self.explore.lobe_view, self.explore.polar_view
        self.albedo_view, self.sphere_view = self.explore.albedo_view, self.explore.sphere_view
        self.direction_editor = self.explore.direction_editor
        self.sampling_view = self.sampling_panel = SamplingView()
        self.viewport = self.scene_panel = SceneViewport(self.document)
        self.viewport.object_picked.connect(lambda name: self.document.select_object(name or None))
        self.render_view = self.render_panel = RenderPanel(self.render_scene, self.jobs)
        self.render_view.error.connect(lambda msg: self.show_error("Render", msg))
        self.render_view.project_provider = lambda: self.document.path
        self.document.events.materials.connect(lambda _items: self.render_view.scene_changed())
        for name in ("meshes", "lights", "environment", "camera", "render"):
            self.document.events[name].connect(lambda _items: self.render_view.scene_changed())
        self.tabs = QTabWidget()
        for panel, title in ((self.explore, "Explore"), (self.sampling_panel, "Sampling"),
                             (self.scene_panel, "Scene"), (self.render_panel, "Render")):  # fmt: skip
            self.tabs.addTab(panel, title)
        self.setCentralWidget(self.tabs)
        self._build_docks()

        self.redraw = Redrawer(self)
        self.files = FileManager(self)
        self.model_watcher = ModelFileWatcher(self.model_files, self.jobs, self)
        self.model_files.reloaded.connect(self._model_file_reloaded)
        self.sampling_view.options_changed.connect(lambda: self.schedule("sampling"))
        self.tabs.currentChanged.connect(lambda _: self.schedule("tab"))
        self.menus = install_actions(self)
        self.recent_menu = self.menus["&File"].addMenu("Open &recent")
        self.recent_menu.aboutToShow.connect(lambda: self.files.fill_recent(self.recent_menu))
        self.setAcceptDrops(True)
        self.autosave_timer = QTimer(self)
        self.autosave_timer.setInterval(AUTOSAVE_MS)
        self.autosave_timer.timeout.connect(self.autosave)
        self.autosave_timer.start()
        self.document.history_changed.connect(self._history_changed)
        self.document.path_changed.connect(self._update_title)
        self._history_changed()
        self.statusBar().showMessage("Ready")
        self.layout_restored = self.restore_layout()
        self.schedule("brdf")
        if warm_up:
            snapshot_process.prewarm()
            self.jobs.submit("warm_up", Job(_warm_up_kernels, progress=lambda label: self.statusBar().showMessage(
                f"Compiled kernels: {label}", 1500)))  # fmt: skip

    def _build_docks(self) -> None:
        self.material_editor = MaterialEditor(self.document, library=self.model_files)
        self.material_editor.error.connect(lambda msg: self.show_error("Material", msg))
        self.material_editor.load_measured_requested.connect(lambda: self.load_measured())
        self.object_editor = ObjectEditor(self.document)
        self.object_editor.error.connect(lambda msg: self.show_error("Object", msg))
        page = QWidget()
        column = QVBoxLayout(page)
        column.setContentsMargins(0, 0, 0, 0)
        column.addWidget(self.object_editor)
        column.addWidget(self.material_editor, 1)
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(page)
        self.item_editor = SceneItemEditor(self.document, self.viewport.camera)
        self.item_editor.error.connect(lambda msg: self.show_error("Scene", msg))
        self.material_dock = QDockWidget("Material", self)
        self.material_dock.setObjectName("material_dock")
        self.material_dock.setWidget(
            PropertiesStack(self.document, scroll, self.item_editor, self.material_dock)
        )
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.material_dock)
        self.scene_tree = SceneTree(self.document)
        self.scene_tree.error.connect(lambda msg: self.show_error("Scene", msg))
        self.tree_dock = QDockWidget("Scene", self)
        self.tree_dock.setObjectName("scene_dock")
        self.tree_dock.setWidget(self.scene_tree)
        self.addDockWidget(Qt.DockWidgetArea.LeftDockWidgetArea, self.tree_dock)

    # ---- layout: sized to content on first open, then what the user left ----------------------------
    def size_docks_to_content(self) -> None:
        """Docks as wide as their content needs: every name in the scene tree readable (at most 30 % of the
        window), the editors' rows whole (at most a third)."""
        tree = min(max(200, int(0.3 * self.width())), self.scene_tree.content_width())
        editor = min(
            max(200, self.width() // 3), max(380, self.material_dock.widget().sizeHint().width() + 24)
        )
        self.resizeDocks([self.tree_dock, self.material_dock], [tree, editor], Qt.Orientation.Horizontal)

    def restore_layout(self) -> bool:
        """The layout the user left (True), or docks sized to their content once the window has its size."""
        settings = _layout_settings()
        geometry, state = settings.value("window/geometry"), settings.value("window/state")
        if (
            geometry is not None
            and state is not None
            and int(settings.value("window/version", 0)) == LAYOUT_VERSION
        ):
            self.restoreGeometry(geometry)
            self.restoreState(state, LAYOUT_VERSION)
            return True
        QTimer.singleShot(0, self.size_docks_to_content)
        return False

    def save_layout(self) -> None:
        settings = _layout_settings()
        settings.setValue("window/geometry", self.saveGeometry())
        settings.setValue("window/state", self.saveState(LAYOUT_VERSION))
        settings.setValue("window/version", LAYOUT_VERSION)

    def reset_layout(self) -> None:
        for dock, area in ((self.tree_dock, Qt.DockWidgetArea.LeftDockWidgetArea),
                           (self.material_dock, Qt.DockWidgetArea.RightDockWidgetArea)):  # fmt: skip
            dock.setFloating(False)
            self.addDockWidget(area, dock)
            dock.show()
        self.size_docks_to_content()

    def show_tab(self, index: int) -> None:
        self.tabs.setCurrentIndex(index)

    # ---- redraws and background jobs (app.redraw, app.jobs) -----------------------------------------
    def schedule(self, *kinds: str) -> None:
        self.redraw.schedule(*kinds)

    def refresh_now(self) -> None:
        self.redraw.refresh_now()

    def flush_slow_jobs(self) -> None:
        self.redraw.flush_slow_jobs()

    def jobs_idle(self, *lanes: str) -> bool:
        """No background job running or waiting in ``lanes`` (default all), the sampler view's next follow-up
        counted as one of the ``sampling`` lane's."""
        if (not lanes or "sampling" in lanes) and self.redraw.follow_up_pending:
            return False
        return self.jobs.idle(*lanes)

    @property
    def timings(self) -> dict[str, float]:
        return self.redraw.timings

    @property
    def sampling_always(self) -> bool:
        return self.redraw.sampling_always

    @sampling_always.setter
    def sampling_always(self, on: bool) -> None:
        self.redraw.sampling_always = on

    # ---- the scene a render uses ---------------------------------------------------------------------
    def render_scene(self) -> Scene:
        """The document's scene seen from the viewport's camera; a scene with no light at all gets a white
        sky so that it shows something. Files are checked (a render needs them)."""
        if not self.document.objects():
            raise BrdfStudioError("the scene has no objects: import a mesh (File > Import mesh) first")
        scene = self.document.scene.model_copy(deep=True)
        scene.camera = Camera.model_validate(self.viewport.camera())
        if not scene.lights and scene.environment is None and not any(m.emissive for m in scene.materials):
            scene.environment = ConstantEnvironment(type="constant", radiance=(1.0, 1.0, 1.0))
        base = self.document.path.parent if self.document.path else Path.cwd()
        scene.set_origin(base, self.document.path.name if self.document.path else "untitled.json")
        validate_scene(scene, check_files=True)
        return scene

    # ---- commands (the actions call these; see app.actions) --------------------------------------------
    def start(self, path: Path | None = None, empty: bool = False, restore: str = "ask") -> None:
        """Once the window is shown: offer to restore a crashed session's edits, then open ``path``, or the
        bundled demo scene unless ``empty``. ``restore`` is ``"ask"``, ``"yes"`` or ``"no"``."""
        if not self.layout_restored:
            QTimer.singleShot(0, self.size_docks_to_content)  # to the names of the project opened below
        if restore != "no" and self.files.restore_autosave(ask=restore == "ask"):
            return
        if path is not None:
            self.open_project(path, confirm=False)
        elif not empty:
            self.open_project(demo_scene_path(), confirm=False, remember=False)
            self.document.set_path(None)  # "Save" asks where: never overwrite the bundled file

    def new_project(self) -> None:
        self.files.new_project()

    def open_project(
        self, path: Path | str | None = None, confirm: bool = True, remember: bool = True
    ) -> bool:
        return self.files.open_project(path, confirm, remember)

    def save_project(self) -> bool:
        return self.files.save_project()

    def save_project_as(self, path: Path | str | None = None) -> bool:
        return self.files.save_project_as(path)

    def import_mesh(self, paths: list[Path | str] | Path | str | None = None) -> list[str]:
        return self.files.import_mesh(paths)

    def load_measured(self, path: Path | str | None = None) -> bool:
        return self.files.load_measured(path)

    def import_model(self, path: Path | str | None = None) -> bool:
        return self.files.import_model(path)

    def _model_file_reloaded(self, path: str) -> None:
        """A saved model file compiled: its materials and their views follow, and a render of them restarts."""
        self.document.model_file_reloaded(path)
        self.statusBar().showMessage(f"Reloaded {path}", 4000)
        if self.render_view.running and any(m.model == path for m in self.document.scene.materials):
            self.render_view.start()

    def autosave(self) -> None:
        self.files.autosave()

    def restore_autosave(self, ask: bool = True) -> bool:
        return self.files.restore_autosave(ask)

    def undo(self) -> None:
        self.document.undo()

    def redo(self) -> None:
        self.document.redo()

    def new_material(self) -> None:
        self.material_editor.new_material()

    def delete_selected(self) -> None:
        doc = self.document
        if doc.selected_item is not None and doc.selected_item[0] == "light":
            self.item_editor.delete_selected_light()
        elif doc.selected_object is None:
            self.statusBar().showMessage(
                "Select an object or a light (in the tree or the viewport) to delete it", 4000
            )
        else:
            try:
                doc.remove_object(doc.selected_object)
            except (BrdfStudioError, KeyError) as exc:
                self.show_error("Delete", str(exc))

    def start_render(self) -> None:
        self.tabs.setCurrentWidget(self.render_panel)
        self.render_view.start()

    def cancel_render(self) -> None:
        self.render_view.cancel()

    def make_reference(self) -> None:
        self.tabs.setCurrentWidget(self.render_panel)
        self.render_view.make_reference()

    def load_reference(self, path: Path | str | None = None) -> bool:
        if path is None:
            path = self.files.dialog_path(False, "Reference image", "OpenEXR (*.exr)")
            if path is None:
                return False
        try:
            self.render_view.load_reference(path)
        except BrdfStudioError as exc:
            self.show_error("Cannot load the reference", str(exc))
            return False
        return True

    def export_render(self, kind: str, path: Path | str | None = None) -> list[Path]:
        return self.files.export_render(kind, path)

    def export_samples(self, path: Path | str | None = None, n: int | None = None) -> Path | None:
        return self.files.export_samples(path, n)

    def export_plots(self, folder: Path | str | None = None, fmt: str = "png") -> list[Path]:
        return self.files.export_plots(folder, fmt)

    # ---- drag and drop -------------------------------------------------------------------------------
    def dragEnterEvent(self, event) -> None:  # noqa: N802
        if event.mimeData().hasUrls():
            event.acceptProposedAction()

    def dropEvent(self, event) -> None:  # noqa: N802
        self.files.open_dropped([Path(u.toLocalFile()) for u in event.mimeData().urls() if u.isLocalFile()])
        event.acceptProposedAction()

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

    def _ask_unsaved(self) -> str:
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(self, APP_NAME, "The project has unsaved changes. Save them first?",
                                      buttons.Save | buttons.Discard | buttons.Cancel, buttons.Save)  # fmt: skip
        return {buttons.Save: "save", buttons.Discard: "discard"}.get(answer, "cancel")

    def _ask_trust(self, path: str) -> bool:
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(self, APP_NAME, f"The project uses the Python model file\n{path}\n\nLoading "
                                      "it runs its code. Load it? (No: its materials use a built-in model.)",
                                      buttons.Yes | buttons.No, buttons.No)  # fmt: skip
        return answer == buttons.Yes

    def _ask_restore(self, when: str) -> bool:
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(self, APP_NAME, f"BRDF Studio did not close normally. Restore the unsaved "
                                      f"edits from {when}?", buttons.Yes | buttons.No, buttons.Yes)  # fmt: skip
        return answer == buttons.Yes

    def show_error(self, title: str, message: str) -> None:
        """Tell the user what went wrong, without blocking (the box is window-modal, opened async)."""
        self.errors.append(message)
        self.statusBar().showMessage(message, 8000)
        box = QMessageBox(QMessageBox.Icon.Warning, title, message, QMessageBox.StandardButton.Ok, self)
        box.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        box.open()
        self.last_error_box = box

    def closeEvent(self, event: QCloseEvent) -> None:  # noqa: N802
        if not self.files.maybe_save():
            event.ignore()
            return
        from app import settings

        settings.clear_autosave()
        self.save_layout()
        self.shutdown()
        super().closeEvent(event)

    def shutdown(self) -> None:
        """Stop background work and release the 3D views (safe to call twice)."""
        already = getattr(self, "_closed", False)
        self._closed = True
        self.redraw.stop()
        self.autosave_timer.stop()
        self.jobs.shutdown()
        if not already:
            self.lobe_view.close_view()
            self.viewport.close_view()
