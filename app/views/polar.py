"""Polar plot of the incidence-plane slice of ``f cos(theta_i)``."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.ticker import MaxNLocator
from PySide6.QtWidgets import QWidget

from app.view_data import incidence_plane
from app.views.figure import FigureView
from core.model import BRDF, luminance


class PolarView(FigureView):
    """The slice in the plane of ``wo`` and the normal: the normal points up, the mirror side is right.
    The artists are made once and updated (a redraw during a slider drag stays cheap)."""

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
        top = top if top > 0 else 1.0
        theta_o = math.acos(min(1.0, max(-1.0, wo[2])))
        self._wo.set_data([-theta_o, -theta_o], [0, top])
        self._mirror.set_data([theta_o, theta_o], [0, top])
        self.axes.set_ylim(0, top * 1.05)
        self.status.setText(f"peak {top:.4g} 1/sr")
        self.redraw()
