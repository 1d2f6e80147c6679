"""The 3D lobe: ``f(wo, wi) cos(theta_i)`` over the hemisphere of ``wi``, radius and colour by value.

An edit must reach the screen fast (the target is <= 100 ms for lobe + quadtree), so the view keeps one
``vtkPolyData`` whose points, normals and scalars are overwritten in place, and never renders synchronously:
it asks the widget for a repaint, whose ``paintGL`` renders once (pyvistaqt's widget re-renders on every
paint, so an explicit ``render()`` would draw each edit twice). Anti-aliasing is off: under a software
OpenGL (llvmpipe, Xvfb) 4x MSAA made a frame ~5x slower and FXAA ~3.5x (about 70 ms against 20 ms for a
700x775 view).
"""

from __future__ import annotations

import math

import numpy as np
import pyvista as pv
from PySide6.QtOpenGLWidgets import QOpenGLWidget
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QVBoxLayout, QWidget
from pyvistaqt import QtInteractor

from app.view_data import grid_normals, grid_quads, hemisphere_grid, lobe
from core.model import BRDF


class LobeView(QWidget):
    """A pyvista view of the lobe. The shape is normalized to unit size (the value range is in the colour
    bar and the caption) unless *Absolute scale* is ticked."""

    def __init__(self, parent: QWidget | None = None, n_theta: int = 40, n_phi: int = 80):
        super().__init__(parent)
        self.directions = hemisphere_grid(n_theta, n_phi)
        self.caption = QLabel("")
        self.caption.setWordWrap(True)  # a long model name wraps instead of widening the Explore tab
        self.absolute = QCheckBox("Absolute scale")
        self.absolute.setToolTip("Radius = f cos in sr^-1 instead of normalized to the lobe's maximum")
        # auto_update=False: no 5 Hz re-render timer (each frame costs the GUI thread tens of ms in software
        # GL); the view repaints when its data or the camera changes.
        self.plotter = QtInteractor(self, auto_update=False, multi_samples=0)
        self.plotter.ren_win.SetMultiSamples(0)
        self.plotter.set_background("white")
        top = QHBoxLayout()
        top.addWidget(self.caption, 1)
        top.addWidget(self.absolute)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(top)
        layout.addWidget(self.plotter.interactor, 1)

        self._dirs = np.ascontiguousarray(self.directions.reshape(-1, 3))
        self.mesh = pv.PolyData(self._dirs.copy(), grid_quads(*self.directions.shape[:2]))
        self.mesh.point_data["f_cos"] = np.zeros(self.mesh.n_points)
        self.mesh.point_data["Normals"] = self._dirs.copy()
        self.mesh.point_data.active_normals_name = "Normals"
        # Our own normals (one numpy pass per edit) instead of pyvista's smooth shading, which re-runs a
        # surface extraction and a normals filter in Python on every render.
        self._actor = self.plotter.add_mesh(
            self.mesh,
            scalars="f_cos",
            cmap="viridis",
            show_scalar_bar=True,
            scalar_bar_args={"title": "f cos (1/sr)", "vertical": True, "color": "black"},
        )
        self._actor.prop.interpolation = "gouraud"
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
        """Evaluate the lobe of ``brdf`` for direction ``wo`` (local frame) and schedule its drawing."""
        wo = np.asarray(wo, dtype=np.float64)
        _, value = lobe(brdf, wo, self.directions)
        self._value = value.reshape(-1)
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
        points = (self._dirs * (self._value * scale)[:, None]).reshape(self.directions.shape)
        # In place: the VTK arrays keep their identity, the mapper only re-uploads them.
        self.mesh.points[:] = points.reshape(-1, 3)
        self.mesh.point_data["Normals"][:] = grid_normals(points, self.directions).reshape(-1, 3)
        self.mesh.point_data["f_cos"][:] = self._value
        for array in (
            self.mesh.GetPoints(),
            *(self.mesh.GetPointData().GetArray(k) for k in ("Normals", "f_cos")),
        ):
            array.Modified()
        hi = self.max_value if self.max_value > 0.0 else 1.0
        if tuple(self._actor.mapper.scalar_range) != (0.0, hi):
            self._actor.mapper.scalar_range = (0.0, hi)
        QOpenGLWidget.update(self.plotter)

    def close_view(self) -> None:
        self.plotter.close()
