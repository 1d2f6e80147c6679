"""Drag handles in the scene viewport: a sphere per light (at a point light's position, at a quad light's
centre) and one at the centre of the selected object. Dragging a handle (left button) moves its light or
object in the document as **one undoable edit, made when the button is released**; while the mouse moves,
only the drawing follows (the light's outline or the object's actors are offset, nothing is rebuilt and no
edit is made per mouse move). A press on a light's handle also selects the light, so its page shows the new
position after the drag.

The handles are VTK's ``vtkSphereWidget`` (translation on, scaling off). A widget takes the mouse events it
handles before the interactor style and the viewport's own observers see them, so a drag of a handle is not a
camera move and records no *Move camera* step.

Decision: a drag translates only (points, quads, objects). Rotation and scale of an object stay on its
placement page; a translation is what a user reaches for in a viewport, and it needs no gizmo convention.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pyvista as pv
import vtk

from core.errors import BrdfStudioError
from core.scene import QuadLight

if TYPE_CHECKING:
    from app.views.viewport import SceneViewport

HANDLE_COLOUR = "#4fc3f7"
SELECTED_HANDLE_COLOUR = "#ff6d00"
OBJECT_HANDLE_COLOUR = "#ffb300"
HANDLE_OPACITY = 0.45
HANDLE_FRACTION = 0.02
"""A handle's radius as a fraction of the diagonal of the objects' bounds."""
MIN_RADIUS = 0.04

Key = tuple[str, int | str]
"""What a handle moves: ``("light", index)`` or ``("object", name)``."""


def light_centre(light) -> np.ndarray:
    """Where a light's handle sits: a point light's position, a quad light's centre."""
    if isinstance(light, QuadLight):
        c, e1, e2 = (np.asarray(v, dtype=float) for v in (light.corner, light.edge1, light.edge2))
        return c + 0.5 * (e1 + e2)
    return np.asarray(light.position, dtype=float)


class DragHandles:
    """The handles of one :class:`app.views.viewport.SceneViewport`. ``light_widgets[i]`` is light ``i``'s
    handle; ``object_widget`` is the selected object's (disabled while no object is selected)."""

    def __init__(self, viewport: SceneViewport) -> None:
        self.viewport = viewport
        self.light_widgets: list[vtk.vtkSphereWidget] = []
        self.object_widget = self._new_widget(("object", ""), OBJECT_HANDLE_COLOUR)
        self.object_key: Key | None = None
        self._drag: tuple[Key, np.ndarray] | None = None
        """The handle being dragged and its centre at the press."""

    # ---- widgets ---------------------------------------------------------------------------------------
    def _new_widget(self, key: Key, colour: str) -> vtk.vtkSphereWidget:
        w = vtk.vtkSphereWidget()
        w.SetInteractor(self.viewport.plotter.iren.interactor)
        w.SetDefaultRenderer(self.viewport.plotter.renderer)
        w.SetRepresentationToSurface()
        w.TranslationOn()
        w.ScaleOff()
        w.HandleVisibilityOff()
        w.SetThetaResolution(16)
        w.SetPhiResolution(10)
        for prop, c in (
            (w.GetSphereProperty(), colour),
            (w.GetSelectedSphereProperty(), SELECTED_HANDLE_COLOUR),
        ):
            prop.SetColor(*pv.Color(c).float_rgb)
            prop.SetOpacity(HANDLE_OPACITY)
        w.key = key  # type: ignore[attr-defined]
        w.AddObserver("StartInteractionEvent", lambda widget, _e: self._start(widget))
        w.AddObserver("InteractionEvent", lambda widget, _e: self._move(widget))
        w.AddObserver("EndInteractionEvent", lambda widget, _e: self._end(widget))
        return w

    def radius(self) -> float:
        """A handle's radius: a small fraction of the scene's size."""
        bounds = [m.bounds for m in self.viewport.meshes.values()]
        if not bounds:
            return 0.1
        b = np.array(bounds, dtype=float)
        lo, hi = b[:, 0::2].min(axis=0), b[:, 1::2].max(axis=0)
        return max(MIN_RADIUS, HANDLE_FRACTION * float(np.linalg.norm(hi - lo)))

    def sync(self) -> None:
        """Put the handles where the document's lights and selected object are (after any edit, undo or
        selection change). Emits nothing and makes no edit."""
        if self._drag is not None:
            return  # the drag's own end puts everything in place
        doc = self.viewport.document
        lights = doc.scene.lights
        while len(self.light_widgets) > len(lights):
            self.light_widgets.pop().Off()
        while len(self.light_widgets) < len(lights):
            self.light_widgets.append(self._new_widget(("light", len(self.light_widgets)), HANDLE_COLOUR))
        r = self.radius()
        selected = doc.selected_item
        for i, (w, light) in enumerate(zip(self.light_widgets, lights, strict=True)):
            w.SetCenter(*light_centre(light))
            w.SetRadius(r)
            colour = SELECTED_HANDLE_COLOUR if selected == ("light", i) else HANDLE_COLOUR
            w.GetSphereProperty().SetColor(*pv.Color(colour).float_rgb)
            if not w.GetEnabled():
                w.On()
        name = doc.selected_object
        mesh = self.viewport.meshes.get(name) if name is not None else None
        if mesh is None:
            self.object_key = None
            if self.object_widget.GetEnabled():
                self.object_widget.Off()
            return
        self.object_key = ("object", name)
        self.object_widget.key = self.object_key  # type: ignore[attr-defined]
        self.object_widget.SetCenter(*mesh.center)
        self.object_widget.SetRadius(1.5 * r)
        if not self.object_widget.GetEnabled():
            self.object_widget.On()

    def widget_for(self, key: Key) -> vtk.vtkSphereWidget | None:
        if key[0] == "light":
            i = int(key[1])
            return self.light_widgets[i] if 0 <= i < len(self.light_widgets) else None
        return self.object_widget if self.object_key == key else None

    def close(self) -> None:
        for w in [*self.light_widgets, self.object_widget]:
            w.Off()
            w.SetInteractor(None)
        self.light_widgets = []

    # ---- a drag ----------------------------------------------------------------------------------------
    def _actors(self, key: Key) -> list:
        """The actors that follow a drag of ``key``: the light's drawing, or every object of the mesh entry
        (the groups of one file share its transform)."""
        vp = self.viewport
        if key[0] == "light":
            return list(vp.light_actors.get(int(key[1]), []))
        index = vp.document.object(str(key[1])).mesh_index
        return [
            vp.actors[o.name] for o in vp.document.objects() if o.mesh_index == index and o.name in vp.actors
        ]

    def _start(self, widget: vtk.vtkSphereWidget) -> None:
        key = widget.key
        if key[0] == "light":
            self.viewport.document.select_item("light", int(key[1]))  # its page shows what the drag does
        self._drag = (key, np.array(widget.GetCenter(), dtype=float))

    def _move(self, widget: vtk.vtkSphereWidget) -> None:
        if self._drag is None:
            return
        key, start = self._drag
        delta = np.array(widget.GetCenter(), dtype=float) - start
        for actor in self._actors(key):
            actor.SetPosition(*delta)

    def _end(self, widget: vtk.vtkSphereWidget) -> None:
        if self._drag is None:
            return
        key, start = self._drag
        delta = np.array(widget.GetCenter(), dtype=float) - start
        for actor in self._actors(key):
            actor.SetPosition(0.0, 0.0, 0.0)
        self._drag = None
        if float(np.abs(delta).max()) > 0.0:
            self.commit(key, delta)
        self.sync()
        self.viewport.plotter.render()

    def commit(self, key: Key, delta: np.ndarray) -> None:
        """Move the light or object ``key`` by ``delta`` (world units) as one undo step of its own. A move
        the schema refuses (beyond the scene's coordinate limit) changes nothing and says why in the status
        line."""
        doc = self.viewport.document
        try:
            doc.end_merge()  # a drag is a step of its own, never merged into the previous edit
            if key[0] == "light":
                i = int(key[1])
                light = doc.scene.lights[i]
                field = "corner" if isinstance(light, QuadLight) else "position"
                value = tuple(float(v) for v in np.asarray(getattr(light, field)) + delta)
                doc.set_field(("lights", i, field), value, f"Drag light {i + 1}")
            else:
                obj = doc.object(str(key[1]))
                value = tuple(float(v) for v in np.asarray(obj.transform.translate) + delta)
                doc.set_field(("meshes", obj.mesh_index, "transform", "translate"), value, f"Drag {obj.name}")
            doc.end_merge()
        except (BrdfStudioError, KeyError) as exc:
            self.viewport.status.setText(f"not moved: {str(exc).strip(chr(39))}")
