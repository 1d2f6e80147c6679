"""Polar plot of the incidence-plane slice of ``f cos(theta_i)``."""

from __future__ import annotations

import math

import numpy as np
from PySide6.QtWidgets import QWidget

from app.view_data import incidence_plane
from app.views.figure import FigureView
from core.brdf import BRDF, luminance

RINGS = (0.25, 0.5, 0.75, 1.0)
"""The radial grid, as fractions of the radial limit."""


def nice_ceiling(x: float) -> float:
    """The smallest of 1, 2, 4, 5, 8 times a power of ten that is >= ``x`` (> 0): a limit whose quarters
    (:data:`RINGS`) are short numbers."""
    e = 10.0 ** math.floor(math.log10(x))
    for m in (1.0, 2.0, 4.0, 5.0, 8.0, 10.0):
        if m * e >= x * (1.0 - 1e-12):
            return m * e
    return 10.0 * e


def ring_label(v: float) -> str:
    return f"{v:.4g}"


class PolarView(FigureView):
    """The slice in the plane of ``wo`` and the normal: the normal points up, the mirror side is right.

    The axes always span the radius 0..1: the curves are drawn divided by a round radial limit, and the four
    ring labels are texts of their own. So a change of scale changes only the curves and the labels' strings,
    and every redraw blits them over a saved background (a few ms) instead of drawing the whole figure (ticks,
    title, legend: 35-55 ms, on the GUI thread, before the lobe could reach the screen). The limit is kept while
    the peak stays between 40 % and 100 % of it."""

    LIMIT_KEEP = 0.4
    """Keep the radial limit while the peak is at least this fraction of it."""

    LABEL_ANGLE = math.radians(75.0)
    """Where the ring labels sit (on the mirror side, near the horizon)."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(
            parent,
            polar=True,
            margins={"left": 0.08, "right": 0.92, "bottom": 0.02, "top": 0.86},
            fit_texts=True,
        )
        self.theta = np.zeros(0)
        self.values = np.zeros((0, 3))
        ax = self.axes
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        ax.set_thetamin(-90)
        ax.set_thetamax(90)
        ax.set_ylim(0.0, 1.0)
        ax.set_yticks(RINGS)
        ax.set_yticklabels([])
        ax.tick_params(axis="x", labelsize=8)
        self._rgb = [
            ax.plot([], [], color=c, lw=0.8, alpha=0.6)[0] for c in ("tab:red", "tab:green", "tab:blue")
        ]
        (self._lum,) = ax.plot([], [], color="black", lw=1.6, label="luminance")
        (self._wo,) = ax.plot([], [], color="red", lw=1.5, ls="--", label="wo")
        (self._mirror,) = ax.plot([], [], color="gray", lw=1.0, ls=":", label="mirror")
        self._labels = [
            ax.text(self.LABEL_ANGLE, r, "", fontsize=7, ha="center", va="bottom", color="dimgray")
            for r in RINGS
        ]
        ax.set_title("f cos(theta_i) in the incidence plane (1/sr)", fontsize=9, wrap=True)
        ax.legend(loc="upper left", bbox_to_anchor=(-0.12, 1.02), fontsize=7, frameon=False)
        self.r_max = 0.0
        """The radial limit (1/sr): the outer ring."""
        # The ring labels change only with the radial limit: drawn into the saved background when they do
        # (text costs ~3 ms a label to draw), not on every update.
        self.set_animated([*self._rgb, self._lum, self._wo, self._mirror], overlay=self._labels)

    def ring_labels(self) -> list[str]:
        """The labels of the rings, inner to outer (tests read them)."""
        return [t.get_text() for t in self._labels]

    def show_slice(self, brdf: BRDF, wo: np.ndarray) -> None:
        wo = np.asarray(wo, dtype=np.float64)
        self.theta, self.values = incidence_plane(brdf, wo)
        lum = luminance(self.values)
        top = max(
            float(self.values.max()) if self.values.size else 0.0, float(lum.max()) if lum.size else 0.0
        )
        top = top if math.isfinite(top) and top > 0 else 1.0
        relabel = not (self.LIMIT_KEEP * self.r_max <= top * 1.05 <= self.r_max)
        if relabel:
            self.r_max = nice_ceiling(top * 1.05)
            for text, r in zip(self._labels, RINGS, strict=True):
                text.set_text(ring_label(r * self.r_max))
        scale = 1.0 / self.r_max
        for k, line in enumerate(self._rgb):
            line.set_data(self.theta, self.values[:, k] * scale)
        self._lum.set_data(self.theta, lum * scale)
        theta_o = math.acos(min(1.0, max(-1.0, wo[2])))
        self._wo.set_data([-theta_o, -theta_o], [0.0, 1.0])
        self._mirror.set_data([theta_o, theta_o], [0.0, 1.0])
        self.status.setText(f"peak {top:.4g} 1/sr; outer ring {ring_label(self.r_max)} 1/sr")
        if relabel:
            self.update_overlay()
        else:
            self.update_artists()
