"""Mesh loading: groups with their own materials, transforms, and clear errors for unusable meshes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.scene import SceneError, Transform
from renderer.mesh import load_mesh_file
from renderer.world import World
from tests.renderer.scenes import make_scene, write_obj

TRI = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def test_obj_groups_and_transform(tmp_path: Path) -> None:
    p = tmp_path / "two.obj"
    p.write_text("o left\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no right\nv 5 0 0\nv 6 0 0\nv 5 1 0\nf 4 5 6\n")
    parts = load_mesh_file(p, Transform(translate=(0, 0, 2), scale=2.0))
    by_name = {q.name: q for q in parts}
    assert set(by_name) == {"left", "right"}
    assert np.allclose(by_name["right"].vertices.min(axis=0), [10.0, 0.0, 2.0])
    assert np.allclose(by_name["left"].normals, [0.0, 0.0, 1.0])


@pytest.mark.parametrize("fmt", ["ply", "stl", "off", "glb"])
def test_other_formats_load(tmp_path: Path, fmt: str) -> None:
    import trimesh

    trimesh.creation.box().export(tmp_path / f"box.{fmt}")
    parts = load_mesh_file(tmp_path / f"box.{fmt}")
    assert sum(len(q.faces) for q in parts) == 12
    v = np.concatenate([q.vertices for q in parts])
    assert np.allclose(np.abs(v), 0.5)


def test_empty_mesh_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "empty.obj").write_text("# nothing here\n")
    with pytest.raises(SceneError, match="no triangles"):
        load_mesh_file(tmp_path / "empty.obj", where="scene.json: meshes[0].path")


def test_nan_vertices_are_an_error(tmp_path: Path) -> None:
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(SceneError, match="NaN or infinite"):
        load_mesh_file(tmp_path / "nan.obj")


def test_garbage_file_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "junk.ply").write_bytes(b"\x00\x01 not a ply file at all")
    with pytest.raises(SceneError, match="junk.ply"):
        load_mesh_file(tmp_path / "junk.ply")


def test_world_names_the_mesh_at_fault(tmp_path: Path) -> None:
    write_obj(tmp_path / "ok.obj", TRI, np.array([[0, 1, 2]]))
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n")
    scene = make_scene(
        tmp_path,
        {
            "materials": [{"name": "m", "model": "lambert"}],
            "meshes": [{"path": "ok.obj", "material": "m"}, {"path": "bad.obj", "material": "m"}],
        },
    )
    with pytest.raises(SceneError, match=r"test\.json: meshes\[1\]\.path"):
        World(scene)


def test_group_materials_assign_per_group(tmp_path: Path) -> None:
    p = tmp_path / "two.obj"
    p.write_text("o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n")
    scene = make_scene(
        tmp_path,
        {
            "materials": [
                {"name": "m0", "model": "lambert"},
                {"name": "m1", "model": "lambert", "emission": 2.0},
            ],
            "meshes": [{"path": "two.obj", "material": "m0", "group_materials": {"b": "m1"}}],
        },
    )
    w = World(scene)
    z = w.v0[:, 2]
    assert w.tri_material[z == 0].tolist() == [0] and w.tri_material[z == 1].tolist() == [1]
    assert w.tri_emissive.tolist() == (z == 1).tolist()
