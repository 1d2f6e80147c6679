"""Directional albedo against the polar angle, from the library's quadrature (``core.analysis``)."""

from __future__ import annotations

import numpy as np
from PySide6.QtWidgets import QWidget

from app.views.figure import FigureView
from core.brdf import luminance

ALBEDO_THETAS_DEG = np.array([0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0, 89.0])
"""Includes the angles the material editor quotes (0, 30, 60, 80)."""


class AlbedoView(FigureView):
    """Plots ``rho(theta)`` (RGB and luminance); the values are computed off the GUI thread."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent, fit_texts=True)
        self.thetas = np.zeros(0)
        self.values = np.zeros((0, 3))
        self._shown: str | None = None
        """The label of the plot shown (``None``: a message)."""
        self.show_message("computing ...")

    def show_message(self, text: str) -> None:
        ax = self.axes
        ax.clear()
        ax.set_axis_off()
        ax.text(0.5, 0.5, text, ha="center", va="center", wrap=True, fontsize=10, transform=ax.transAxes)
        self._shown = None
        self.status.setText(text)
        self.redraw()

    def show_albedo(self, thetas_deg: np.ndarray, values: np.ndarray, label: str = "") -> None:
        self.thetas = np.asarray(thetas_deg, dtype=np.float64)
        self.values = np.asarray(values, dtype=np.float64)
        ax = self.axes
        ax.clear()
        ax.set_axis_on()
        if self.values.shape[1] == 3:
            for k, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
                ax.plot(self.thetas, self.values[:, k], color=colour, lw=0.8, alpha=0.6)
            lum = luminance(self.values)
        else:
            lum = self.values[:, 0]
        ax.plot(self.thetas, lum, color="black", lw=1.6)
        ax.axhline(1.0, color="gray", lw=0.8, ls=":")
        ax.set_xlim(0, 90)
        ax.set_ylim(0, max(1.05, float(self.values.max()) * 1.05 if self.values.size else 1.05))
        ax.set_xlabel("theta (deg)")
        ax.set_ylabel("directional albedo")
        ax.set_title(f"albedo vs theta {label}", fontsize=9, wrap=True)
        ax.grid(alpha=0.3)
        self.status.setText(f"max albedo {float(lum.max()):.4f} (luminance)" if lum.size else "")
        if self._shown != label:  # a new title, or axes after a message: other margins (not on every edit)
            self._shown = label
            self.fit_texts()
        self.redraw()
