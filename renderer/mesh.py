"""Mesh files to triangle arrays (through trimesh), with the checks a renderer needs.

Every format trimesh reads is accepted (OBJ, PLY, STL, OFF, GLB/GLTF); a file becomes a list of
:class:`MeshPart` (one per OBJ object/group or GLTF node), with the scene's transform applied.
Empty meshes, NaN or infinite vertices and out-of-range face indices are :class:`~core.scene.SceneError`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.io import check_input_size
from core.scene import SceneError, Transform

MAX_MESH_BYTES = 2 << 30
"""The largest mesh file read (trimesh holds several times a file's size while it parses it)."""


@dataclass
class MeshPart:
    """One group of triangles: ``vertices (n, 3)`` float64 world space, ``faces (m, 3)`` int64,
    ``normals (n, 3)`` per-vertex unit normals (for smooth shading), and the group's name."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (the sum of the unnormalized face normals around each vertex)."""
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    vn = np.zeros_like(v)
    for k in range(3):
        np.add.at(vn, f[:, k], fn)
    length = np.linalg.norm(vn, axis=1, keepdims=True)
    return np.where(length > 0, vn / np.where(length > 0, length, 1.0), np.array([0.0, 0.0, 1.0]))


def check_triangles(vertices: np.ndarray, faces: np.ndarray, where: str) -> None:
    """Raise :class:`SceneError` (prefixed with ``where``) for arrays a renderer cannot use."""
    if faces.size == 0 or vertices.size == 0:
        raise SceneError(f"{where}: the mesh has no triangles")
    if not np.all(np.isfinite(vertices)):
        bad = int(np.count_nonzero(~np.all(np.isfinite(vertices), axis=1)))
        raise SceneError(f"{where}: {bad} vertex/vertices are NaN or infinite")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise SceneError(f"{where}: a face refers to a vertex that does not exist")


def apply_transform(vertices: np.ndarray, transform: Transform) -> np.ndarray:
    m = np.asarray(transform.matrix())
    return vertices @ m[:3, :3].T + m[:3, 3]


def load_mesh_file(path: Path, transform: Transform | None = None, where: str = "mesh") -> list[MeshPart]:
    """Read ``path`` into triangle groups in world space; raises :class:`SceneError` naming ``where``."""
    import trimesh

    try:
        check_input_size(path, MAX_MESH_BYTES, "mesh file", SceneError)
    except OSError:
        raise SceneError(f"{where}: file '{path}' not found") from None
    except SceneError as exc:
        raise SceneError(f"{where}: {exc}") from None
    try:
        loaded = trimesh.load_scene(
            str(path), split_objects=True, split_groups=True, group_material=False, process=False
        )
        geoms = loaded.dump(concatenate=False)
    except Exception as exc:  # trimesh raises many kinds; all mean "cannot read this file"
        raise SceneError(f"{where}: cannot read '{path.name}': {exc}") from None
    parts: list[MeshPart] = []
    for g in geoms:
        if not hasattr(g, "faces") or len(g.faces) == 0:
            continue  # point clouds and paths carry no surface
        v = np.asarray(g.vertices, dtype=np.float64)
        f = np.asarray(g.faces, dtype=np.int64)
        name = str(g.metadata.get("name") or g.metadata.get("node") or "")
        check_triangles(v, f, f"{where} ('{path.name}', group '{name}')" if name else where)
        if transform is not None:
            v = apply_transform(v, transform)
        area2 = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
        f = f[area2 > 0.0]  # degenerate triangles have no normal and are invisible anyway
        if len(f) == 0:
            continue
        parts.append(MeshPart(name, v, f, _vertex_normals(v, f)))
    if not parts:
        raise SceneError(f"{where}: '{path.name}' holds no triangles (an empty mesh)")
    return parts
