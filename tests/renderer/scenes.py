"""Small scenes for the renderer tests, written to a temporary folder."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from core.scene import Scene, scene_from_dict


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> Path:
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def sphere(path: Path, subdivisions: int = 3) -> Path:
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    return write_obj(path, m.vertices, m.faces)


def quad(path: Path, size: float = 1.0, y: float = 0.0) -> Path:
    """A square in the plane y = ``y``, normal +y."""
    s = size
    v = np.array([[-s, y, -s], [s, y, -s], [s, y, s], [-s, y, s]], dtype=float)
    return write_obj(path, v, np.array([[0, 2, 1], [0, 3, 2]]))


def make_scene(folder: Path, data: dict[str, Any]) -> Scene:
    base: dict[str, Any] = {"version": 1}
    base.update(data)
    return scene_from_dict(base, "test.json", base_dir=folder)
