"""The document the desktop app edits: one :class:`core.scene.Scene` (the project file's own model), evented
and undoable through :class:`app.evented.EventedModel`, plus the view state that is not part of the project
(selection, the exploration's direction, the lit sphere's light).

The scene's paths are absolute while the app holds it (:mod:`app.project` writes them relative to the project
file when saving). *Objects* are what the user sees in the tree and the viewport: a mesh entry of the scene,
or one group of a multi-group mesh file (its material is the entry's ``group_materials`` entry; deleting it
adds it to ``exclude_groups``). They are derived from the scene, never stored beside it.

Every edit is checked by the schema itself: pydantic's field validation on assignment and
:func:`core.scene.validate_scene` for what spans fields (names, models and parameters, quads with area, a
camera that can form an image). No Qt here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from app.evented import Event, EventedModel, Items
from app.model_library import fit_params
from app.objects import PartLister, SceneObject, mesh_parts, scene_objects, unique_name
from app.view_state import ViewState
from core.brdf import BRDF, get_model
from core.errors import BrdfStudioError, ParameterError
from core.scene import (
    Camera,
    ConstantEnvironment,
    MapEnvironment,
    Material,
    Mesh,
    PointLight,
    QuadLight,
    Scene,
    SceneError,
    parse_environment,
    validate_scene,
)

NEW_LIGHTS: dict[str, dict[str, Any]] = {
    "point": {"type": "point", "position": (0.0, 3.0, 0.0), "intensity": (10.0, 10.0, 10.0)},
    "quad": {  # edge1 x edge2 = -y: a ceiling light shining down
        "type": "quad", "corner": (-0.5, 3.0, -0.5), "edge1": (1.0, 0.0, 0.0), "edge2": (0.0, 0.0, 1.0),
        "radiance": (5.0, 5.0, 5.0),
    },
}  # fmt: skip
"""What *Add light* starts from, per light type."""
LIGHT_TYPES = {"point": PointLight, "quad": QuadLight}


def _check(scene: Scene) -> None:
    validate_scene(scene, check_files=False)


def default_scene() -> Scene:
    """What the app opens with no project: one material per a few typical models, nothing else."""
    materials = [
        Material(name=m, model=m, params=dict(get_model(m).defaults())) for m in ("ggx", "phong", "lambert")
    ]
    return Scene(materials=materials)


class Document(EventedModel[Scene], ViewState):
    """The edited project. ``events`` has one event per scene field (``materials``, ``meshes``, ``lights``,
    ``environment``, ``camera``, ``render``, ...); the view state's events are :class:`app.view_state.ViewState`'s,
    plus ``path_changed`` and ``history_changed``."""

    def __init__(self, scene: Scene | None = None, path: Path | None = None, parts: PartLister = mesh_parts):
        EventedModel.__init__(self, scene if scene is not None else default_scene(), _check)
        ViewState.__init__(self)
        self.path = path
        self.parts = parts
        self.path_changed = Event()
        self.current_material = self._first_material()
        self._brdfs: dict[str, tuple[Any, BRDF]] = {}
        self._objects: tuple[int, list[SceneObject]] | None = None

    @property
    def scene(self) -> Scene:
        return self.model

    # ---- queries ----------------------------------------------------------------------------------------
    def _first_material(self) -> str | None:
        return self.model.materials[0].name if self.model.materials else None

    def material_names(self) -> list[str]:
        return [m.name for m in self.scene.materials]

    def material(self, name: str | None = None) -> Material:
        name = self.current_material if name is None else name
        for m in self.scene.materials:
            if m.name == name:
                return m
        raise KeyError(f"no material named '{name}'")

    def brdf(self, name: str | None = None) -> BRDF:
        """The bound BRDF of a material (cached until the material changes)."""
        mat = self.material(name)
        key = (mat.model, mat.measured, tuple(sorted(mat.params.items())))
        hit = self._brdfs.get(mat.name)
        if hit is not None and hit[0] == key:
            return hit[1]
        if mat.measured:
            from core.measured import load_measured

            brdf = load_measured(mat.measured)
        else:
            model = get_model(mat.model or "")
            # a model file's values fitted to its version in use (an undo step may hold an older version's)
            brdf = model.bind(fit_params(model, mat.params) if model.source is not None else mat.params)
        self._brdfs[mat.name] = (key, brdf)
        return brdf

    def objects(self) -> list[SceneObject]:
        """The scene's objects (computed from its meshes, once per revision)."""
        if self._objects is None or self._objects[0] != self.revision:
            self._objects = (self.revision, scene_objects(self.scene, self.parts))
        return self._objects[1]

    def object(self, name: str) -> SceneObject:
        for o in self.objects():
            if o.name == name:
                return o
        raise KeyError(f"no object named '{name}'")

    def to_dict(self) -> dict[str, Any]:
        """The scene in its JSON form (what an autosave holds)."""
        from core.scene import scene_to_dict

        return scene_to_dict(self.scene)

    # ---- edits: any field ---------------------------------------------------------------------------------
    def set_field(self, path: tuple[str | int, ...], value: Any, label: str | None = None) -> None:
        """Set the field at ``path`` (``("lights", 0, "radiance")``, ``("camera", "fov_deg")``) to ``value``,
        validated by the schema; one undo step per burst of edits of that field."""
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path[:-1]).lstrip(".")
        name = path[-1]

        def change(scene: Scene) -> None:
            target: Any = scene
            for step in path[:-1]:
                target = target[step] if isinstance(step, int) else getattr(target, step)
            if target is None:
                raise ParameterError(f"{where}: the scene has none; choose one first")
            if isinstance(target, dict):
                target[name] = value
                return
            if name not in type(target).model_fields:
                raise ParameterError(f"{where}.{name}: unknown field (check the spelling)")
            if name == "type":
                raise ParameterError(f"{where}: the type cannot change: add one of the other type")
            setattr(target, str(name), tuple(value) if isinstance(value, list) else value)

        self.edit(label or f"Set {where} {name}", change, merge_key=("field", path), where=where)

    # ---- materials -----------------------------------------------------------------------------------------
    def _material_edit(
        self, label: str, material: str | None, change: Callable[[Material], None], key: Any = None
    ) -> None:
        name = self.material(material).name
        self.edit(label, lambda s: change(s.materials[s.material_index(name)]), merge_key=key)

    def set_param(self, name: str, value: Any, material: str | None = None) -> None:
        """Set one parameter (validated against the model's bounds; raises :class:`ParameterError`)."""
        mat = self.material(material)
        if mat.measured:
            raise ParameterError(f"material '{mat.name}' is measured: it has no parameters to edit")
        value = get_model(mat.model or "").param(name).validate(mat.model or "", value)
        self._material_edit(
            f"Set {name}", mat.name, lambda m: m.params.__setitem__(name, value), ("param", mat.name, name)
        )

    def set_model(self, model: str, material: str | None = None) -> None:
        """Switch a material to another model, with that model's default parameters."""
        m = get_model(model)

        def change(mat: Material) -> None:
            mat.measured, mat.model, mat.params = None, model, dict(m.defaults())

        self._material_edit(f"Switch to {m.label}", material, change)

    def model_file_reloaded(self, path: str) -> None:
        """A new version of the model file ``path`` is in use (:class:`app.model_library.ModelLibrary`): its
        materials keep the values the new version accepts and take its defaults for the others (one undo
        step, when a value changed), and every view of them hears of it."""
        indices = frozenset(i for i, m in enumerate(self.scene.materials) if m.model == path)
        if not indices:
            return
        model = get_model(path)
        fitted = {i: fit_params(model, self.scene.materials[i].params) for i in indices}
        for i in indices:
            self._brdfs.pop(self.scene.materials[i].name, None)
        if any(fitted[i] != self.scene.materials[i].params for i in indices):

            def change(scene: Scene) -> None:
                for i, params in fitted.items():
                    scene.materials[i].params = params

            self.edit(f"Reload {Path(path).name}", change)
        else:
            self.events.materials.emit(indices)

    def set_measured(self, path: str, material: str | None = None) -> None:
        """Make a material measured from a MERL or RGL file (read now, so a bad file raises before any edit)."""
        from core.measured import load_measured

        load_measured(str(path))

        def change(mat: Material) -> None:
            mat.model, mat.params, mat.measured = None, {}, str(path)

        self._material_edit(f"Load measured {Path(path).name}", material, change)

    def set_notes(self, notes: str, material: str | None = None) -> None:
        name = self.material(material).name
        self._material_edit("Edit notes", name, lambda m: setattr(m, "notes", notes), ("notes", name))

    def set_tags(self, tags: Iterable[str], material: str | None = None) -> None:
        clean = [t.strip() for t in tags if t.strip()]
        name = self.material(material).name
        self._material_edit("Edit tags", name, lambda m: setattr(m, "tags", clean), ("tags", name))

    def add_material(
        self, model: str = "lambert", name: str | None = None, params: Mapping[str, Any] | None = None
    ) -> str:
        m = get_model(model)
        new = Material(
            name=unique_name(name or m.name, self.material_names()),
            model=model,
            params=dict(m.resolve(params)),
        )
        self.edit(f"New material {new.name}", lambda s: s.materials.append(new.model_copy(deep=True)))
        self.select_material(new.name)
        return new.name

    def rename_material(self, old: str, new: str) -> str:
        new = new.strip()
        if not new:
            raise ParameterError("a material name cannot be empty")
        if new != old and new in self.material_names():
            raise ParameterError(f"a material named '{new}' exists already")

        def change(scene: Scene) -> None:
            scene.materials[scene.material_index(old)].name = new
            for mesh in scene.meshes:
                mesh.material = new if mesh.material == old else mesh.material
                mesh.group_materials = {g: new if m == old else m for g, m in mesh.group_materials.items()}

        if self.current_material == old:
            self.current_material = new  # before the events: the views look the material up by this name
        try:
            self.edit(f"Rename {old}", change)
        except BrdfStudioError:
            self.current_material = old
            raise
        return new

    def remove_material(self, name: str) -> None:
        if any(o.material == name for o in self.objects()):
            raise ParameterError(f"material '{name}' is assigned to objects; assign another material first")
        self.edit(f"Delete material {name}", lambda s: s.materials.pop(s.material_index(name)))

    # ---- objects ---------------------------------------------------------------------------------------
    def add_mesh(self, path: str | Path, label: str | None = None, merge_key: Any = None) -> list[str]:
        """Add a mesh file with the current material; returns the new objects' names. A file that cannot be
        read raises :class:`SceneError` and changes nothing. Imports sharing ``merge_key`` are one step."""
        path = Path(path).resolve()
        from core.scene import MESH_FORMATS

        if path.suffix.lower() not in MESH_FORMATS:
            raise SceneError(
                f"'{path.name}' is not a mesh file this app reads (expected one of {', '.join(MESH_FORMATS)})"
            )
        if self.current_material is None:
            raise ParameterError("the project has no material: add one first")
        self.parts(path)  # read now: a bad file is refused before any edit
        before = {o.name for o in self.objects()}
        name = unique_name(path.stem, [m.name or Path(m.path).stem for m in self.scene.meshes])
        mesh = Mesh(name=name, path=str(path), material=self.current_material)
        self.edit(
            label or f"Import {path.name}", lambda s: s.meshes.append(mesh.model_copy(deep=True)), merge_key
        )
        return [o.name for o in self.objects() if o.name not in before]

    def remove_object(self, name: str) -> None:
        """Remove an object; a group of a multi-group file is added to the mesh's ``exclude_groups`` (the
        mesh entry goes when its last group does)."""
        obj = self.object(name)

        def change(scene: Scene) -> None:
            mesh = scene.meshes[obj.mesh_index]
            left = [o for o in self.objects() if o.mesh_index == obj.mesh_index and o.name != name]
            if obj.part is None or not left:
                scene.meshes.pop(obj.mesh_index)
            else:
                mesh.exclude_groups = [*mesh.exclude_groups, obj.part]
                mesh.group_materials = {g: m for g, m in mesh.group_materials.items() if g != obj.part}

        self.edit(f"Delete {name}", change)

    def assign_material(self, name: str, material: str) -> None:
        if material not in self.material_names():
            raise ParameterError(f"no material named '{material}'")
        obj = self.object(name)

        def change(scene: Scene) -> None:
            mesh = scene.meshes[obj.mesh_index]
            if obj.part is None:
                mesh.material = material
            else:
                mesh.group_materials = {**mesh.group_materials, obj.part: material}

        self.edit(f"Assign {material} to {name}", change)

    # ---- lights, camera, environment -------------------------------------------------------------------
    def add_light(self, kind: str = "point", values: Mapping[str, Any] | None = None) -> int:
        """Add a light of ``kind`` (``"point"`` or ``"quad"``) from :data:`NEW_LIGHTS` overridden by
        ``values``; selects it and returns its index."""
        if kind not in LIGHT_TYPES:
            raise ParameterError(f"unknown light type '{kind}'; known types: {', '.join(LIGHT_TYPES)}")
        index = len(self.scene.lights)
        data = {**NEW_LIGHTS[kind], **(values or {})}
        self.edit(
            f"Add {kind} light",
            lambda s: s.lights.append(LIGHT_TYPES[kind].model_validate(data)),
            where=f"lights[{index}]",
        )
        self.select_item("light", index)
        return index

    def remove_light(self, index: int) -> None:
        if not 0 <= index < len(self.scene.lights):
            raise KeyError(f"no light number {index + 1}")
        item = self.selected_item
        if item is not None and item[0] == "light" and item[1] >= index:  # the same light, one place up
            self.selected_item = None if item[1] == index else ("light", item[1] - 1)
        self.edit(f"Delete {self.scene.lights[index].type} light {index + 1}", lambda s: s.lights.pop(index))

    def set_light_field(self, index: int, name: str, value: Any) -> None:
        if not 0 <= index < len(self.scene.lights):
            raise KeyError(f"no light number {index + 1}")
        self.set_field(("lights", index, name), value, f"Set light {index + 1} {name}")

    def set_camera(
        self,
        camera: Camera | Mapping[str, Any],
        label: str = "Move camera",
        merge_key: Any = ("camera", "view"),
        join_last: bool = False,
    ) -> None:
        """Replace the camera (validated; an unchanged camera is no edit)."""

        def change(scene: Scene) -> None:
            scene.camera = camera if isinstance(camera, Camera) else Camera.model_validate(dict(camera))

        self.edit(label, change, merge_key, "camera", join_last)

    def set_camera_field(self, name: str, value: Any) -> None:
        self.set_field(("camera", name), value, f"Set camera {name}")

    def set_environment(
        self, environment: ConstantEnvironment | MapEnvironment | None, label: str = "Set environment"
    ) -> None:
        self.edit(label, lambda s: setattr(s, "environment", environment), where="environment")

    def set_environment_kind(self, kind: str | None, path: str | None = None) -> None:
        """No environment (``None``), a ``"constant"`` one (grey sky) or a ``"map"`` (needs an existing EXR
        ``path``; its scale and rotation are kept from the previous map)."""
        env = self.scene.environment
        if kind is None:
            self.set_environment(None, "Remove environment")
        elif kind == "constant":
            if not isinstance(env, ConstantEnvironment):
                self.set_environment(
                    ConstantEnvironment(type="constant", radiance=(0.5, 0.5, 0.5)), "Constant environment"
                )
        elif kind == "map":
            if not path:
                raise ParameterError("an environment map needs an EXR file")
            keep = (
                {"scale": env.scale, "rotate_deg": env.rotate_deg} if isinstance(env, MapEnvironment) else {}
            )
            try:
                new = parse_environment({"type": "map", "path": str(path), **keep})
            except SceneError as exc:
                raise ParameterError(str(exc)) from None
            self.set_environment(new, "Environment map")  # type: ignore[arg-type]
        else:
            raise ParameterError(f"unknown environment type '{kind}'; known types: constant, map")

    def set_environment_field(self, name: str, value: Any) -> None:
        self.set_field(("environment", name), value, f"Set environment {name}")

    # ---- view state (not undoable) ---------------------------------------------------------------------
    def _changed(self, changes: dict[str, Items]) -> None:
        """Keep the selection valid before the views hear of the change."""
        names = self.material_names()
        if self.current_material not in names:
            self.current_material = names[0] if names else None
        if self.selected_object is not None and self.selected_object not in {o.name for o in self.objects()}:
            self.selected_object = None
        item = self.selected_item
        if item is not None and item[0] == "light" and item[1] >= len(self.scene.lights):
            self.selected_item = None
        if "materials" in changes:
            self._brdfs = {k: v for k, v in self._brdfs.items() if k in names}
        super()._changed(changes)
        if {"materials", "meshes", "lights"} & set(changes):
            self.selection_changed.emit()

    def set_path(self, path: Path | None) -> None:
        self.path = path
        self.path_changed.emit()

    def replace(self, scene: Scene, path: Path | None) -> None:
        """Load another scene: history cleared, document clean, selection reset."""
        self.path = path
        self._brdfs.clear()
        self.current_material = scene.materials[0].name if scene.materials else None
        self.selected_object = None
        self.selected_item = None
        self.reset(scene)
        self.path_changed.emit()
