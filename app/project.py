"""Project files: a project *is* a scene file (:mod:`core.scene`); the app reads and writes it with the
scene module's own loader and writer. Two things happen at the boundary, both on the same schema:

- paths: absolute while the app holds the scene (so undo steps stay valid when *Save as* moves the project),
  relative to the project file's folder when saved; a material's model file (``"model": "my.brdf"``) too;
- parameters: a material's parameter values completed with its model's defaults when read, so the editor
  shows every parameter (the saved file then lists them all).

A project's model files are opened before the scene is checked, through the app's ``open_model`` (a
:data:`ModelOpener`: it asks before it runs a ``.py`` file, :mod:`app.model_library`); a material whose file
it does not open takes :data:`app.model_library.FALLBACK_MODEL`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from app.document import PartLister, mesh_parts, unique_name
from app.model_library import FALLBACK_MODEL, fit_params
from core.brdf import get_model
from core.errors import BrdfStudioError
from core.model_files import is_model_file
from core.scene import Scene, SceneError, kept_groups, load_scene, save_scene, scene_from_dict, validate_scene

ModelOpener = Callable[[Path, str], bool]
"""``open_model(path, material)``: open the model file ``path`` (absolute) that the material named
``material`` uses; False when it was not opened (declined or broken: the opener tells the user why)."""


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
        if mat.model and is_model_file(mat.model):
            mat.model = fn(mat.model)
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


def open_model_files(data: Any, base: Path, open_model: ModelOpener | None = None) -> None:
    """In a scene's JSON ``data`` (changed in place): each material's model file made an absolute path (a
    relative one is relative to ``base``, the project's folder) and opened by ``open_model``: one it does
    not open takes :data:`FALLBACK_MODEL`; one it opens keeps the values its parameters accept (the file
    may have changed since the project was saved). Malformed entries are left to the scene's checks."""
    materials = data.get("materials") if isinstance(data, dict) else None
    for mat in materials if isinstance(materials, list) else ():
        model = mat.get("model") if isinstance(mat, dict) else None
        if not isinstance(model, str) or not is_model_file(model):
            continue
        full = (base / Path(model).expanduser()).resolve()
        mat["model"] = str(full)
        if open_model is not None and not open_model(full, str(mat.get("name", ""))):
            mat["model"], mat["params"] = FALLBACK_MODEL, {}
            continue
        params = mat.get("params")
        try:
            mat["params"] = fit_params(get_model(full), params if isinstance(params, dict) else {})
        except BrdfStudioError:
            pass  # the scene's checks say what is wrong with the file


def _json_of(path: Path) -> Any:
    """The JSON a project file holds, or None when it cannot be read (:func:`load_scene` then says why)."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return None


def load_project(path: Path, parts: PartLister = mesh_parts, open_model: ModelOpener | None = None) -> Scene:
    """Read a project file for editing (``SceneError`` with the file and field at fault); its model files
    are opened by ``open_model`` (:func:`open_model_files`)."""
    path = Path(path)
    data = _json_of(path)
    if data is None:
        return for_editing(load_scene(path), parts)
    folder = path.resolve().parent
    open_model_files(data, folder, open_model)
    return for_editing(scene_from_dict(data, source=path.name, base_dir=folder), parts)


def scene_from_autosave(
    data: dict, parts: PartLister = mesh_parts, open_model: ModelOpener | None = None
) -> Scene:
    """The scene an autosave holds (it was written with absolute paths)."""
    open_model_files(data, Path.cwd(), open_model)
    return for_editing(scene_from_dict(data, source="autosave", check_files=False), parts)


def save_project(scene: Scene, path: Path) -> None:
    """Validate and write ``scene`` as the project ``path``, paths relative to its folder, atomically
    (``BrdfStudioError`` with the reason on failure). ``scene`` itself is not changed."""
    path = Path(path)
    folder = path.resolve().parent
    copy = scene.model_copy(deep=True)
    copy.set_origin(folder, path.name)
    validate_scene(copy, check_files=False)  # with absolute paths: a model file's is read from the file
    _map_paths(copy, lambda p: _relative(p, folder))
    try:
        save_scene(copy, path)
    except OSError as exc:
        raise BrdfStudioError(f"cannot save '{path}': {exc.strerror or exc}") from None
