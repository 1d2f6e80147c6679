"""The render panel's error plot: RMSE and relMSE against render time for each strategy, log-log, side by
side, with the equal-time verdict in words under it (:func:`app.reference.equal_time_verdict`).

While a render runs, new points only move the lines, drawn over the saved axes (blitting): the axes' limits
grow in generous steps, so a render costs a handful of full figure draws (~100 ms each on the GUI thread of a
loaded machine) instead of one per update."""

from __future__ import annotations

import math

from matplotlib.ticker import FuncFormatter, NullLocator
from PySide6.QtWidgets import QWidget

from app.reference import equal_time_verdict
from app.views.figure import FigureView

METRICS = (("rmse", "RMSE"), ("relmse", "relMSE"))
_PLAIN = FuncFormatter(lambda value, _pos: f"{value:g}")


class ErrorPlot(FigureView):
    """``show_curves(curves)`` with ``curves`` as the render panel keeps them: strategy -> records with
    ``seconds``, ``rmse``, ``relmse``. Lines are kept and only their data change (rebuilding the axes on every
    frame cost the GUI thread up to hundreds of milliseconds under load)."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(
            parent,
            size=(7.0, 2.3),
            margins={"left": 0.09, "right": 0.98, "bottom": 0.2, "top": 0.88, "wspace": 0.28},
            status_lines=2,  # the verdict's two lines, whether it is there or not: the canvas keeps its size
            fit_texts=True,
        )
        # titles, tick labels and axis labels take ~80 px: room for the curves too, however the panes are split
        self.canvas.setMinimumHeight(11 * self.fontMetrics().lineSpacing())
        self.figure.clear()
        self.axes_by_metric = {m: self.figure.add_subplot(1, 2, i + 1) for i, (m, _) in enumerate(METRICS)}
        self.axes = self.axes_by_metric["rmse"]
        self._lines: dict[tuple[str, str], object] | None = None
        self._limits_set: dict[str, bool] = {}
        self.verdict = ""
        self.horizon: float | None = None
        """The render's expected length in seconds (equal time), or ``None``: the time axis reaches past it at
        once, so the render needs no full draw for the time axis after its first frame."""
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
        wanted = {(name, metric) for name in curves for metric, _ in METRICS}
        if not points and self._lines and curves and not any(curves.values()) and set(self._lines) == wanted:
            # a render of the same strategies has started and no frame has come yet: empty the lines, keep the
            # axes (no full draw: the frames will most likely fit them)
            for line in self._lines.values():
                line.set_data([], [])  # type: ignore[attr-defined]
            self.verdict = ""
            self.status.setText("")
            self.update_artists()
            return
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
        if self._lines is None or set(self._lines) - wanted:  # other strategies: new axes
            self._lines = {}
            self._limits_set = {}
            for metric, label in METRICS:
                ax = self.axes_by_metric[metric]
                ax.clear()
                ax.set_axis_on()
                ax.set_xscale("log")
                ax.set_yscale("log")
                # Plain tick labels and no minor ticks: log axes' mathtext labels ("10^-1") and minor ticks
                # made each redraw (twice a second while rendering) cost the GUI thread 3x more.
                for axis in (ax.xaxis, ax.yaxis):
                    axis.set_major_formatter(_PLAIN)
                    axis.set_minor_locator(NullLocator())
                ax.set_xlabel("render time (s)", fontsize=8)
                ax.set_title(label, fontsize=9)
                ax.tick_params(labelsize=8)
                ax.grid(alpha=0.3)
        added = False
        # every strategy's line at once, empty until its first frame: the second strategy's first frame then
        # moves a line instead of costing another full draw (new line, legend)
        for name in curves:
            for metric, _ in METRICS:
                t, e = zip(*points[(name, metric)], strict=True) if (name, metric) in points else ((), ())
                line = self._lines.get((name, metric))
                if line is None:
                    (line,) = self.axes_by_metric[metric].plot(t, e, marker="o", ms=3, label=name)
                    self._lines[(name, metric)] = line
                    added = True
                else:
                    line.set_data(t, e)  # type: ignore[attr-defined]
        exceeded = self._limits_exceeded(points)
        stale = added or exceeded
        if added:
            for ax in self.axes_by_metric.values():
                if ax.lines:
                    ax.legend(fontsize=8, loc="upper right")  # "best" searched the data on every full draw
            self.set_animated(list(self._lines.values()))
        self.verdict = equal_time_verdict(curves, "rmse")
        self.status.setText(f"<b>{self.verdict}</b>" if self.verdict else "")
        if stale:
            self.fit_texts()  # new tick labels may need other margins
            self.redraw()  # new limits or lines: the whole figure (tens of ms)
        else:
            self.update_artists()  # the lines only, over the saved axes (a few ms)

    def _limits_exceeded(self, points: dict[tuple[str, str], list[tuple[float, float]]]) -> bool:
        """Set wider limits when a point falls outside the current ones: generous steps (x8 in time, x10 down in
        error), so that a render needs a handful of full draws instead of one per frame."""
        changed = False
        for metric, _ in METRICS:
            pts = [p for (_n, m), v in points.items() if m == metric for p in v]
            if not pts:
                continue
            ax = self.axes_by_metric[metric]
            t = [p[0] for p in pts]
            e = [p[1] for p in pts]
            (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
            if not self._limits_set.get(metric) or min(t) < x0 or max(t) > x1:
                ax.set_xlim(min(t) / 1.5, max(max(t) * 8.0, 1.3 * (self.horizon or 0.0)))
                changed = True
            if not self._limits_set.get(metric) or min(e) < y0 or max(e) > y1:
                # knowing the render's length: room for the error at its end (Monte Carlo: RMSE ~ t^-1/2,
                # relMSE ~ t^-1), so the error axis too needs no full draw half-way
                fall = (
                    min(1.0, min(t) / self.horizon) ** (1.0 if metric == "relmse" else 0.5)
                    if self.horizon
                    else 1.0
                )
                ax.set_ylim(min(e) * fall / 10.0, max(e) * 3.0)
                changed = True
            self._limits_set[metric] = True
        return changed
