"""Every menu action of the main window, declared in one table.

An action is one :class:`ActionSpec` line: its menu, its text, its shortcut and the window method it calls
(by name, with optional arguments). :func:`install_actions` builds the menus from :data:`ACTIONS` and keeps
each ``QAction`` as an attribute of the window when the spec names one (tests and the toolbar use them).
Adding a command to the app is adding a line here (and the method it calls).
"""

from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass
from typing import Any

from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QMainWindow, QMenu

MENUS = ("&File", "&Edit", "&Render", "&View")


@dataclass(frozen=True)
class ActionSpec:
    menu: str
    """Menu path, ``"&File"`` or ``"&File/&Export"``."""
    text: str
    method: str
    """The window's method to call, or ``"module:function"``, called with the window (dialogs in their own
    modules, imported on first use)."""
    args: tuple[Any, ...] = ()
    shortcut: str | QKeySequence.StandardKey | None = None
    attribute: str | None = None
    """Keep the ``QAction`` as this attribute of the window."""
    separator_before: bool = False


ACTIONS: list[ActionSpec] = [
    ActionSpec("&File", "&New project", "new_project", shortcut=QKeySequence.StandardKey.New, attribute="new_action"),
    ActionSpec("&File", "&Open project ...", "open_project", shortcut=QKeySequence.StandardKey.Open, attribute="open_action"),
    ActionSpec("&File", "&Save", "save_project", shortcut=QKeySequence.StandardKey.Save, attribute="save_action"),
    ActionSpec("&File", "Save &as ...", "save_project_as", shortcut="Ctrl+Shift+S", attribute="save_as_action"),
    ActionSpec("&File", "&Import mesh ...", "import_mesh", shortcut="Ctrl+I", attribute="import_action", separator_before=True),
    ActionSpec("&File", "Load &MERL file ...", "load_measured", shortcut="Ctrl+L", attribute="merl_action"),
    ActionSpec("&File", "Import mo&del ...", "import_model", shortcut="Ctrl+Shift+M", attribute="import_model_action"),
    ActionSpec("&File/&Export", "&Sample set (CSV, NPY, PLY) ...", "export_samples", shortcut="Ctrl+E"),
    ActionSpec("&File/&Export", "&Plots (PNG, SVG) ...", "export_plots", shortcut="Ctrl+Shift+E"),
    ActionSpec("&File/&Export", "&Render images (EXR, PNG) ...", "export_render", ("exr",)),
    ActionSpec("&File/&Export", "Render &composite (PNG) ...", "export_render", ("composite",)),
    ActionSpec("&File/&Export", "&Error curves (CSV, PNG) ...", "export_render", ("errors",)),
    ActionSpec("&File", "&Quit", "close", shortcut=QKeySequence.StandardKey.Quit, attribute="quit_action", separator_before=True),
    ActionSpec("&Edit", "&Undo", "undo", shortcut=QKeySequence.StandardKey.Undo, attribute="undo_action"),
    ActionSpec("&Edit", "&Redo", "redo", shortcut=QKeySequence.StandardKey.Redo, attribute="redo_action"),
    ActionSpec("&Edit", "New &material", "new_material", shortcut="Ctrl+M", attribute="new_material_action", separator_before=True),
    ActionSpec("&Edit", "&Delete selected", "delete_selected", shortcut=QKeySequence.StandardKey.Delete, attribute="delete_action"),
    ActionSpec("&Edit", "&Fit model to measured material ...", "app.views.fit_dialog:open_fit_dialog", separator_before=True),
    ActionSpec("&Render", "&Render / restart", "start_render", shortcut="F5", attribute="render_action"),
    ActionSpec("&Render", "&Cancel render", "cancel_render", shortcut="Esc", attribute="cancel_render_action"),
    ActionSpec("&Render", "Make &reference", "make_reference", shortcut="Ctrl+R", attribute="reference_action", separator_before=True),
    ActionSpec("&Render", "Load reference &EXR ...", "load_reference"),
    ActionSpec("&View", "Explore", "show_tab", (0,), shortcut="Ctrl+1"),
    ActionSpec("&View", "Sampling", "show_tab", (1,), shortcut="Ctrl+2"),
    ActionSpec("&View", "Scene", "show_tab", (2,), shortcut="Ctrl+3"),
    ActionSpec("&View", "Render", "show_tab", (3,), shortcut="Ctrl+4"),
    ActionSpec("&View", "Reset &layout", "reset_layout", separator_before=True),
]  # fmt: skip


def _menu(window: QMainWindow, menus: dict[str, QMenu], path: str) -> QMenu:
    if path not in menus:
        parent, _, name = path.rpartition("/")
        holder = _menu(window, menus, parent) if parent else window.menuBar()
        menus[path] = holder.addMenu(name)
    return menus[path]


def _target(window: QMainWindow, method: str) -> Any:
    if ":" in method:
        module, _, function = method.partition(":")
        return functools.partial(getattr(importlib.import_module(module), function), window)
    return getattr(window, method)


def install_actions(window: QMainWindow, actions: list[ActionSpec] = ACTIONS) -> dict[str, QMenu]:
    """Build the menus of ``window`` from ``actions``; returns the menus by path."""
    menus: dict[str, QMenu] = {}
    for name in MENUS:
        _menu(window, menus, name)
    for spec in actions:
        menu = _menu(window, menus, spec.menu)
        if spec.separator_before:
            menu.addSeparator()
        action = QAction(spec.text, window)
        if spec.shortcut is not None:
            action.setShortcut(QKeySequence(spec.shortcut))
        method, args = spec.method, spec.args
        action.triggered.connect(lambda _checked=False, m=method, a=args: _target(window, m)(*a))
        menu.addAction(action)
        if spec.attribute:
            setattr(window, spec.attribute, action)
    return menus
