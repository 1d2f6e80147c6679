"""Polar plot of the incidence-plane slice of ``f cos(theta_i)``."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.ticker import MaxNLocator
from PySide6.QtWidgets import QWidget

from app.view_data import incidence_plane
from app.views.figure import FigureView
from core.model import BRDF, luminance


def nice_ceiling(x: float) -> float:
    """The smallest of 1, 1.25, 1.5, 2, 2.5, 3, 4, 5, 6, 8 times a power of ten that is >= ``x`` (> 0)."""
    e = 10.0 ** math.floor(math.log10(x))
    for m in (1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0):
        if m * e >= x * (1.0 - 1e-12):
            return m * e
    return 10.0 * e


class PolarView(FigureView):
    """The slice in the plane of ``wo`` and the normal: the normal points up, the mirror side is right.

    The curves are blitted over a saved background (axes, grid, labels); the radial limit is a round number
    kept while the peak stays between 40 % and 100 % of it, so that a slider drag redraws the whole figure
    (tens of ms) only when the scale must change."""

    LIMIT_KEEP = 0.4
    """Keep the radial limit while the peak is at least this fraction of it."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(
            parent, polar=True, margins={"left": 0.08, "right": 0.92, "bottom": 0.02, "top": 0.86}
        )
        self.theta = np.zeros(0)
        self.values = np.zeros((0, 3))
        ax = self.axes
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        ax.set_thetamin(-90)
        ax.set_thetamax(90)
        ax.tick_params(axis="y", labelsize=7)
        ax.yaxis.set_major_locator(MaxNLocator(4))
        ax.tick_params(axis="x", labelsize=8)
        self._rgb = [
            ax.plot([], [], color=c, lw=0.8, alpha=0.6)[0] for c in ("tab:red", "tab:green", "tab:blue")
        ]
        (self._lum,) = ax.plot([], [], color="black", lw=1.6, label="luminance")
        (self._wo,) = ax.plot([], [], color="red", lw=1.5, ls="--", label="wo")
        (self._mirror,) = ax.plot([], [], color="gray", lw=1.0, ls=":", label="mirror")
        ax.set_title("f cos(theta_i) in the incidence plane (1/sr)", fontsize=9)
        ax.legend(loc="upper left", bbox_to_anchor=(-0.12, 1.02), fontsize=7, frameon=False)
        self.r_max = 0.0
        self.set_animated([*self._rgb, self._lum, self._wo, self._mirror])

    def show_slice(self, brdf: BRDF, wo: np.ndarray) -> None:
        wo = np.asarray(wo, dtype=np.float64)
        self.theta, self.values = incidence_plane(brdf, wo)
        for k, line in enumerate(self._rgb):
            line.set_data(self.theta, self.values[:, k])
        lum = luminance(self.values)
        self._lum.set_data(self.theta, lum)
        top = max(
            float(self.values.max()) if self.values.size else 0.0, float(lum.max()) if lum.size else 0.0
        )
        top = top if math.isfinite(top) and top > 0 else 1.0
        rescale = not (self.LIMIT_KEEP * self.r_max <= top * 1.05 <= self.r_max)
        if rescale:
            self.r_max = nice_ceiling(top * 1.05)
            self.axes.set_ylim(0, self.r_max)
        theta_o = math.acos(min(1.0, max(-1.0, wo[2])))
        self._wo.set_data([-theta_o, -theta_o], [0, self.r_max])
        self._mirror.set_data([theta_o, theta_o], [0, self.r_max])
        self.status.setText(f"peak {top:.4g} 1/sr")
        if rescale:
            self.redraw()
        else:
            self.update_artists()
