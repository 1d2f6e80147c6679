"""What the tree and the viewport call *objects*, derived from a scene's meshes (never stored beside them):
a mesh entry, or each kept group of a multi-group mesh file. A group's material is the entry's
``group_materials`` entry (else the entry's material); a deleted group is in the entry's ``exclude_groups``."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from core.errors import BrdfStudioError
from core.scene import Scene, Transform

PartLister = Callable[[Path], list[str]]
"""The group names of a mesh file (``SceneError`` if it cannot be read)."""


def mesh_parts(path: Path) -> list[str]:
    """The group names of a mesh file as the renderer reads it (``SceneError`` if unreadable or empty)."""
    from app.meshes import load_parts

    return [p.name for p in load_parts(path)]


@dataclass(frozen=True)
class SceneObject:
    """What the tree and the viewport show: a mesh entry of the scene, or one group of its file."""

    name: str
    mesh_index: int
    part: str | None
    """The group inside a multi-group file (``None``: the whole file)."""
    mesh: str
    """The mesh file's absolute path."""
    material: str
    transform: Transform
    smooth: bool


def unique_name(base: str, taken: Iterable[str]) -> str:
    """``base`` or ``base.1``, ``base.2``, ... whichever is free."""
    taken = set(taken)
    if base not in taken:
        return base
    i = 1
    while f"{base}.{i}" in taken:
        i += 1
    return f"{base}.{i}"


def scene_objects(scene: Scene, parts: PartLister) -> list[SceneObject]:
    """The objects of ``scene``, named uniquely (a file that cannot be read is one object)."""
    out: list[SceneObject] = []
    taken: list[str] = []
    for i, mesh in enumerate(scene.meshes):
        base = mesh.name or Path(mesh.path).stem
        try:
            groups = parts(Path(mesh.path))
        except BrdfStudioError:
            groups = []
        whole = len(groups) <= 1 and not mesh.group_materials and not mesh.exclude_groups
        for group in [None] if whole else [g for g in groups if g not in mesh.exclude_groups]:
            name = unique_name(base if group is None else f"{base}/{group}", taken)
            taken.append(name)
            material = mesh.material if group is None else mesh.group_materials.get(group, mesh.material)
            out.append(SceneObject(name, i, group, mesh.path, material, mesh.transform, mesh.smooth))
    return out
