"""Mitsuba 3's Cornell box (``mitsuba.cornell_box()``) as one of our scene files, for cross-checks.

Mitsuba is an optional, test-only dependency: it is imported lazily, and only here. Rectangles become two
triangles (keeping the side the emitter faces), merged meshes are exported as they are, diffuse reflectances
become Lambert materials, the area emitter an emissive material, and the sensor our pinhole camera.
Mitsuba counts path *vertices* in ``max_depth``; we count bounces, so its ``max_depth`` is ours + 1.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np


def cornell_dict(
    size: int, bounces: int, variant: str = "scalar_rgb", sampler: str | None = None
) -> dict[str, Any]:
    """Mitsuba's Cornell box at ``size x size`` with a box pixel filter and ``bounces`` bounces; ``sampler``
    replaces its sample generator (``independent`` by default; e.g. ``ldsampler``, ``multijitter``)."""
    import mitsuba as mi

    mi.set_variant(variant)
    d = mi.cornell_box()
    d["sensor"]["film"].update(width=size, height=size, rfilter={"type": "box"})
    if sampler is not None:
        d["sensor"]["sampler"]["type"] = sampler
    d["integrator"] = {"type": "path", "max_depth": bounces + 1}
    return d


def _write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    path.write_text("\n".join(lines) + "\n")


def export_cornell_box(folder: Path, size: int, bounces: int) -> Path:
    """Write ``cornell.json`` and its OBJ meshes into ``folder``; returns the scene file's path."""
    import mitsuba as mi

    d = cornell_dict(size, bounces)
    scene = mi.load_dict(d)
    materials: list[dict[str, Any]] = []
    meshes = []
    for k, shape in enumerate(scene.shapes()):
        p = mi.traverse(shape)
        rgb = [float(x) for x in np.array(p["bsdf.reflectance.value"]).ravel()[:3]]
        emit = [0.0, 0.0, 0.0]
        if "emitter.radiance.value" in p.keys():
            emit = [float(x) for x in np.array(p["emitter.radiance.value"]).ravel()[:3]]
        if "vertex_positions" in p.keys():
            v = np.array(p["vertex_positions"], dtype=float).reshape(-1, 3)
            f = np.array(p["faces"], dtype=np.int64).reshape(-1, 3)
        else:  # a rectangle: [-1, 1]^2 at z = 0, normal +z, mapped by to_world
            m = np.array(p["to_world"].matrix, dtype=float)
            local = np.array([[-1, -1, 0, 1], [1, -1, 0, 1], [1, 1, 0, 1], [-1, 1, 0, 1]], dtype=float)
            v = (local @ m.T)[:, :3]
            f = np.array([[0, 1, 2], [0, 2, 3]])
            n_world = np.linalg.inv(m[:3, :3]).T @ np.array([0.0, 0.0, 1.0])
            if np.dot(np.cross(v[1] - v[0], v[2] - v[0]), n_world) < 0:  # keep the emitting side
                f = f[:, ::-1]
        name = f"mat{k}"
        materials.append({"name": name, "model": "lambert", "params": {"kd": rgb}, "emission": emit})
        _write_obj(folder / f"shape{k}.obj", v, f)
        meshes.append({"path": f"shape{k}.obj", "material": name})
    sensor = scene.sensors()[0]
    m = np.array(mi.traverse(sensor)["to_world"].matrix, dtype=float)
    pos = m[:3, 3]
    fwd = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
    up = m[:3, :3] @ np.array([0.0, 1.0, 0.0])
    data = {
        "version": 1,
        "name": "Mitsuba 3 Cornell box",
        "camera": {
            "position": pos.tolist(),
            "target": (pos + fwd).tolist(),
            "up": up.tolist(),
            "fov_deg": float(d["sensor"]["fov"]),
        },  # fmt: skip
        "materials": materials,
        "meshes": meshes,
        "render": {"width": size, "height": size, "max_depth": bounces, "rr_depth": 5, "sampler": "cosine"},
    }
    path = folder / "cornell.json"
    path.write_text(json.dumps(data))
    return path
