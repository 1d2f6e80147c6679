"""The app's view state beside the document: the current material, the selection, the exploration's
incident direction and the lit sphere's light. Not part of the project, not undoable, never dirty; each
change fires its event (``selection_changed``, ``direction_changed``, ``preview_light_changed``)."""

from __future__ import annotations

import math

from app.evented import Event
from core.errors import ParameterError
from core.scene import Scene


class ViewState:
    """Mixed into :class:`app.document.Document` (which provides ``scene``, ``material_names`` and
    ``object``)."""

    scene: Scene

    def __init__(self) -> None:
        self.selection_changed = Event()
        self.direction_changed = Event()
        self.preview_light_changed = Event()
        self.current_material: str | None = None
        self.selected_object: str | None = None
        self.selected_item: tuple[str, int] | None = None
        """A selected light ``("light", index)``, ``("camera", 0)`` or ``("environment", 0)``."""
        self.theta_deg = 30.0
        self.phi_deg = 0.0
        self.light_dir = (0.5, 0.5, math.sqrt(0.5))

    def wo(self) -> tuple[float, float, float]:
        """The exploration direction as a unit vector in the local frame (the API's ``wo``)."""
        t, p = math.radians(self.theta_deg), math.radians(self.phi_deg)
        z = 0.0 if self.theta_deg >= 90.0 else math.cos(t)
        return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), z)

    def select_material(self, name: str | None) -> None:
        if name is not None and name not in self.material_names():
            raise KeyError(f"no material named '{name}'")
        if name != self.current_material:
            self.current_material = name
            self.selection_changed.emit()

    def select_object(self, name: str | None) -> None:
        if name == self.selected_object and self.selected_item is None:
            return
        self.selected_object = name
        self.selected_item = None  # one selection at a time: an object, or a light/camera/environment
        if name is not None:
            self.current_material = self.object(name).material or self.current_material
        self.selection_changed.emit()

    def select_item(self, kind: str | None, index: int = 0) -> None:
        """Select a light (``"light"``, its index), the ``"camera"`` or the ``"environment"``; ``None``
        clears it. Deselects any object (the material editor keeps its current material)."""
        if kind is None:
            item = None
        elif kind == "light":
            if not 0 <= index < len(self.scene.lights):
                raise KeyError(f"no light number {index + 1}")
            item = ("light", index)
        elif kind in ("camera", "environment"):
            item = (kind, 0)
        else:
            raise KeyError(f"no scene item of kind '{kind}'")
        if item == self.selected_item and (item is None or self.selected_object is None):
            return
        self.selected_item = item
        if item is not None:
            self.selected_object = None
        self.selection_changed.emit()

    def set_direction(self, theta_deg: float, phi_deg: float) -> None:
        """Set the exploration's incident direction (degrees; theta clamped to [0, 89.9])."""
        if not (math.isfinite(theta_deg) and math.isfinite(phi_deg)):
            raise ParameterError("the incident direction needs finite angles")
        theta, phi = min(max(float(theta_deg), 0.0), 89.9), float(phi_deg) % 360.0
        if (theta, phi) != (self.theta_deg, self.phi_deg):
            self.theta_deg, self.phi_deg = theta, phi
            self.direction_changed.emit()

    def set_preview_light(self, direction: tuple[float, float, float]) -> None:
        """The lit sphere's light (view state)."""
        x, y, z = (float(c) for c in direction)
        n = math.sqrt(x * x + y * y + z * z)
        if not math.isfinite(n) or n == 0.0:
            raise ParameterError("the light direction must be a non-zero vector")
        self.light_dir = (x / n, y / n, z / n)
        self.preview_light_changed.emit()
