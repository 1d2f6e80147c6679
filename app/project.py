"""Between the app's document and the project file (the renderer's scene format, :mod:`core.scene`).

A mesh file becomes one object, or one object per group when it holds several (``group_materials`` in the
scene; deleted groups are its ``exclude_groups``); paths are written relative to the project file. Camera,
lights and environment are kept in the scene's form in the document's ``extras`` (edited there through the
document), render settings are carried through unchanged.
"""

from __future__ import annotations

import copy
import os
from collections.abc import Callable
from pathlib import Path

from app.capabilities import MEASURED_MODEL
from app.state import DocumentData, Material, SceneObject, unique_name
from core.errors import BrdfStudioError
from core.scene import (
    SCENE_VERSION,
    Mesh,
    Scene,
    SceneError,
    kept_groups,
    load_scene,
    save_scene,
    scene_from_dict,
)

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
EXTRA_KEYS = ("name", "camera", "lights", "environment", "render")

PartLister = Callable[[Path], list[str]]


def mesh_parts(path: Path) -> list[str]:
    """The group names of a mesh file as the renderer reads it (``SceneError`` if unreadable or empty)."""
    from app.meshes import load_parts

    return [p.name for p in load_parts(path)]


def objects_from_mesh(path: Path, material: str, parts: PartLister = mesh_parts) -> list[SceneObject]:
    """One object for a single-part file, one per part for a multi-part file."""
    path = Path(path)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise SceneError(
            f"'{path.name}' is not a mesh file this app reads (expected one of {', '.join(MESH_SUFFIXES)})"
        )
    names = parts(path)
    if len(names) <= 1:
        return [SceneObject(path.stem, str(path), None, material)]
    return [SceneObject(f"{path.stem}/{n or i}", str(path), n, material) for i, n in enumerate(names)]


def _rel(path: str, base: Path) -> str:
    p = Path(path)
    if not p.is_absolute():
        return p.as_posix()
    try:
        return Path(os.path.relpath(p, base)).as_posix()
    except ValueError:  # another drive (Windows)
        return p.as_posix()


def document_to_scene(data: DocumentData, project: Path) -> Scene:
    """A validated :class:`Scene` for ``data`` saved as ``project`` (paths made relative to its folder)."""
    base = Path(project).resolve().parent
    materials = []
    for m in data.materials:
        entry: dict = {"name": m.name, "notes": m.notes, "tags": list(m.tags)}
        if m.measured:
            entry["measured"] = _rel(m.measured, base)
        else:
            entry["model"] = m.model
            entry["params"] = {k: list(v) if isinstance(v, tuple) else v for k, v in m.params.items()}
        emission = data.extras.get("emission", {}).get(m.name)
        if emission:
            entry["emission"] = emission
        materials.append(entry)
    meshes: list[dict] = []
    by_entry: dict[tuple[str, str], dict] = {}
    for o in data.objects:
        options: dict = {}
        if o.transform:
            options["transform"] = o.transform
        if o.smooth:
            options["smooth"] = True
        if o.part is None:
            meshes.append({"name": o.name, "path": _rel(o.mesh, base), "material": o.material, **options})
            continue
        key = (o.mesh, o.entry or Path(o.mesh).stem)
        entry = by_entry.get(key)
        if entry is None:
            entry = {"name": key[1], "path": _rel(o.mesh, base), "material": o.material, **options}
            entry["group_materials"] = {}
            by_entry[key] = entry
            meshes.append(entry)
        entry["group_materials"][o.part] = o.material
    for o in data.excluded_parts:  # deleted parts of files that still have parts in the scene
        entry = by_entry.get((o.mesh, o.entry or Path(o.mesh).stem))
        if entry is not None and o.part not in entry["group_materials"]:
            excluded = entry.setdefault("exclude_groups", [])
            if o.part not in excluded:
                excluded.append(o.part)
    raw = {"version": SCENE_VERSION, "materials": materials, "meshes": meshes}
    for k in EXTRA_KEYS:
        if k in data.extras and data.extras[k] is not None:
            raw[k] = copy.deepcopy(data.extras[k])
    if raw.get("environment", {}).get("path"):
        raw["environment"]["path"] = _rel(raw["environment"]["path"], base)
    return scene_from_dict(raw, source=Path(project).name, base_dir=base, check_files=False)


def save_project(data: DocumentData, project: Path) -> None:
    """Validate and write atomically (``BrdfStudioError`` with the reason on failure)."""
    scene = document_to_scene(data, project)
    try:
        save_scene(scene, project)
    except OSError as exc:
        raise BrdfStudioError(f"cannot save '{project}': {exc.strerror or exc}") from None


def scene_to_document(scene: Scene, parts: PartLister = mesh_parts) -> DocumentData:
    """The document for a loaded scene; mesh files are listed (not loaded into the document)."""
    data = DocumentData()
    emission = {}
    for m in scene.materials:
        if m.measured:
            data.materials.append(Material(m.name, MEASURED_MODEL, {}, str(scene.resolve(m.measured))))
        else:
            params = {k: tuple(v) if isinstance(v, list) else v for k, v in m.params.items()}
            from core.model import get_model

            values = get_model(m.model or "").resolve(params)
            data.materials.append(Material(m.name, m.model or "", dict(values)))
        data.materials[-1].notes = getattr(m, "notes", "") or ""
        data.materials[-1].tags = list(getattr(m, "tags", []) or [])
        if m.emissive:
            emission[m.name] = list(m.emission)
    identity = Mesh(path="x", material="x").transform.model_dump(mode="json")
    for i, mesh in enumerate(scene.meshes):
        full = scene.resolve(mesh.path)
        name = mesh.name or Path(mesh.path).stem
        transform = mesh.transform.model_dump(mode="json")
        transform = None if transform == identity else transform
        try:
            names = parts(full)
        except BrdfStudioError as exc:
            raise SceneError(f"{scene.source}: meshes[{i}].path: {exc}") from None
        keep = kept_groups(scene, i, names)  # an excluded name the file does not hold is an error
        if len(names) <= 1 and not mesh.group_materials and not mesh.exclude_groups:
            data.objects.append(
                SceneObject(name, str(full), None, mesh.material, True, transform, mesh.smooth)
            )
        else:
            for n, kept in zip(names, keep, strict=True):
                obj = SceneObject(
                    f"{name}/{n}",
                    str(full),
                    n,
                    mesh.group_materials.get(n, mesh.material),
                    True,
                    transform,
                    mesh.smooth,
                    name,
                )  # fmt: skip
                (data.objects if kept else data.excluded_parts).append(obj)
    taken: list[str] = []
    for o in data.objects:  # names identify objects in the app: keep them unique
        o.name = unique_name(o.name, taken)
        taken.append(o.name)
    dumped = scene.model_dump(mode="json")
    data.extras = {k: dumped[k] for k in EXTRA_KEYS if dumped.get(k) is not None}
    env = data.extras.get("environment")
    if env and env.get("path"):  # absolute while in the app; relative again when saved
        env["path"] = str(scene.resolve(env["path"]))
    if emission:
        data.extras["emission"] = emission
    return data


def load_project(path: Path, parts: PartLister = mesh_parts) -> DocumentData:
    """Read a project file into a document (``SceneError`` with the file and field at fault)."""
    return scene_to_document(load_scene(path), parts)
