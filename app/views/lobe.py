"""The 3D lobe: ``f(wo, wi) cos(theta_i)`` over the hemisphere of ``wi``, radius and colour by value.

An edit must reach the screen fast (the target is <= 100 ms for lobe + quadtree), so the view keeps one
``vtkPolyData`` whose points, normals and scalars are overwritten in place, and never renders synchronously:
it asks the widget for a repaint, whose ``paintGL`` renders once (pyvistaqt's widget re-renders on every
paint, so an explicit ``render()`` would draw each edit twice). Anti-aliasing is off: under a software
OpenGL (llvmpipe, Xvfb) 4x MSAA made a frame ~5x slower and FXAA ~3.5x (about 70 ms against 20 ms for a
700x775 view).

The view fits its own size: whenever it is resized, the colour bar is laid out in pixels from its texts'
measured widths (the title and the labels whole, at the right edge), and the camera's view angle and window
centre are chosen so that the whole upper hemisphere of radius 1 (where a normalized lobe lies, the floor
circle included) is centred in the room left of the bar.
"""

from __future__ import annotations

import math

import numpy as np
import pyvista as pv
from PySide6.QtOpenGLWidgets import QOpenGLWidget
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QVBoxLayout, QWidget
from pyvistaqt import QtInteractor
from vtkmodules import vtkRenderingFreeType  # noqa: F401 (the text renderer measuring the bar's texts)
from vtkmodules.vtkRenderingCore import vtkTextProperty, vtkTextRenderer

from app.view_data import grid_normals, grid_quads, hemisphere_grid, lobe
from core.brdf import BRDF

BAR_TITLE = "f cos (1/sr)"
BAR_LABELS = 5
BAR_LABEL_FORMAT = "%.3g"
BAR_FONT_PT = (12, 11)
"""The colour bar's title and label sizes (points at the window's DPI: pixels at 72 DPI)."""
BAR_THICKNESS_PX = 14
MARGIN_PX = 8
"""Room kept free at the view's edges, and between the colour bar and the lobe."""


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
            scalar_bar_args={
                "title": BAR_TITLE,
                "vertical": True,
                "color": "black",
                "n_labels": BAR_LABELS,
                "fmt": BAR_LABEL_FORMAT,
                "title_font_size": BAR_FONT_PT[0],
                "label_font_size": BAR_FONT_PT[1],
            },
        )
        self.scalar_bar = self.plotter.scalar_bars[BAR_TITLE]
        self._actor.prop.interpolation = "gouraud"
        circle = pv.Circle(radius=1.0, resolution=96)
        self.plotter.add_mesh(circle.extract_feature_edges(), color="gray", line_width=1)
        self._arrow = pv.Line((0, 0, 0), (0, 0, 1.2))
        self.plotter.add_mesh(self._arrow, color="red", line_width=3)
        self.plotter.add_axes(color="black")
        self.plotter.camera_position = [(2.6, -2.6, 2.2), (0, 0, 0.35), (0, 0, 1)]
        self.fit_points = hemisphere_grid(12, 48).reshape(-1, 3)
        """What the camera keeps in view: the upper unit hemisphere (a normalized lobe and the floor circle),
        scaled to the lobe when an absolute lobe reaches beyond it."""
        self.plotter.iren.add_observer("ConfigureEvent", lambda *_: self.fit_view())  # sent on resize
        self.max_value = 0.0
        self.absolute.toggled.connect(lambda _: self._redraw_geometry(refit=True))
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

    def _redraw_geometry(self, refit: bool = False) -> None:
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
            self._place_bar()  # the labels' width may have changed
        if refit:
            self.fit_view()
        QOpenGLWidget.update(self.plotter)

    def bar_width(self) -> int:
        """The colour bar's width in pixels: its title whole, or the bar and its widest label."""
        bar = self.scalar_bar
        dpi = self.plotter.ren_win.GetDPI()
        renderer = vtkTextRenderer.GetInstance()

        def text_width(prop: vtkTextProperty, text: str) -> int:
            box = [0, 0, 0, 0]
            renderer.GetBoundingBox(prop, text, box, dpi)
            return box[1] - box[0] + 1

        lo, hi = self._actor.mapper.scalar_range
        labels = [BAR_LABEL_FORMAT % v for v in np.linspace(lo, hi, BAR_LABELS)]
        label_w = max(text_width(bar.GetLabelTextProperty(), t) for t in labels)
        pad = bar.GetTextPad()
        return max(text_width(bar.GetTitleTextProperty(), BAR_TITLE), BAR_THICKNESS_PX + label_w) + 4 * pad

    def _place_bar(self) -> int:
        """Put the colour bar at the view's right edge, as wide as its texts; returns its width in pixels."""
        w, h = self.plotter.ren_win.GetSize()
        bar = self.scalar_bar
        bar_w = self.bar_width()
        if w > 0 and h > 0:
            bar.SetBarRatio(min(0.5, BAR_THICKNESS_PX / bar_w))
            bar.SetWidth(bar_w / w)
            bar.SetHeight(0.5)
            bar.SetPosition(1.0 - (bar_w + MARGIN_PX) / w, MARGIN_PX / h)
        return bar_w

    def projected_bounds(self, points: np.ndarray) -> tuple[float, float, float, float]:
        """``(x0, y0, x1, y1)``: the bounding box of ``points`` ``(n, 3)`` on screen, in normalized device
        coordinates (-1..1 across the view), as the camera projects them."""
        w, h = self.plotter.ren_win.GetSize()
        camera = self.plotter.renderer.GetActiveCamera()
        matrix = camera.GetCompositeProjectionTransformMatrix(w / max(h, 1), -1.0, 1.0)
        m = np.array([[matrix.GetElement(i, j) for j in range(4)] for i in range(4)])
        clip = np.c_[points, np.ones(len(points))] @ m.T
        ndc = clip[:, :2] / clip[:, 3:4]
        (x0, y0), (x1, y1) = ndc.min(axis=0), ndc.max(axis=0)
        return float(x0), float(y0), float(x1), float(y1)

    def fit_view(self) -> None:
        """Lay the colour bar out at the view's right edge, and fit the lobe's hemisphere in the rest (the
        camera's direction and distance stay the user's)."""
        w, h = self.plotter.ren_win.GetSize()
        bar_w = self._place_bar()
        left, right = -1.0 + 2.0 * MARGIN_PX / max(w, 1), 1.0 - 2.0 * (bar_w + 2 * MARGIN_PX) / max(w, 1)
        bottom, top = -1.0 + 2.0 * MARGIN_PX / max(h, 1), 1.0 - 2.0 * MARGIN_PX / max(h, 1)
        if right <= left or top <= bottom:
            return  # too small to hold anything (a view being laid out)
        # The hemisphere's projection with the window centred, then the view angle and window centre that put
        # it in the room left of the bar (x and y scale as 1 / tan(view angle / 2); the centre shifts them).
        camera = self.plotter.renderer.GetActiveCamera()
        camera.SetWindowCenter(0.0, 0.0)
        radius = max(1.0, self.max_value) if self.absolute.isChecked() else 1.0
        x0, y0, x1, y1 = self.projected_bounds(radius * self.fit_points)
        s = min((right - left) / (x1 - x0), (top - bottom) / (y1 - y0))
        angle = math.radians(camera.GetViewAngle())
        camera.SetViewAngle(math.degrees(2.0 * math.atan(math.tan(angle / 2.0) / s)))
        camera.SetWindowCenter(s * (x0 + x1) / 2 - (left + right) / 2, s * (y0 + y1) / 2 - (bottom + top) / 2)
        QOpenGLWidget.update(self.plotter)

    def close_view(self) -> None:
        self.plotter.close()
