"""The document the desktop app edits: materials, scene objects, lights, camera, environment, selection and
the undo history.

Plain Python with no Qt import (napari's split): widgets receive a :class:`Document`, connect to its
events and write back through its methods; they keep no copy of the state. Every edit goes through
:meth:`Document.edit`, which snapshots the (small) document data first, so every edit can be undone.
Meshes are referenced by path; their triangles live in the views, not here. Lights, the camera and the
environment are kept in the scene file's own form (``core.scene`` dicts in ``extras``) and every edit of
them is validated by that schema before it is applied.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from core.errors import ParameterError
from core.model import BRDF, ParamValue, get_model
from core.scene import Camera, SceneError, parse_camera, parse_environment, parse_light


class Event:
    """A minimal event: callbacks connected to it are called in order by :meth:`emit`."""

    def __init__(self) -> None:
        self._callbacks: list[Callable[..., Any]] = []

    def connect(self, callback: Callable[..., Any]) -> Callable[..., Any]:
        self._callbacks.append(callback)
        return callback

    def disconnect(self, callback: Callable[..., Any]) -> None:
        if callback in self._callbacks:
            self._callbacks.remove(callback)

    def emit(self, *args: Any) -> None:
        for callback in list(self._callbacks):
            callback(*args)


@dataclass
class Material:
    """A named material: a model with parameter values, or a measured (MERL) file."""

    name: str
    model: str
    params: dict[str, ParamValue] = field(default_factory=dict)
    measured: str | None = None
    """Path of a MERL ``.binary`` file when the material is measured (then ``model`` names the reader)."""
    notes: str = ""
    tags: list[str] = field(default_factory=list)


@dataclass
class SceneObject:
    """One mesh (or one part of a multi-part mesh file) with its material."""

    name: str
    mesh: str
    """Path of the mesh file (absolute while the project is unsaved)."""
    part: str | None = None
    """Geometry name inside a multi-part file (``None``: the whole file)."""
    material: str = ""
    visible: bool = True
    transform: dict[str, Any] | None = None
    """The project's transform of the mesh (``core.scene.Transform`` fields), ``None`` for identity."""
    smooth: bool = False
    entry: str = ""
    """Objects that are parts of one file share the project's mesh entry of this name."""


@dataclass
class DocumentData:
    """Everything an undo step restores."""

    materials: list[Material] = field(default_factory=list)
    objects: list[SceneObject] = field(default_factory=list)
    extras: dict[str, Any] = field(default_factory=dict)
    """Project parts in the scene file's form: ``lights`` (list), ``camera``, ``environment`` (edited through
    the document's methods), ``render`` settings and ``name`` (kept as loaded and written back)."""
    excluded_parts: list[SceneObject] = field(default_factory=list)
    """Parts of multi-part mesh files that were deleted: saved as the mesh entry's ``exclude_groups``."""


@dataclass
class _Step:
    label: str
    before: DocumentData
    after: DocumentData
    merge_key: Any = None
    stamp: float = 0.0


class Events:
    """The document's events. Arguments are given in each comment."""

    def __init__(self) -> None:
        self.material_changed = Event()  # (name): model, parameters, notes or tags of one material
        self.materials_changed = Event()  # (): a material added, removed or renamed
        self.objects_changed = Event()  # (): an object added, removed, or its material assigned
        self.selection_changed = Event()  # (): current material or selected object
        self.direction_changed = Event()  # (): the exploration's incident direction
        self.light_changed = Event()  # (): the lit-sphere preview's light direction
        self.history_changed = Event()  # (): undo/redo availability or the dirty flag
        self.lights_changed = Event()  # (): a light added, removed or edited, or the environment edited
        self.camera_changed = Event()  # (): the scene camera edited
        self.path_changed = Event()  # (): the project file


MERGE_SECONDS = 1.0
"""Edits of the same value within this time merge into one undo step (a slider drag is one step)."""


class Document:
    """The edited project. Selection and exploration directions are view state: not undoable, not dirty."""

    def __init__(self, data: DocumentData | None = None, path: Path | None = None):
        self.events = Events()
        self.data = data if data is not None else DocumentData()
        self.path = path
        self._undo: list[_Step] = []
        self._redo: list[_Step] = []
        self._clean_index: int | None = 0
        self._brdf_cache: dict[str, tuple[Any, BRDF]] = {}
        self.current_material: str | None = self.data.materials[0].name if self.data.materials else None
        self.selected_object: str | None = None
        self.selected_item: tuple[str, int] | None = None
        """A selected light ``("light", index)``, ``("camera", 0)`` or ``("environment", 0)`` (exclusive with
        ``selected_object``)."""
        self.theta_deg = 30.0
        self.phi_deg = 0.0
        self.light_dir = (0.5, 0.5, math.sqrt(0.5))
        self.revision = 0
        """Increases with every change of the document data (autosave compares it)."""

    # ---- queries -------------------------------------------------------------------------------
    @property
    def dirty(self) -> bool:
        return self._clean_index != len(self._undo)

    def material(self, name: str | None = None) -> Material:
        name = self.current_material if name is None else name
        for m in self.data.materials:
            if m.name == name:
                return m
        raise KeyError(f"no material named '{name}'")

    def material_names(self) -> list[str]:
        return [m.name for m in self.data.materials]

    def object(self, name: str) -> SceneObject:
        for o in self.data.objects:
            if o.name == name:
                return o
        raise KeyError(f"no object named '{name}'")

    def brdf(self, name: str | None = None) -> BRDF:
        """The bound BRDF of a material (cached until the material changes)."""
        mat = self.material(name)
        key = (mat.model, mat.measured, tuple(sorted(mat.params.items())))
        hit = self._brdf_cache.get(mat.name)
        if hit is not None and hit[0] == key:
            return hit[1]
        if mat.measured:
            from app.capabilities import load_measured

            brdf = load_measured(mat.measured)
        else:
            brdf = get_model(mat.model).bind(mat.params)
        self._brdf_cache[mat.name] = (key, brdf)
        return brdf

    def wo(self) -> tuple[float, float, float]:
        """The exploration direction as a unit vector in the local frame (the API's ``wo``)."""
        t, p = math.radians(self.theta_deg), math.radians(self.phi_deg)
        z = 0.0 if self.theta_deg >= 90.0 else math.cos(t)
        return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), z)

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    def undo_text(self) -> str:
        return self._undo[-1].label if self._undo else ""

    def redo_text(self) -> str:
        return self._redo[-1].label if self._redo else ""

    # ---- the one way to change the data --------------------------------------------------------
    def edit(self, label: str, change: Callable[[DocumentData], None], merge_key: Any = None) -> None:
        """Apply ``change`` to the data as one undoable step (merged with the previous step when both
        carry the same ``merge_key`` and follow each other within :data:`MERGE_SECONDS`)."""
        before = copy.deepcopy(self.data)
        change(self.data)
        now = time.monotonic()
        top = self._undo[-1] if self._undo else None
        mergeable = (
            merge_key is not None
            and top is not None
            and not self._redo
            and top.merge_key == merge_key
            and now - top.stamp < MERGE_SECONDS
            and self._clean_index != len(self._undo)
        )
        if mergeable:
            top.after = copy.deepcopy(self.data)
            top.stamp = now
        else:
            if self._redo and self._clean_index is not None and self._clean_index > len(self._undo):
                self._clean_index = None  # the saved state was in the redo branch being discarded
            self._undo.append(_Step(label, before, copy.deepcopy(self.data), merge_key, now))
        self._redo.clear()
        self.revision += 1
        self.events.history_changed.emit()

    def end_merge(self) -> None:
        """Stop merging into the last step (e.g. when a slider is released)."""
        if self._undo:
            self._undo[-1].merge_key = None

    def undo(self) -> None:
        if not self._undo:
            return
        step = self._undo.pop()
        self._redo.append(step)
        self._restore(step.before)

    def redo(self) -> None:
        if not self._redo:
            return
        step = self._redo.pop()
        self._undo.append(step)
        self._restore(step.after)

    def _restore(self, data: DocumentData) -> None:
        self.data = copy.deepcopy(data)
        self.revision += 1
        names = self.material_names()
        if self.current_material not in names:
            self.current_material = names[0] if names else None
        if self.selected_object is not None and self.selected_object not in [
            o.name for o in self.data.objects
        ]:
            self.selected_object = None
        self._check_selected_item()
        self.events.materials_changed.emit()
        self.events.objects_changed.emit()
        for name in names:
            self.events.material_changed.emit(name)
        self.events.lights_changed.emit()
        self.events.camera_changed.emit()
        self.events.selection_changed.emit()
        self.events.history_changed.emit()

    def _check_selected_item(self) -> None:
        if self.selected_item is not None and self.selected_item[0] == "light":
            if self.selected_item[1] >= len(self.lights()):
                self.selected_item = None

    def mark_unsaved(self) -> None:
        """Mark the document as differing from any saved file (restored edits)."""
        self._clean_index = None
        self.events.history_changed.emit()

    def mark_clean(self) -> None:
        self._clean_index = len(self._undo)
        self.events.history_changed.emit()

    def set_path(self, path: Path | None) -> None:
        self.path = path
        self.events.path_changed.emit()

    # ---- material edits ------------------------------------------------------------------------
    def set_param(self, name: str, value: Any, material: str | None = None) -> None:
        """Set one parameter (validated against the model's bounds; raises :class:`ParameterError`)."""
        mat = self.material(material)
        if mat.measured:
            raise ParameterError(f"material '{mat.name}' is measured: it has no parameters to edit")
        value = get_model(mat.model).param(name).validate(mat.model, value)
        if mat.params.get(name) == value:
            return
        mname = mat.name

        def change(d: DocumentData) -> None:
            _find(d.materials, mname).params[name] = value

        self.edit(f"Set {name}", change, merge_key=("param", mname, name))
        self.events.material_changed.emit(mname)

    def set_model(self, model: str, material: str | None = None) -> None:
        """Switch a material to another model, with that model's default parameters."""
        m = get_model(model)
        mat = self.material(material)
        if mat.model == model and not mat.measured:
            return
        mname = mat.name

        def change(d: DocumentData) -> None:
            target = _find(d.materials, mname)
            target.model = model
            target.measured = None
            target.params = dict(m.defaults())

        self.edit(f"Switch to {m.label}", change)
        self.events.material_changed.emit(mname)

    def set_measured(self, path: str, material: str | None = None) -> None:
        """Make a material measured from a MERL file (read now, so a bad file raises before any edit)."""
        from app.capabilities import MEASURED_MODEL, load_measured

        load_measured(path)
        mname = self.material(material).name

        def change(d: DocumentData) -> None:
            target = _find(d.materials, mname)
            target.model = MEASURED_MODEL
            target.measured = str(path)
            target.params = {}

        self.edit(f"Load measured {Path(path).name}", change)
        self.events.material_changed.emit(mname)

    def set_notes(self, notes: str, material: str | None = None) -> None:
        mname = self.material(material).name
        if self.material(mname).notes == notes:
            return
        self.edit(
            "Edit notes", lambda d: setattr(_find(d.materials, mname), "notes", notes), ("notes", mname)
        )
        self.events.material_changed.emit(mname)

    def set_tags(self, tags: Iterable[str], material: str | None = None) -> None:
        clean = [t.strip() for t in tags if t.strip()]
        mname = self.material(material).name
        if self.material(mname).tags == clean:
            return
        self.edit("Edit tags", lambda d: setattr(_find(d.materials, mname), "tags", clean), ("tags", mname))
        self.events.material_changed.emit(mname)

    def add_material(
        self, model: str = "lambert", name: str | None = None, params: Mapping[str, Any] | None = None
    ) -> str:
        m = get_model(model)
        values = m.resolve(params)
        new = Material(unique_name(name or m.name, self.material_names()), model, dict(values))
        self.edit(f"New material {new.name}", lambda d: d.materials.append(copy.deepcopy(new)))
        self.current_material = new.name
        self.events.materials_changed.emit()
        self.events.selection_changed.emit()
        return new.name

    def rename_material(self, old: str, new: str) -> str:
        new = new.strip()
        if not new:
            raise ParameterError("a material name cannot be empty")
        if new == old:
            return old
        if new in self.material_names():
            raise ParameterError(f"a material named '{new}' exists already")

        def change(d: DocumentData) -> None:
            _find(d.materials, old).name = new
            for o in d.objects:
                if o.material == old:
                    o.material = new

        self.edit(f"Rename {old}", change)
        if self.current_material == old:
            self.current_material = new
        self.events.materials_changed.emit()
        self.events.objects_changed.emit()
        self.events.selection_changed.emit()
        return new

    def remove_material(self, name: str) -> None:
        if any(o.material == name for o in self.data.objects):
            raise ParameterError(f"material '{name}' is assigned to objects; assign another material first")

        def change(d: DocumentData) -> None:
            d.materials.remove(_find(d.materials, name))

        self.edit(f"Delete material {name}", change)
        if self.current_material == name:
            self.current_material = self.data.materials[0].name if self.data.materials else None
        self.events.materials_changed.emit()
        self.events.selection_changed.emit()

    # ---- object edits --------------------------------------------------------------------------
    def add_objects(self, objects: Iterable[SceneObject], label: str = "Import mesh") -> list[str]:
        """Add objects (names made unique; a missing material becomes the current one)."""
        taken = [o.name for o in self.data.objects]
        new = []
        for o in objects:
            o = copy.deepcopy(o)
            o.name = unique_name(o.name, taken)
            taken.append(o.name)
            if o.material not in self.material_names():
                o.material = self.current_material or ""
            new.append(o)
        if not new:
            return []
        self.edit(label, lambda d: d.objects.extend(copy.deepcopy(new)))
        self.events.objects_changed.emit()
        return [o.name for o in new]

    def remove_object(self, name: str) -> None:
        """Remove an object; a part of a multi-part file is remembered as excluded (the project file's
        ``exclude_groups``) so that it stays deleted when the project is saved and opened again."""

        def change(d: DocumentData) -> None:
            obj = _find(d.objects, name)
            d.objects.remove(obj)
            if obj.part is not None:
                d.excluded_parts.append(obj)

        self.edit(f"Delete {name}", change)
        if self.selected_object == name:
            self.selected_object = None
            self.events.selection_changed.emit()
        self.events.objects_changed.emit()

    def assign_material(self, obj: str, material: str) -> None:
        if material not in self.material_names():
            raise ParameterError(f"no material named '{material}'")
        if self.object(obj).material == material:
            return
        self.edit(
            f"Assign {material} to {obj}", lambda d: setattr(_find(d.objects, obj), "material", material)
        )
        self.events.objects_changed.emit()

    # ---- lights, camera, environment (validated by the scene schema) -----------------------------
    def lights(self) -> list[dict[str, Any]]:
        """The lights in the scene file's form (do not modify: edit through the methods below)."""
        return list(self.data.extras.get("lights") or [])

    def camera(self) -> dict[str, Any]:
        """The scene camera in the scene file's form (the schema's defaults when the project has none)."""
        cam = self.data.extras.get("camera")
        return copy.deepcopy(cam) if cam else Camera().model_dump(mode="json")

    def environment(self) -> dict[str, Any] | None:
        env = self.data.extras.get("environment")
        return copy.deepcopy(env) if env else None

    def add_light(self, kind: str = "point", values: Mapping[str, Any] | None = None) -> int:
        """Add a light of ``kind`` (``"point"`` or ``"quad"``) with default values (overridden by
        ``values``); selects it and returns its index."""
        if kind not in NEW_LIGHTS:
            raise ParameterError(f"unknown light type '{kind}'; known types: {', '.join(NEW_LIGHTS)}")
        index = len(self.lights())
        light = _checked(parse_light, {**NEW_LIGHTS[kind], **(values or {})}, f"lights[{index}]")

        def change(d: DocumentData) -> None:
            d.extras["lights"] = [*(d.extras.get("lights") or []), light]

        self.edit(f"Add {kind} light", change)
        self.events.lights_changed.emit()
        self.select_item("light", index)
        return index

    def remove_light(self, index: int) -> None:
        lights = self.lights()
        if not 0 <= index < len(lights):
            raise KeyError(f"no light number {index + 1}")

        def change(d: DocumentData) -> None:
            d.extras["lights"] = [x for i, x in enumerate(d.extras.get("lights") or []) if i != index]

        self.edit(f"Delete {lights[index].get('type', '')} light {index + 1}", change)
        selected = self.selected_item
        if selected is not None and selected[0] == "light" and selected[1] >= index:
            self.selected_item = None if selected[1] == index else ("light", selected[1] - 1)
        self.events.lights_changed.emit()
        self.events.selection_changed.emit()

    def set_light_field(self, index: int, name: str, value: Any) -> None:
        """Set one field of a light (validated: :class:`ParameterError` with the reason, nothing changed)."""
        lights = self.lights()
        if not 0 <= index < len(lights):
            raise KeyError(f"no light number {index + 1}")
        if name == "type":
            raise ParameterError("a light's type cannot change: add a light of the other type")
        new = _checked(parse_light, {**lights[index], name: _plain(value)}, f"lights[{index}]")
        if new == lights[index]:
            return

        def change(d: DocumentData) -> None:
            d.extras["lights"][index] = new

        self.edit(f"Set light {index + 1} {name}", change, merge_key=("light", index, name))
        self.events.lights_changed.emit()

    def set_camera_field(self, name: str, value: Any) -> None:
        """Set one field of the camera (``position``, ``target``, ``up``, ``fov_deg``), validated."""
        self.set_camera({**self.camera(), name: _plain(value)}, f"Set camera {name}", ("camera", name))

    def set_camera(
        self, camera: Mapping[str, Any], label: str = "Move camera", merge_key: Any = None
    ) -> None:
        """Replace the camera (validated; an unchanged camera is no edit)."""
        new = _checked(parse_camera, dict(camera), "camera")
        if new == self.data.extras.get("camera"):
            return
        self.edit(label, lambda d: d.extras.__setitem__("camera", new), merge_key)
        self.events.camera_changed.emit()

    def set_environment(self, environment: Mapping[str, Any] | None, label: str = "Set environment") -> None:
        """Replace the environment (``None`` removes it); a map's path must name an existing EXR file."""
        new = None if environment is None else _checked(parse_environment, dict(environment), "environment")
        if new == self.data.extras.get("environment"):
            return

        def change(d: DocumentData) -> None:
            if new is None:
                d.extras.pop("environment", None)
            else:
                d.extras["environment"] = new

        self.edit(label, change)
        self.events.lights_changed.emit()

    def set_environment_kind(self, kind: str | None, path: str | None = None) -> None:
        """Switch to no environment, a ``"constant"`` one (grey sky) or a ``"map"`` (needs ``path``)."""
        env = self.environment()
        if kind is None:
            self.set_environment(None, "Remove environment")
        elif kind == "constant":
            if env is None or env.get("type") != "constant":
                self.set_environment(
                    {"type": "constant", "radiance": [0.5, 0.5, 0.5]}, "Constant environment"
                )
        elif kind == "map":
            if not path:
                raise ParameterError("an environment map needs an EXR file")
            keep = {k: env[k] for k in ("scale", "rotate_deg") if env and k in env}
            self.set_environment({"type": "map", "path": str(path), **keep}, "Environment map")
        else:
            raise ParameterError(f"unknown environment type '{kind}'; known types: constant, map")

    def set_environment_field(self, name: str, value: Any) -> None:
        env = self.environment()
        if env is None:
            raise ParameterError("the scene has no environment: choose a constant one or a map first")
        if name == "type":
            raise ParameterError("use set_environment_kind to change the environment's type")
        new = _checked(parse_environment, {**env, name: _plain(value)}, "environment")
        if new == env:
            return
        self.edit(
            f"Set environment {name}",
            lambda d: d.extras.__setitem__("environment", new),
            merge_key=("environment", name),
        )
        self.events.lights_changed.emit()

    # ---- view state (not undoable) -------------------------------------------------------------
    def select_material(self, name: str | None) -> None:
        if name is not None and name not in self.material_names():
            raise KeyError(f"no material named '{name}'")
        if name != self.current_material:
            self.current_material = name
            self.events.selection_changed.emit()

    def select_object(self, name: str | None) -> None:
        if name == self.selected_object and self.selected_item is None:
            return
        self.selected_object = name
        self.selected_item = None  # one selection at a time: an object, or a light/camera/environment
        if name is not None:
            self.current_material = self.object(name).material or self.current_material
        self.events.selection_changed.emit()

    def select_item(self, kind: str | None, index: int = 0) -> None:
        """Select a light (``"light"``, its index), the ``"camera"`` or the ``"environment"``; ``None``
        clears it. Deselects any object (the material editor keeps its current material)."""
        if kind is None:
            item = None
        elif kind == "light":
            if not 0 <= index < len(self.lights()):
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
        self.events.selection_changed.emit()

    def set_direction(self, theta_deg: float, phi_deg: float) -> None:
        """Set the exploration's incident direction (degrees; theta clamped to [0, 89.9])."""
        if not (math.isfinite(theta_deg) and math.isfinite(phi_deg)):
            raise ParameterError("the incident direction needs finite angles")
        theta = min(max(float(theta_deg), 0.0), 89.9)
        phi = float(phi_deg) % 360.0
        if (theta, phi) != (self.theta_deg, self.phi_deg):
            self.theta_deg, self.phi_deg = theta, phi
            self.events.direction_changed.emit()

    def set_light(self, direction: tuple[float, float, float]) -> None:
        x, y, z = (float(c) for c in direction)
        n = math.sqrt(x * x + y * y + z * z)
        if not math.isfinite(n) or n == 0.0:
            raise ParameterError("the light direction must be a non-zero vector")
        self.light_dir = (x / n, y / n, z / n)
        self.events.light_changed.emit()

    # ---- persistence (the app's own JSON form; the project file goes through app.project) ------
    def to_dict(self) -> dict[str, Any]:
        return {
            "materials": [vars(copy.deepcopy(m)) for m in self.data.materials],
            "objects": [vars(copy.deepcopy(o)) for o in self.data.objects],
            "extras": copy.deepcopy(self.data.extras),
            "excluded_parts": [vars(copy.deepcopy(o)) for o in self.data.excluded_parts],
        }

    @staticmethod
    def data_from_dict(raw: Mapping[str, Any]) -> DocumentData:
        mats = []
        for m in raw.get("materials", []):
            params = {k: tuple(v) if isinstance(v, list) else v for k, v in m.get("params", {}).items()}
            mats.append(
                Material(
                    m["name"],
                    m["model"],
                    params,
                    m.get("measured"),
                    m.get("notes", ""),
                    list(m.get("tags", [])),
                )
            )

        def objects(key: str) -> list[SceneObject]:
            return [
                SceneObject(
                    o["name"],
                    o["mesh"],
                    o.get("part"),
                    o.get("material", ""),
                    o.get("visible", True),
                    o.get("transform"),
                    bool(o.get("smooth", False)),
                    o.get("entry", ""),
                )  # fmt: skip
                for o in raw.get(key, [])
            ]

        return DocumentData(mats, objects("objects"), dict(raw.get("extras", {})), objects("excluded_parts"))

    def replace(self, data: DocumentData, path: Path | None) -> None:
        """Load new data: history cleared, document clean."""
        self.data = data
        self.path = path
        self._undo.clear()
        self._redo.clear()
        self._clean_index = 0
        self._brdf_cache.clear()
        self.revision += 1
        self.current_material = data.materials[0].name if data.materials else None
        self.selected_object = None
        self.selected_item = None
        self.events.materials_changed.emit()
        self.events.objects_changed.emit()
        for m in data.materials:
            self.events.material_changed.emit(m.name)
        self.events.lights_changed.emit()
        self.events.camera_changed.emit()
        self.events.selection_changed.emit()
        self.events.history_changed.emit()
        self.events.path_changed.emit()


NEW_LIGHTS: dict[str, dict[str, Any]] = {
    "point": {"type": "point", "position": [0.0, 3.0, 0.0], "intensity": [10.0, 10.0, 10.0]},
    "quad": {
        "type": "quad",
        "corner": [-0.5, 3.0, -0.5],
        "edge1": [1.0, 0.0, 0.0],
        "edge2": [0.0, 0.0, 1.0],  # edge1 x edge2 = -y: a ceiling light shining down
        "radiance": [5.0, 5.0, 5.0],
        "two_sided": False,
    },
}
"""What *Add light* starts from, per light type (scene-file form)."""


def _plain(value: Any) -> Any:
    """Tuples (from the editors) as the lists the scene file's JSON form holds."""
    return [float(v) for v in value] if isinstance(value, tuple | list) else value


def _checked(parse: Callable[..., Any], data: dict[str, Any], where: str) -> dict[str, Any]:
    """``data`` validated by the scene schema and returned in its normalized JSON form; the schema's message
    (field and reason) becomes a :class:`ParameterError`."""
    try:
        return parse(data, where).model_dump(mode="json")  # type: ignore[no-any-return]
    except SceneError as exc:
        raise ParameterError(str(exc)) from None


def _find(items: list, name: str) -> Any:
    for item in items:
        if item.name == name:
            return item
    raise KeyError(name)


def unique_name(base: str, taken: Iterable[str]) -> str:
    """``base`` or ``base.1``, ``base.2``, ... whichever is free."""
    taken = set(taken)
    if base not in taken:
        return base
    i = 1
    while f"{base}.{i}" in taken:
        i += 1
    return f"{base}.{i}"


def default_document() -> Document:
    """A document with one material per a few typical models (what the app opens with no project)."""
    data = DocumentData()
    for model in ("ggx", "phong", "lambert"):
        try:
            m = get_model(model)
        except KeyError:
            continue
        data.materials.append(Material(m.name, m.name, dict(m.defaults())))
    if not data.materials:
        from core.model import all_models

        m = all_models()[0]
        data.materials.append(Material(m.name, m.name, dict(m.defaults())))
    return Document(data)
