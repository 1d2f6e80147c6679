"""The 3D lobe: ``f(wo, wi) cos(theta_i)`` over the hemisphere of ``wi``, radius and colour by value."""

from __future__ import annotations

import math

import numpy as np
import pyvista as pv
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QVBoxLayout, QWidget
from pyvistaqt import QtInteractor

from app.view_data import hemisphere_grid, lobe
from core.model import BRDF


class LobeView(QWidget):
    """A pyvista view of the lobe. The shape is normalized to unit size (the value range is in the colour
    bar and the caption) unless *Absolute scale* is ticked."""

    def __init__(self, parent: QWidget | None = None, n_theta: int = 40, n_phi: int = 80):
        super().__init__(parent)
        self.directions = hemisphere_grid(n_theta, n_phi)
        self.caption = QLabel("")
        self.absolute = QCheckBox("Absolute scale")
        self.absolute.setToolTip("Radius = f cos in sr^-1 instead of normalized to the lobe's maximum")
        self.plotter = QtInteractor(self)
        self.plotter.set_background("white")
        top = QHBoxLayout()
        top.addWidget(self.caption, 1)
        top.addWidget(self.absolute)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(top)
        layout.addWidget(self.plotter.interactor, 1)

        x, y, z = (self.directions[..., k] for k in range(3))
        self.mesh = pv.StructuredGrid(x.copy(), y.copy(), z.copy())
        self.mesh.point_data["f_cos"] = np.zeros(self.mesh.n_points)
        # The grid's points run with the first axis fastest (Fortran order): keep the directions so.
        self._dirs_f = np.stack([self.directions[..., k].ravel(order="F") for k in range(3)], axis=-1)
        self._actor = self.plotter.add_mesh(
            self.mesh,
            scalars="f_cos",
            cmap="viridis",
            smooth_shading=True,
            show_scalar_bar=True,
            scalar_bar_args={"title": "f cos (1/sr)", "vertical": True, "color": "black"},
        )
        circle = pv.Circle(radius=1.0, resolution=96)
        self.plotter.add_mesh(circle.extract_feature_edges(), color="gray", line_width=1)
        self._arrow = pv.Line((0, 0, 0), (0, 0, 1.2))
        self.plotter.add_mesh(self._arrow, color="red", line_width=3)
        self.plotter.add_axes(color="black")
        self.plotter.camera_position = [(2.6, -2.6, 2.2), (0, 0, 0.35), (0, 0, 1)]
        self.max_value = 0.0
        self.absolute.toggled.connect(lambda _: self._redraw_geometry())
        self._value = np.zeros(self.mesh.n_points)

    def show_lobe(self, brdf: BRDF, wo: np.ndarray) -> None:
        """Evaluate and draw the lobe of ``brdf`` for direction ``wo`` (local frame)."""
        wo = np.asarray(wo, dtype=np.float64)
        _, value = lobe(brdf, wo, self.directions)
        # StructuredGrid points are ordered with the first axis fastest (Fortran order).
        self._value = value.ravel(order="F")
        self.max_value = float(self._value.max()) if self._value.size else 0.0
        self._arrow.points = np.array([[0.0, 0.0, 0.0], 1.25 * wo])
        theta = math.degrees(math.acos(min(1.0, max(-1.0, wo[2]))))
        self.caption.setText(
            f"{brdf.model.label}   wo: theta {theta:.1f} deg   max f cos = {self.max_value:.4g} 1/sr"
        )
        self._redraw_geometry()

    def _redraw_geometry(self) -> None:
        scale = 1.0
        if not self.absolute.isChecked() and self.max_value > 0.0:
            scale = 1.0 / self.max_value
        self.mesh.points = self._dirs_f * (self._value * scale)[:, None]
        self.mesh.point_data["f_cos"] = self._value
        hi = self.max_value if self.max_value > 0.0 else 1.0
        self._actor.mapper.scalar_range = (0.0, hi)
        self.plotter.render()

    def close_view(self) -> None:
        self.plotter.close()
