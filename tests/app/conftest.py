"""Fixtures for the app tests: one main window shared by the whole session (building one takes seconds)."""

from __future__ import annotations

import os

import pytest


@pytest.fixture(scope="session", autouse=True)
def _isolated_config(tmp_path_factory):
    """Recent files, autosaves and the window layout (all in app.settings.config_dir) of the tests go to a
    temporary folder, never the user's."""
    folder = tmp_path_factory.mktemp("config")
    old = os.environ.get("BRDF_STUDIO_CONFIG_DIR")
    os.environ["BRDF_STUDIO_CONFIG_DIR"] = str(folder)
    yield folder
    if old is None:
        os.environ.pop("BRDF_STUDIO_CONFIG_DIR", None)
    else:
        os.environ["BRDF_STUDIO_CONFIG_DIR"] = old


@pytest.fixture(scope="session")
def window(qapp):
    from app.main_window import MainWindow

    w = MainWindow(warm_up=False)
    w.ask_unsaved = lambda: "discard"  # no modal dialogs in tests
    w.ask_restore = lambda when: False
    w.show()
    qapp.processEvents()
    w.refresh_now()
    yield w
    w.shutdown()
    from app.workers import ABANDONED

    for worker in ABANDONED:  # let threads past the shutdown grace period end before the interpreter does
        worker.wait()
    w.close()
    w.deleteLater()
    qapp.processEvents()
