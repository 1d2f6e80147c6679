"""Regenerate the demo scene's meshes and environment map (run from anywhere):

    python resources/scenes/demo/make_demo.py

Writes small OBJ/PLY meshes (a floor, spheres, a torus, a box) and ``sky.exr``, a procedural 128 x 64 HDR
lat-long sky (blue zenith, bright horizon, dark ground, a small sun). ``demo.json`` refers to them and to the
synthetic measured material ``resources/materials/red_plastic_ct.binary``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


def sky(width: int = 128, height: int = 64) -> np.ndarray:
    """Lat-long radiance: row 0 is the zenith (+y); phi = atan2(z, x) grows with the column."""
    theta = (np.arange(height) + 0.5) / height * math.pi
    phi = (np.arange(width) + 0.5) / width * 2.0 * math.pi
    T, P = np.meshgrid(theta, phi, indexing="ij")
    up = np.cos(T)
    zenith = np.array([0.25, 0.45, 1.0])
    horizon = np.array([1.1, 1.05, 0.95])
    ground = np.array([0.18, 0.15, 0.12])
    t = np.clip(up, 0.0, 1.0)[..., None] ** 0.5
    img = np.where(up[..., None] > 0, horizon * (1 - t) + zenith * t, ground)
    sun_dir = np.array([math.cos(math.radians(35)) * math.cos(math.radians(60)), math.sin(math.radians(35)),
                        math.cos(math.radians(35)) * math.sin(math.radians(60))])  # fmt: skip
    d = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], axis=-1)
    sun = (d @ sun_dir) > math.cos(math.radians(4.0))
    img[sun] = np.array([60.0, 55.0, 45.0])
    return img.astype(np.float32)


def main() -> None:
    import trimesh

    from renderer.image_io import write_exr

    s = 40.0  # wide enough that its edge lies near the horizon
    floor_v = np.array([[-s, 0, -s], [s, 0, -s], [s, 0, s], [-s, 0, s]], dtype=float)
    write_obj(HERE / "floor.obj", floor_v, np.array([[0, 2, 1], [0, 3, 2]]))
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    ball.export(HERE / "sphere.ply")
    torus = trimesh.creation.torus(major_radius=0.42, minor_radius=0.16, major_sections=48, minor_sections=16)
    write_obj(HERE / "torus.obj", torus.vertices, torus.faces)
    box = trimesh.creation.box(extents=(0.7, 0.7, 0.7))
    write_obj(HERE / "box.obj", box.vertices, box.faces)
    write_exr(HERE / "sky.exr", sky())


if __name__ == "__main__":
    main()
