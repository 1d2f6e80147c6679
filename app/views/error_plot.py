"""The render panel's error plot: RMSE and relMSE against render time for each strategy, log-log, side by
side, with the equal-time verdict in words under it (:func:`app.reference.equal_time_verdict`)."""

from __future__ import annotations

import math

from matplotlib.ticker import NullFormatter
from PySide6.QtWidgets import QWidget

from app.reference import equal_time_verdict
from app.views.figure import FigureView

METRICS = (("rmse", "RMSE"), ("relmse", "relMSE"))


class ErrorPlot(FigureView):
    """``show_curves(curves)`` with ``curves`` as the render panel keeps them: strategy -> records with
    ``seconds``, ``rmse``, ``relmse``. Lines are kept and only their data change (rebuilding the axes on every
    frame cost the GUI thread up to hundreds of milliseconds under load)."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(
            parent,
            size=(7.0, 2.3),
            margins={"left": 0.09, "right": 0.98, "bottom": 0.2, "top": 0.88, "wspace": 0.28},
        )
        self.figure.clear()
        self.axes_by_metric = {m: self.figure.add_subplot(1, 2, i + 1) for i, (m, _) in enumerate(METRICS)}
        self.axes = self.axes_by_metric["rmse"]
        self._lines: dict[tuple[str, str], object] | None = None
        self.verdict = ""
        self.placeholder = "Error vs time: Render > Make reference (or load a reference EXR) to measure RMSE"
        self.show_curves({})

    def show_curves(self, curves: dict[str, list[dict]]) -> None:
        points: dict[tuple[str, str], list[tuple[float, float]]] = {}
        for name, recs in curves.items():
            for metric, _ in METRICS:
                pts = [
                    (r["seconds"], r[metric])
                    for r in recs
                    if math.isfinite(r[metric]) and r[metric] > 0 and r["seconds"] > 0
                ]
                if pts:
                    points[(name, metric)] = pts
        if not points:
            if self._lines is not None or not self.axes.texts:
                self._lines = None
                for ax in self.axes_by_metric.values():
                    ax.clear()
                    ax.set_axis_off()
                self.axes.text(0.5, 0.5, self.placeholder, ha="center", va="center", transform=self.axes.transAxes,
                               fontsize=9, wrap=True)  # fmt: skip
                self.redraw()
            self.verdict = ""
            self.status.setText("")
            return
        if self._lines is None or set(self._lines) - set(points):
            self._lines = {}
            for metric, label in METRICS:
                ax = self.axes_by_metric[metric]
                ax.clear()
                ax.set_axis_on()
                ax.set_xscale("log")
                ax.set_yscale("log")
                ax.set_xlabel("render time (s)")
                ax.xaxis.set_minor_formatter(NullFormatter())  # log minor labels crowd a short axis
                ax.set_title(label, fontsize=9)
                ax.grid(alpha=0.3, which="both")
        added = False
        for (name, metric), pts in points.items():
            t, e = zip(*pts, strict=True)
            line = self._lines.get((name, metric))
            if line is None:
                (line,) = self.axes_by_metric[metric].plot(t, e, marker="o", ms=3, label=name)
                self._lines[(name, metric)] = line
                added = True
            else:
                line.set_data(t, e)  # type: ignore[attr-defined]
        for ax in self.axes_by_metric.values():
            if added and ax.lines:
                ax.legend(fontsize=8)
            ax.relim()
            ax.autoscale_view()
        self.verdict = equal_time_verdict(curves, "rmse")
        self.status.setText(f"<b>{self.verdict}</b>" if self.verdict else "")
        self.redraw()
