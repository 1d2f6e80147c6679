"""The render panel's error plot: RMSE and relMSE lines for both strategies, the verdict under them, and
frames that move only the lines (a handful of full figure draws per render, not one per frame)."""

from __future__ import annotations

import numpy as np
import pytest

from app.views.error_plot import ErrorPlot

pytestmark = pytest.mark.gui


@pytest.mark.parametrize("horizon", [None, 10.0])
def test_lines_follow_the_frames_with_few_full_draws(qtbot, horizon):
    plot = ErrorPlot()
    plot.horizon = horizon  # an equal-time render's length: the time axis is sized for it at once
    qtbot.addWidget(plot)
    plot.resize(760, 220)
    plot.show()
    qtbot.waitExposed(plot)
    t = np.geomspace(0.25, 10.0, 40)
    curves = {
        name: [{"seconds": x, "rmse": k / np.sqrt(x), "relmse": k * k / x, "spp": i} for i, x in enumerate(t)]
        for name, k in (("uniform", 0.2), ("adaptive_exact", 0.05))
    }
    start = plot.full_draws
    for n in range(2, len(t) + 1):
        plot.show_curves({name: recs[:n] for name, recs in curves.items()})
        plot.canvas.repaint()  # runs a pending full draw, if any
    # limits grow in steps; the other frames are blitted. Knowing the render's length, the first frame's
    # draw is the only one (RMSE falls as 1/sqrt(t), relMSE as 1/t: both within the axes set at once)
    assert plot.full_draws - start <= (5 if horizon is None else 1)
    rmse = plot._lines[("adaptive_exact", "rmse")]
    assert np.allclose(rmse.get_ydata(), [r["rmse"] for r in curves["adaptive_exact"]])
    relmse = plot._lines[("uniform", "relmse")]
    assert np.allclose(relmse.get_ydata(), [r["relmse"] for r in curves["uniform"]])
    assert plot.verdict.startswith("adaptive_exact reaches uniform's final RMSE in 1/")
    assert plot.verdict in plot.status.text()
    plot.show_curves({name: [{**r, "rmse": float("nan"), "relmse": float("nan")} for r in recs]
                      for name, recs in curves.items()})  # fmt: skip
    assert plot.verdict == "" and plot.axes.texts  # no reference: the placeholder says how to get one


def test_a_restart_of_the_same_strategies_costs_no_full_draw(qtbot):
    plot = ErrorPlot()
    qtbot.addWidget(plot)
    plot.resize(760, 220)
    plot.show()
    qtbot.waitExposed(plot)
    recs = [{"seconds": x, "rmse": 0.1 / x, "relmse": 0.01 / x, "spp": 1} for x in (0.5, 1.0, 2.0)]
    plot.show_curves({"uniform": recs, "adaptive_exact": recs})
    plot.canvas.repaint()
    draws = plot.full_draws
    plot.show_curves({"uniform": [], "adaptive_exact": []})  # Render again: no frame yet
    plot.canvas.repaint()
    assert plot.full_draws == draws and all(len(line.get_xdata()) == 0 for line in plot._lines.values())
    plot.show_curves({"uniform": recs[:1], "adaptive_exact": []})  # the first frame of one strategy
    plot.canvas.repaint()
    assert plot.full_draws == draws and len(plot._lines[("uniform", "rmse")].get_xdata()) == 1


def test_the_second_strategys_first_frame_costs_no_full_draw(qtbot):
    """Both strategies' lines are made with the first frame of either (a new line and its legend would cost a
    full draw of the figure, 100-600 ms on the GUI thread of a loaded machine, measured by
    ``bench/app_latency.py --stacks``)."""
    plot = ErrorPlot()
    qtbot.addWidget(plot)
    plot.resize(760, 220)
    plot.show()
    qtbot.waitExposed(plot)
    plot.horizon = 8.0
    recs = [{"seconds": x, "rmse": 0.1 / np.sqrt(x), "relmse": 0.01 / x, "spp": 1} for x in (0.4, 0.8, 1.6)]
    plot.show_curves({"uniform": recs[:1], "adaptive_exact": []})  # the first frame of the render: new axes
    plot.canvas.repaint()
    draws = plot.full_draws
    assert len(plot._lines) == 4 and len(plot._lines[("adaptive_exact", "rmse")].get_xdata()) == 0
    plot.show_curves({"uniform": recs[:2], "adaptive_exact": recs[:1]})
    plot.canvas.repaint()
    plot.show_curves({"uniform": recs, "adaptive_exact": recs[:2]})
    plot.canvas.repaint()
    assert plot.full_draws == draws and len(plot._lines[("adaptive_exact", "rmse")].get_xdata()) == 2
    canvas = plot.canvas.size()
    plot.show_curves(
        {"uniform": recs, "adaptive_exact": recs}
    )  # both strategies complete: the verdict appears
    plot.canvas.repaint()
    assert plot.verdict and plot.canvas.size() == canvas  # the same canvas: no full draw for a new size
    assert plot.full_draws == draws
