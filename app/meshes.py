"""Mesh files as the viewport shows them: read once (through the renderer's reader, so groups are named
the way the renderer names them) and cached by path and modification time."""

from __future__ import annotations

from pathlib import Path

from core.scene import SceneError
from renderer.mesh import MeshPart, load_mesh_file

_CACHE: dict[tuple[str, int], list[MeshPart]] = {}


def load_parts(path: str | Path) -> list[MeshPart]:
    """The triangle groups of a mesh file (``SceneError`` with the reason if unreadable or empty)."""
    path = Path(path)
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        raise SceneError(f"mesh file '{path}' not found") from None
    key = (str(path.resolve()), stamp)
    parts = _CACHE.get(key)
    if parts is None:
        parts = load_mesh_file(path, where=f"mesh '{path.name}'")
        if not parts:
            raise SceneError(f"mesh '{path.name}': the file holds no triangles")
        _CACHE[key] = parts
    return parts


def part(path: str | Path, name: str | None) -> list[MeshPart]:
    """The groups of an object: all of the file's, or the one named ``name``."""
    parts = load_parts(path)
    if name is None:
        return parts
    chosen = [p for p in parts if p.name == name]
    if not chosen:
        raise SceneError(f"mesh '{Path(path).name}' has no group named '{name}'")
    return chosen
