"""Project files: a project *is* a scene file (:mod:`core.scene`); the app reads and writes it with the
scene module's own loader and writer. Two things happen at the boundary, both on the same schema:

- paths: absolute while the app holds the scene (so undo steps stay valid when *Save as* moves the project),
  relative to the project file's folder when saved;
- parameters: a material's parameter values completed with its model's defaults when read, so the editor
  shows every parameter (the saved file then lists them all).
"""

from __future__ import annotations

import os
from pathlib import Path

from app.document import PartLister, mesh_parts, unique_name
from core.errors import BrdfStudioError
from core.model import get_model
from core.scene import Scene, SceneError, kept_groups, load_scene, save_scene, scene_from_dict, validate_scene


def _relative(path: str, base: Path) -> str:
    p = Path(path)
    if not p.is_absolute():
        return p.as_posix()
    try:
        return Path(os.path.relpath(p, base)).as_posix()
    except ValueError:  # another drive (Windows)
        return p.as_posix()


def _map_paths(scene: Scene, fn) -> None:
    for mesh in scene.meshes:
        mesh.path = fn(mesh.path)
    for mat in scene.materials:
        if mat.measured:
            mat.measured = fn(mat.measured)
    if scene.environment is not None and scene.environment.type == "map":
        scene.environment.path = fn(scene.environment.path)


def for_editing(scene: Scene, parts: PartLister = mesh_parts) -> Scene:
    """``scene`` (changed in place and returned) as the app holds it: absolute paths, every material's
    parameters complete, every mesh named (names identify objects), excluded groups checked against the
    files (``SceneError`` naming the mesh when one cannot be read)."""
    taken: list[str] = []
    for i, mesh in enumerate(scene.meshes):
        try:
            groups = parts(scene.resolve(mesh.path))
        except BrdfStudioError as exc:
            raise SceneError(f"{scene.source}: meshes[{i}].path: {exc}") from None
        kept_groups(scene, i, groups)  # an excluded group the file does not hold is an error
        mesh.name = unique_name(mesh.name or Path(mesh.path).stem, taken)
        taken.append(mesh.name)
    _map_paths(scene, lambda p: str(scene.resolve(p).resolve()))
    for mat in scene.materials:
        if mat.model is not None:
            mat.params = dict(get_model(mat.model).resolve(mat.params))
    return scene


def load_project(path: Path, parts: PartLister = mesh_parts) -> Scene:
    """Read a project file for editing (``SceneError`` with the file and field at fault)."""
    return for_editing(load_scene(path), parts)


def scene_from_autosave(data: dict, parts: PartLister = mesh_parts) -> Scene:
    """The scene an autosave holds (it was written with absolute paths)."""
    return for_editing(scene_from_dict(data, source="autosave", check_files=False), parts)


def save_project(scene: Scene, path: Path) -> None:
    """Validate and write ``scene`` as the project ``path``, paths relative to its folder, atomically
    (``BrdfStudioError`` with the reason on failure). ``scene`` itself is not changed."""
    path = Path(path)
    folder = path.resolve().parent
    copy = scene.model_copy(deep=True)
    _map_paths(copy, lambda p: _relative(p, folder))
    copy.set_origin(folder, path.name)
    validate_scene(copy, check_files=False)
    try:
        save_scene(copy, path)
    except OSError as exc:
        raise BrdfStudioError(f"cannot save '{path}': {exc.strerror or exc}") from None
