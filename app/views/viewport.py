"""The scene viewport: every object's mesh shaded in its material's colour, the selection highlighted,
lights drawn as outlines (quads with their emitting direction), click to select an object or a light, drag a
light's or the selected object's handle to move it (:mod:`app.views.handles`).

Its camera is the scene's camera, the one renders use: edits of the document's camera move the view, and
moving the view (a drag or the wheel) is recorded as a *Move camera* edit of the document."""

from __future__ import annotations

import math

import numpy as np
import pyvista as pv
import vtk
from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget
from pyvistaqt import QtInteractor

from app.document import Document
from app.meshes import part
from app.views.handles import DragHandles
from core.brdf import BRDF
from core.errors import BrdfStudioError
from core.scene import Camera, QuadLight, Transform

SELECTED_EDGE = "#ffb300"
LIGHT_COLOUR = "#f5e663"
SELECTED_LIGHT_COLOUR = "#ff6d00"


_STRATA = 48


def _cosine_directions(n: int = _STRATA) -> np.ndarray:
    """``n * n`` stratified cosine-weighted directions (fixed, so colours do not flicker)."""
    u = (np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2) + 0.5) / n
    r, phi = np.sqrt(u[:, 0]), 2.0 * math.pi * u[:, 1]
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - u[:, 0]))], axis=1)


_COSINE = _cosine_directions()


def display_colour(brdf: BRDF) -> tuple[float, float, float]:
    """A flat colour for a material: its directional albedo at 20 degrees (stratified cosine-weighted
    estimate, ``mean(pi f)``), clipped to [0, 1] and gamma-encoded for display."""
    wo = np.array([math.sin(math.radians(20.0)), 0.0, math.cos(math.radians(20.0))])
    rgb = np.clip(math.pi * brdf.eval(wo, _COSINE).mean(axis=0), 0.0, 1.0)
    return tuple(float(c) ** (1 / 2.2) for c in rgb)  # type: ignore[return-value]


def polydata_for(mesh: str, group: str | None, transform: Transform | None = None) -> pv.PolyData:
    parts = part(mesh, group)
    verts, faces, offset = [], [], 0
    m = np.asarray(transform.matrix()) if transform is not None else None
    for p in parts:
        v = p.vertices
        if m is not None:
            v = v @ m[:3, :3].T + m[:3, 3]
        verts.append(v)
        faces.append(p.faces + offset)
        offset += len(v)
    v = np.concatenate(verts)
    f = np.concatenate(faces)
    cells = np.hstack([np.full((len(f), 1), 3), f]).ravel()
    return pv.PolyData(v, cells)


class SceneViewport(QWidget):
    """Emits ``object_picked(name)`` (empty string: clicked on nothing)."""

    object_picked = Signal(str)

    def __init__(self, document: Document, parent: QWidget | None = None):
        super().__init__(parent)
        self.document = document
        self.plotter = QtInteractor(self)
        self.plotter.set_background("#3a3f44", top="#8a949c")
        self.status = QLabel("")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.plotter.interactor, 1)
        layout.addWidget(self.status)
        self.actors: dict[str, vtk.vtkActor] = {}
        self.meshes: dict[str, pv.PolyData] = {}
        self._light_actors: list = []
        self.light_actors: dict[int, list] = {}
        """The actors drawing each light (by index): outline or marker, and a quad's direction."""
        self._keys: dict[str, tuple] = {}
        self.plotter.add_axes()
        self._picker = vtk.vtkPropPicker()
        self._press: tuple[int, int] | None = None
        self.plotter.iren.add_observer("LeftButtonPressEvent", self._on_press)
        self.plotter.iren.add_observer("LeftButtonReleaseEvent", self._on_release)
        for event in ("MiddleButtonReleaseEvent", "RightButtonReleaseEvent"):
            self.plotter.iren.add_observer(event, self._on_drag_end)
        for event in ("MouseWheelForwardEvent", "MouseWheelBackwardEvent"):
            self.plotter.iren.add_observer(event, lambda _iren, _event: self._view_moved_later())
        self._press_any: tuple[int, int] | None = None
        for event in ("MiddleButtonPressEvent", "RightButtonPressEvent"):
            self.plotter.iren.add_observer(event, self._on_press_any)
        ev = document.events
        ev.meshes.connect(lambda _items: self.sync())
        ev.materials.connect(lambda _items: self.recolour())
        ev.lights.connect(lambda _items: self._lights_changed())
        ev.camera.connect(lambda _items: self._camera_changed())
        document.selection_changed.connect(self.highlight)
        self._camera_set = False
        self.handles = DragHandles(self)
        """Drag handles: one per light, one on the selected object."""
        self.sync()

    # ---- document -> actors ----------------------------------------------------------------------------
    def sync(self) -> None:
        """Add, remove and update actors to match the document's objects."""
        doc = self.document
        wanted = {o.name: o for o in doc.objects()}
        for name in list(self.actors):
            if name not in wanted:
                self.plotter.remove_actor(self.actors.pop(name), render=False)
                self.meshes.pop(name, None)
                self._keys.pop(name, None)
        problems = []
        for name, o in wanted.items():
            transform = o.transform
            key = (o.mesh, o.part, repr(transform), o.smooth)
            if self._keys.get(name) == key:
                continue
            if name in self.actors:
                self.plotter.remove_actor(self.actors.pop(name), render=False)
            try:
                mesh = polydata_for(o.mesh, o.part, transform)
            except BrdfStudioError as exc:
                problems.append(str(exc))
                continue
            self.meshes[name] = mesh
            self.actors[name] = self.plotter.add_mesh(
                mesh, color="white", smooth_shading=o.smooth, render=False
            )
            self._keys[name] = key
        self.recolour(render=False)
        self.highlight(render=False)  # draws the lights and places the handles
        if not self._camera_set and self.actors:
            self.apply_camera(doc.scene.camera)
        self.status.setText(
            f"{len(self.actors)} object(s)" + ("; problems: " + "; ".join(problems) if problems else "")
        )
        self.plotter.render()

    def _lights_changed(self) -> None:
        self._draw_lights()
        self.handles.sync()
        self.plotter.render()

    def _draw_lights(self) -> None:
        for a in self._light_actors:
            self.plotter.remove_actor(a, render=False)
        self._light_actors = []
        self.light_actors = {}
        selected = self.document.selected_item
        for i, light in enumerate(self.document.scene.lights):
            on = selected == ("light", i)
            colour = SELECTED_LIGHT_COLOUR if on else LIGHT_COLOUR
            actors = []
            if isinstance(light, QuadLight):
                c, e1, e2 = (np.asarray(v, dtype=float) for v in (light.corner, light.edge1, light.edge2))
                pts = np.array([c, c + e1, c + e1 + e2, c + e2, c])
                actors.append(self.plotter.add_lines(pts, color=colour, width=5 if on else 3, connected=True))
                # a short stroke from the centre along the emitting side (edge1 x edge2)
                n = np.cross(e1, e2)
                size = math.sqrt(np.linalg.norm(n))
                n = n / np.linalg.norm(n)
                centre = c + 0.5 * (e1 + e2)
                stroke = np.array([centre, centre + 0.5 * size * n])
                actors.append(self.plotter.add_lines(stroke, color=colour, width=2, connected=True))
                if light.two_sided:
                    stroke = np.array([centre, centre - 0.5 * size * n])
                    actors.append(self.plotter.add_lines(stroke, color=colour, width=2, connected=True))
            else:
                actors.append(
                    self.plotter.add_mesh(
                        pv.Sphere(radius=0.08 if on else 0.05, center=light.position),
                        color=colour,
                        render=False,
                    )
                )
            self.light_actors[i] = actors
            self._light_actors += actors

    def recolour(self, render: bool = True) -> None:
        doc = self.document
        for o in doc.objects():
            actor = self.actors.get(o.name)
            if actor is None:
                continue
            try:
                colour = display_colour(doc.brdf(o.material))
            except (BrdfStudioError, KeyError):
                colour = (1.0, 0.0, 1.0)  # a material that cannot be evaluated shows magenta
            actor.GetProperty().SetColor(*colour)
        if render:
            self.plotter.render()

    def highlight(self, render: bool = True) -> None:
        self._draw_lights()  # the selected light is drawn in another colour
        selected = self.document.selected_object
        for name, actor in self.actors.items():
            prop = actor.GetProperty()
            on = name == selected
            prop.SetEdgeVisibility(on)
            prop.SetEdgeColor(*pv.Color(SELECTED_EDGE).float_rgb)
            prop.SetLineWidth(1.5 if on else 1.0)
        self.handles.sync()
        if render:
            self.plotter.render()

    # ---- camera ----------------------------------------------------------------------------------------
    def _camera_changed(self) -> None:
        self.apply_camera(self.document.scene.camera)
        self.plotter.render()

    def apply_camera(self, camera: Camera | dict) -> None:
        """Look through ``camera`` (the scene's, or a dict of its fields)."""
        camera = camera if isinstance(camera, Camera) else Camera.model_validate(camera)
        cam = self.plotter.camera
        cam.position = tuple(camera.position)
        cam.focal_point = tuple(camera.target)
        cam.up = tuple(camera.up)
        cam.view_angle = float(camera.fov_deg)
        self._camera_set = True

    def _event_position(self) -> tuple[int, int]:
        # not the observer's caller: pyvista observes release events on the interactor style (it has no
        # event position), see pyvista issue 4976
        x, y = self.plotter.iren.interactor.GetEventPosition()
        return int(x), int(y)

    def _on_press_any(self, _caller, _event) -> None:
        self._press_any = self._event_position()

    def _on_drag_end(self, _caller, _event) -> None:
        pos = self._event_position()
        if (
            self._press_any is not None
            and abs(pos[0] - self._press_any[0]) + abs(pos[1] - self._press_any[1]) > 3
        ):
            self._view_moved_later()
        self._press_any = None

    def _view_moved_later(self) -> None:
        # observers run before the interactor style has moved the camera: look once it has
        QTimer.singleShot(0, self.view_moved)

    def view_moved(self) -> None:
        """Record the view as the scene camera (one undo step per burst of moves)."""
        try:
            self.document.set_camera(self.camera(), "Move camera", merge_key=("camera", "view"))
        except BrdfStudioError:
            pass  # a degenerate view (never from the interactor's own moves) is simply not recorded

    def camera(self) -> dict:
        """The viewport's camera in the project's terms (what a render from the viewport uses)."""
        cam = self.plotter.camera
        return {
            "position": [float(v) for v in cam.position],
            "target": [float(v) for v in cam.focal_point],
            "up": [float(v) for v in cam.up],
            "fov_deg": float(cam.view_angle),
        }

    # ---- picking -------------------------------------------------------------------------------------
    def pick_at(self, x: int, y: int) -> str:
        """The object under display coordinates ``(x, y)`` (VTK's: origin bottom-left), or ``""``."""
        self._picker.Pick(x, y, 0, self.plotter.renderer)
        actor = self._picker.GetActor()
        for name, a in self.actors.items():
            if a is actor:
                return name
        return ""

    def light_at(self, x: int, y: int) -> int | None:
        """The index of the light drawn under display coordinates ``(x, y)``, or ``None``."""
        self._picker.Pick(x, y, 0, self.plotter.renderer)
        actor = self._picker.GetActor()
        for index, actors in self.light_actors.items():
            if any(a is actor for a in actors):
                return index
        return None

    def display_point(self, world: np.ndarray) -> tuple[int, int]:
        """Display coordinates (VTK's) of a world point."""
        r = self.plotter.renderer
        r.SetWorldPoint(*world, 1.0)
        r.WorldToDisplay()
        x, y, _ = r.GetDisplayPoint()
        return int(round(x)), int(round(y))

    def _on_press(self, _caller, _event) -> None:
        self._press = self._event_position()

    def _on_release(self, _caller, _event) -> None:
        pos = self._event_position()
        if self._press is not None and abs(pos[0] - self._press[0]) + abs(pos[1] - self._press[1]) <= 3:
            light = self.light_at(*pos)  # a click, not a drag of the camera
            if light is not None:
                self.document.select_item("light", light)
            else:
                self.object_picked.emit(self.pick_at(*pos))
        elif self._press is not None:
            self._view_moved_later()
        self._press = None

    def close_view(self) -> None:
        self.handles.close()
        self.plotter.close()
