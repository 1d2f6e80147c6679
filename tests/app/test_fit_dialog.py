"""The "Fit…" dialog (app/views/fit_dialog.py): a fit of a model to a .bsdf file recovers its parameters,
shows the incidence-plane slices and the error map, runs in a worker thread, and adds the fitted material to
the document; the Edit menu's action opens it on the current material's measured file."""

from __future__ import annotations

import pytest

from app.document import Document
from core.model import make_brdf
from core.rgl.export import ExportOptions, tabulate
from core.rgl.material import write_bsdf
from core.scene import Material, Scene

pytestmark = pytest.mark.gui

SMALL = ExportOptions(n_theta_i=8, vndf=(32, 32), samples=(16, 16), ndf=(32, 32))
TRUTH = {"n": 40.0, "ks": (0.5, 0.4, 0.3), "kd": (0.3, 0.3, 0.4)}


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    path = tmp_path_factory.mktemp("fit") / "blinn.bsdf"
    write_bsdf(path, tabulate(make_brdf("blinn", TRUTH), SMALL))
    return path


def _document() -> Document:
    return Document(
        Scene(materials=[Material(name="white", model="lambert", params={"kd": (0.8, 0.8, 0.8)})])
    )


def _dialog(qtbot, document, path):
    from app.views.fit_dialog import FitDialog

    dialog = FitDialog(document, str(path))
    qtbot.addWidget(dialog)
    dialog.model_box.setCurrentIndex(dialog.model_box.findData("blinn"))
    dialog.starts.setValue(1)
    return dialog


def test_fit_shows_the_comparison_and_adds_a_material(qtbot, measured):
    document = _document()
    dialog = _dialog(qtbot, document, measured)
    result = dialog.fit_now()
    assert result is not None and result.params["n"] == pytest.approx(40.0, rel=0.02)
    assert len(dialog.figure.axes) == 3  # the slices, the error map and its colour bar
    lines = dialog.figure.axes[0].get_lines()
    assert len(lines) == 2 and all(len(line.get_xdata()) > 100 for line in lines)
    assert "residual" in dialog.status.text() and dialog.add_button.isEnabled()
    name = dialog.add_material()
    assert name in document.material_names()
    added = document.material(name)
    assert added.model == "blinn" and added.params["n"] == pytest.approx(40.0, rel=0.02)


def test_fit_runs_in_a_worker(qtbot, measured):
    dialog = _dialog(qtbot, _document(), measured)
    dialog.start_fit()
    assert not dialog.fit_button.isEnabled()
    qtbot.waitUntil(lambda: dialog.result is not None, timeout=300_000)
    qtbot.waitUntil(lambda: dialog.fit_button.isEnabled(), timeout=10_000)
    assert dialog.result.params["n"] == pytest.approx(40.0, rel=0.02)


def test_a_bad_file_is_reported_in_the_dialog(qtbot, tmp_path):
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(b"tensor_file")
    dialog = _dialog(qtbot, _document(), bad)
    dialog.start_fit()
    assert "truncated" in dialog.status.text() and dialog.result is None


def test_the_edit_menu_opens_it_on_the_measured_file(qtbot, measured):
    from PySide6.QtWidgets import QMainWindow

    from app.actions import install_actions

    window = QMainWindow()
    qtbot.addWidget(window)
    window.document = _document()
    window.document.set_measured(str(measured))
    menus = install_actions(window)
    action = next(a for a in menus["&Edit"].actions() if a.text().startswith("&Fit model"))
    action.trigger()
    from app.views.fit_dialog import FitDialog

    dialogs = window.findChildren(FitDialog)
    assert len(dialogs) == 1 and dialogs[0].path_edit.text() == str(measured)
    dialogs[0].close()
