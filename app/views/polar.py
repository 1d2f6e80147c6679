"""Polar plot of the incidence-plane slice of ``f cos(theta_i)``."""

from __future__ import annotations

import math

import numpy as np
from PySide6.QtWidgets import QWidget

from app.view_data import incidence_plane
from app.views.figure import FigureView
from core.model import BRDF, luminance


class PolarView(FigureView):
    """The slice in the plane of ``wo`` and the normal: the normal points up, the mirror side is right."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent, polar=True)
        self.theta = np.zeros(0)
        self.values = np.zeros((0, 3))

    def show_slice(self, brdf: BRDF, wo: np.ndarray) -> None:
        wo = np.asarray(wo, dtype=np.float64)
        self.theta, self.values = incidence_plane(brdf, wo)
        ax = self.axes
        ax.clear()
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        ax.set_thetamin(-90)
        ax.set_thetamax(90)
        for k, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
            ax.plot(self.theta, self.values[:, k], color=colour, lw=0.8, alpha=0.6)
        lum = luminance(self.values)
        ax.plot(self.theta, lum, color="black", lw=1.6, label="luminance")
        top = float(lum.max()) if lum.size and lum.max() > 0 else 1.0
        top = max(top, float(self.values.max()) if self.values.size else 0.0) or 1.0
        theta_o = math.acos(min(1.0, max(-1.0, wo[2])))
        ax.plot([-theta_o, -theta_o], [0, top], color="red", lw=1.5, ls="--", label="wo")
        ax.plot([theta_o, theta_o], [0, top], color="gray", lw=1.0, ls=":", label="mirror")
        ax.set_ylim(0, top * 1.05)
        ax.set_title("f cos(theta_i) in the incidence plane (1/sr)", fontsize=9)
        ax.legend(loc="lower left", fontsize=7, frameon=False)
        self.status.setText(f"peak {top:.4g} 1/sr")
        self.redraw()
