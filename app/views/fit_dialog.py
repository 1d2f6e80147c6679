"""The "Fit…" dialog: fit an analytic model to a measured material (MERL ``.binary`` or RGL ``.bsdf``) and
look at the result — the fitted lobe beside the measured one in 3-D (two :class:`app.views.lobe.LobeView`, the
main window's lobe view, sharing one camera and the *Absolute scale* box), the two in the plane of incidence,
and the relative error over ``(theta_h, theta_d)`` — then keep the fitted parameters as a new material of the
document.

The fit (:func:`core.fit.fit`, seconds to tens of seconds) runs in a :class:`app.workers.GeneratorWorker`; the
dialog keeps no copy of the document's state: "Add as material" calls ``document.add_material``. Opened by
:func:`open_fit_dialog` (the Edit menu's action, ``app/actions.py``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
from matplotlib.figure import Figure
from PySide6.QtCore import Qt
from PySide6.QtGui import QCloseEvent
from PySide6.QtOpenGLWidgets import QOpenGLWidget
from PySide6.QtWidgets import (
    QComboBox,
    QDialog,
    QFileDialog,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QSpinBox,
    QSplitter,
    QVBoxLayout,
    QWidget,
)

from app.views.lobe import LobeView
from core.brdf import all_models
from core.errors import BrdfStudioError
from core.fit import METRICS, FitResult, error_map, fit, incidence_plane
from core.measured import load_measured

THETA_O_DEG = 30.0
"""Outgoing polar angle of the lobes and of the incidence-plane slice."""


class FitDialog(QDialog):
    """Measured file, model, metric and starts; Fit; the measured and fitted lobes, the two comparison plots;
    Add as material."""

    def __init__(self, document: Any, path: str | None = None, parent: QWidget | None = None):
        super().__init__(parent)
        self.setWindowTitle("Fit an analytic model to a measured material")
        self.document = document
        self.result: FitResult | None = None
        self._source = None
        self._worker = None
        self.path_edit = QLineEdit(path or "")
        browse = QPushButton("Browse ...")
        browse.clicked.connect(self._browse)
        self.model_box = QComboBox()
        for m in all_models():
            self.model_box.addItem(m.label, m.name)
        self.model_box.setCurrentIndex(max(0, self.model_box.findData("ggx")))
        self.metric_box = QComboBox()
        self.metric_box.addItems(list(METRICS))
        self.starts = QSpinBox()
        self.starts.setRange(1, 20)
        self.starts.setValue(3)
        self.fit_button = QPushButton("Fit")
        self.fit_button.clicked.connect(self.start_fit)
        self.add_button = QPushButton("Add as material")
        self.add_button.setEnabled(False)
        self.add_button.clicked.connect(self.add_material)
        self.status = QLabel("Choose a measured file and a model, then Fit.")
        self.status.setWordWrap(True)
        self.figure = Figure(figsize=(9.0, 3.6), dpi=90)
        self.canvas = FigureCanvasQTAgg(self.figure)
        self.measured_lobe = LobeView()
        self.fitted_lobe = LobeView()
        link_lobe_views(self.measured_lobe, self.fitted_lobe)
        lobes = QWidget()
        lobes_row = QHBoxLayout(lobes)
        lobes_row.setContentsMargins(0, 0, 0, 0)
        for title, view in (("Measured", self.measured_lobe), ("Fitted", self.fitted_lobe)):
            column = QVBoxLayout()
            column.addWidget(QLabel(f"<b>{title}</b> lobe: f cos, theta_o = {THETA_O_DEG:g} deg"))
            column.addWidget(view, 1)
            lobes_row.addLayout(column, 1)
        self.lobes = lobes
        lobes.setVisible(False)  # until there is a fit to show (an empty view draws a placeholder dome)
        self.views = QSplitter(Qt.Orientation.Vertical)
        self.views.addWidget(lobes)
        self.views.addWidget(self.canvas)

        row = QHBoxLayout()
        row.addWidget(QLabel("Measured"))
        row.addWidget(self.path_edit, 1)
        row.addWidget(browse)
        opts = QHBoxLayout()
        for label, widget in (
            ("Model", self.model_box),
            ("Metric", self.metric_box),
            ("Starts", self.starts),
        ):
            opts.addWidget(QLabel(label))
            opts.addWidget(widget)
        opts.addStretch(1)
        opts.addWidget(self.fit_button)
        opts.addWidget(self.add_button)
        layout = QVBoxLayout(self)
        layout.addLayout(row)
        layout.addLayout(opts)
        layout.addWidget(self.views, 1)
        layout.addWidget(self.status)
        self.resize(1000, 860)

    # ------------------------------------------------------------------------------------------- actions
    def _browse(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Measured BRDF", "", "Measured BRDF (*.binary *.bsdf)")
        if path:
            self.path_edit.setText(path)

    def _request(self) -> tuple[Any, str, str, int]:
        source = load_measured(self.path_edit.text().strip())
        return source, str(self.model_box.currentData()), self.metric_box.currentText(), self.starts.value()

    def start_fit(self) -> None:
        """Fit in a worker thread; the plots and the button follow when it returns."""
        from app.workers import GeneratorWorker

        try:
            source, model, metric, starts = self._request()
        except BrdfStudioError as exc:
            self.status.setText(f"Cannot read the measured file: {exc}")
            return
        self._source = source
        self.fit_button.setEnabled(False)
        self.add_button.setEnabled(False)
        self.status.setText(f"Fitting {model} ...")
        worker = GeneratorWorker(fit, source, model, metric, starts=starts)
        worker.returned.connect(self.show_result)
        worker.failed.connect(self._failed)
        worker.finished.connect(lambda: self.fit_button.setEnabled(True))
        self._worker = worker
        worker.start()

    def fit_now(self) -> FitResult | None:
        """The same fit on the calling thread (scripts and tests)."""
        try:
            source, model, metric, starts = self._request()
            self._source = source
            result = fit(source, model, metric, starts=starts)
        except BrdfStudioError as exc:
            self._failed(str(exc))
            return None
        self.show_result(result)
        return result

    def _failed(self, message: str) -> None:
        self.status.setText(f"The fit failed: {message}")

    def show_result(self, result: FitResult) -> None:
        self.result = result
        fitted = result.brdf()
        wo = lobe_direction()
        self.measured_lobe.show_lobe(self._source, wo)
        self.fitted_lobe.show_lobe(fitted, wo)
        if not self.lobes.isVisible():
            self.lobes.setVisible(True)
            self.views.setSizes([440, 330])
        self.figure.clear()
        ax1 = self.figure.add_subplot(1, 2, 1)
        t, measured = incidence_plane(self._source, THETA_O_DEG)
        _, model = incidence_plane(fitted, THETA_O_DEG)
        ax1.semilogy(t, np.maximum(measured, 1e-6), label="measured")
        ax1.semilogy(t, np.maximum(model, 1e-6), "--", label=f"{result.model} fit")
        ax1.set_xlabel("theta_i in the plane of incidence (deg)")
        ax1.set_ylabel(f"f cos (luminance), theta_o = {THETA_O_DEG:g}")
        ax1.legend(fontsize=8)
        ax2 = self.figure.add_subplot(1, 2, 2)
        th, td, err = error_map(self._source, fitted)
        lim = max(float(np.nanpercentile(np.abs(err), 99)), 1e-6) if np.isfinite(err).any() else 1.0
        im = ax2.imshow(
            err,
            origin="lower",
            extent=(th[0], th[-1], td[0], td[-1]),
            cmap="RdBu_r",
            vmin=-lim,
            vmax=lim,
            aspect="auto",
        )
        ax2.set_xlabel("theta_h (deg)")
        ax2.set_ylabel("theta_d (deg)")
        ax2.set_title("relative error (fit - measured) / measured, phi_d = 90", fontsize=8)
        self.figure.colorbar(im, ax=ax2)
        self.figure.tight_layout()
        self.canvas.draw_idle()
        values = ", ".join(f"{k}={_text(v)}" for k, v in result.params.items())
        self.status.setText(
            f"{result.model}: {values}; residual {result.residual:.3g} ({result.metric} metric), median relative "
            f"error {result.relative_error:.3g}; {result.seconds:.1f} s, {result.points} measurements"
        )
        self.add_button.setEnabled(True)

    def add_material(self) -> str | None:
        """The fitted parameters as a new material of the document; returns its name."""
        if self.result is None:
            return None
        stem = Path(self.path_edit.text().strip()).stem or "measured"
        params = {k: v for k, v in self.result.params.items()}
        name = self.document.add_material(self.result.model, f"{stem} {self.result.model} fit", params)
        self.status.setText(f"Added material '{name}'.")
        return name

    def closeEvent(self, event: QCloseEvent) -> None:  # noqa: N802 (Qt's name)
        for view in (self.measured_lobe, self.fitted_lobe):
            view.close_view()
        super().closeEvent(event)


def lobe_direction() -> np.ndarray:
    """``wo`` of the lobes: ``theta_o`` = :data:`THETA_O_DEG` in the plane of the incidence-plane slice
    (:func:`core.fit.incidence_plane` puts ``wo`` at ``phi = 180`` degrees)."""
    t = np.radians(THETA_O_DEG)
    return np.array([-np.sin(t), 0.0, np.cos(t)])


def link_lobe_views(first: LobeView, second: LobeView) -> None:
    """One camera for both views (turning or zooming either turns both) and one *Absolute scale* box."""
    second.plotter.renderer.camera = first.plotter.renderer.camera
    for source, other in ((first, second), (second, first)):
        source.plotter.iren.add_observer(
            "InteractionEvent", lambda *_, view=other: QOpenGLWidget.update(view.plotter)
        )
        source.absolute.toggled.connect(other.absolute.setChecked)


def _text(v: Any) -> str:
    if isinstance(v, tuple):
        return "(" + ", ".join(f"{x:.4g}" for x in v) + ")"
    return f"{v:.4g}"


def open_fit_dialog(window: Any) -> FitDialog:
    """Open the dialog for ``window``'s document, on the current material's measured file if it has one."""
    try:
        path = window.document.material().measured
    except (BrdfStudioError, LookupError, AttributeError):
        path = None
    dialog = FitDialog(window.document, path, parent=window)
    dialog.show()
    return dialog
