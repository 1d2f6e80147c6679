"""Scene files: reading their JSON (bounded, duplicate keys refused), loading, saving atomically with model
files relative to the saved file, and the digest of what a scene renders."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

from core.io import atomic_write_text, read_bounded
from core.model_files import is_model_file, load_model_file
from core.scene.checks import model_file_path
from core.scene.parsing import scene_from_dict
from core.scene.schema import Scene, SceneError

MAX_SCENE_BYTES = 64 << 20
"""The largest scene file read (a scene names its meshes and images; its own JSON is a few kilobytes)."""


class DuplicateKeyError(ValueError):
    """A JSON object names the same key twice (``json`` would keep the last value without a word)."""

    def __init__(self, key: str):
        super().__init__(f"the key '{key}' appears twice in one object (each key once)")
        self.key = key


def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``json``'s ``object_pairs_hook`` refusing a key given twice (:class:`DuplicateKeyError`)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise DuplicateKeyError(key)
        out[key] = value
    return out


def parse_scene_json(text: str, source: str) -> Any:
    """The JSON value of a scene file's ``text``; :class:`SceneError` naming ``source`` and the line for
    invalid JSON, and the key for a key given twice in one object."""
    try:
        return json.loads(text, object_pairs_hook=unique_keys)
    except DuplicateKeyError as exc:
        raise SceneError(f"{source}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise SceneError(
            f"{source}: line {exc.lineno}, column {exc.colno}: invalid JSON: {exc.msg}"
        ) from None
    except RecursionError:
        raise SceneError(f"{source}: the JSON is nested too deeply (a scene is a few levels deep)") from None


def read_scene_json(path: str | os.PathLike[str]) -> Any:
    """The JSON value of the scene (project) file at ``path``, read within :data:`MAX_SCENE_BYTES` (a device
    such as ``/dev/zero`` is refused before it is read); :class:`SceneError` saying what is wrong."""
    p = Path(path)
    try:
        text = read_bounded(p, MAX_SCENE_BYTES, "scene file", SceneError).decode("utf-8")
    except FileNotFoundError:
        raise SceneError(f"{path}: scene file not found") from None
    except IsADirectoryError:
        raise SceneError(f"{path}: is a folder, not a scene file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot read the scene file: {exc}") from None
    return parse_scene_json(text, p.name)


def load_scene(path: str | os.PathLike[str], check_files: bool = True) -> Scene:
    """Read and validate a scene file; raises :class:`SceneError` with the file and field at fault."""
    p = Path(path)
    data = read_scene_json(p)
    return scene_from_dict(data, source=p.name, base_dir=p.resolve().parent, check_files=check_files)


def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """The JSON form of ``scene``; an empty ``exclude_groups`` is left out (as in files written by hand)."""
    data = scene.model_dump(mode="json")
    for mesh in data["meshes"]:
        if not mesh["exclude_groups"]:
            del mesh["exclude_groups"]
    return data


def scene_digest(scene: Scene, *extra: Any) -> str:
    """A hex key of what renders ``scene``: its JSON form, ``extra`` (JSON values: size, spp, seed, ...) and the
    bytes of every file it names (meshes, measured materials, the sky map), so that a cached render of it is
    not used once any of them changes."""
    h = hashlib.sha1(json.dumps([scene.model_dump(mode="json"), *extra], sort_keys=True).encode())
    files = {m.path for m in scene.meshes} | {m.measured for m in scene.materials if m.measured}
    if scene.environment is not None and getattr(scene.environment, "path", None):
        files.add(scene.environment.path)
    for rel in sorted(files):
        h.update(scene.resolve(rel).read_bytes())
    for model in sorted({m.model for m in scene.materials if m.model and is_model_file(m.model)}):
        h.update(load_model_file(model_file_path(scene, model)).source.digest.encode())  # type: ignore[union-attr]
    return h.hexdigest()


def save_scene(scene: Scene, path: str | os.PathLike[str]) -> None:
    """Write ``scene`` as indented JSON, atomically (a crash never leaves a half-written file); a material's
    model file is written relative to ``path``'s folder (as it was read)."""
    data = scene_to_dict(scene)
    folder = Path(path).resolve().parent
    for mat in data["materials"]:
        model = mat.get("model")
        if model and is_model_file(model) and Path(model).is_absolute():
            mat["model"] = _relative_to(model, folder)
    atomic_write_text(path, json.dumps(data, indent=2) + "\n")


def _relative_to(path: str, folder: Path) -> str:
    """``path`` relative to ``folder``, with '/' (as a scene file holds paths); unchanged across drives."""
    try:
        return Path(os.path.relpath(path, folder)).as_posix()
    except ValueError:  # another drive (Windows)
        return path
