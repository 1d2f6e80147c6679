"""``exclude_groups``: the groups a mesh entry leaves out are not in the world; unknown names are errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from core.scene import SceneError
from renderer.world import World
from tests.renderer.scenes import make_scene

# Three groups of different sizes, so that the triangle count says which ones were dropped.
THREE_GROUPS = (
    "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
    "o b\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 4 5 6\nf 4 6 7\n"
    "o c\nv 0 0 2\nv 1 0 2\nv 1 1 2\nv 0 1 2\nv 0.5 2 2\nf 8 9 10\nf 8 10 11\nf 11 10 12\n"
)


def _scene(folder: Path, mesh: dict, version: int = 2):
    (folder / "three.obj").write_text(THREE_GROUPS)
    return make_scene(
        folder,
        {
            "version": version,
            "materials": [
                {"name": "m0", "model": "lambert", "params": {"kd": 0.5}},
                {"name": "m1", "model": "lambert", "params": {"kd": 0.2}},
            ],
            "meshes": [{"path": "three.obj", "material": "m0", **mesh}],
            "lights": [{"type": "point", "position": [0, 3, 0], "intensity": 1.0}],
        },
    )


def test_excluded_groups_are_not_in_the_world(tmp_path: Path) -> None:
    full = World(_scene(tmp_path, {}))
    assert full.n_triangles == 1 + 2 + 3
    without_b = World(_scene(tmp_path, {"exclude_groups": ["b"], "group_materials": {"c": "m1"}}))
    assert without_b.n_triangles == 1 + 3
    z = without_b.v0[:, 2]
    assert sorted(set(z.tolist())) == [0.0, 2.0]  # group b lies in the plane z = 1
    assert without_b.tri_material[z == 2].tolist() == [1, 1, 1]  # the others keep their materials
    only_a = World(_scene(tmp_path, {"exclude_groups": ["b", "c"]}))
    assert only_a.n_triangles == 1


def test_unknown_excluded_group_names_the_group_and_the_file(tmp_path: Path) -> None:
    scene = _scene(tmp_path, {"exclude_groups": ["b", "wheel"]})
    with pytest.raises(SceneError) as info:
        World(scene)
    message = str(info.value)
    assert message.startswith("test.json: meshes[0].exclude_groups: ")
    assert "'wheel'" in message and "three.obj" in message and "'a', 'b', 'c'" in message


def test_excluding_every_group_leaves_no_geometry(tmp_path: Path) -> None:
    scene = _scene(tmp_path, {"exclude_groups": ["a", "b", "c"]})
    scene.lights.clear()
    with pytest.raises(SceneError, match="no geometry"):
        World(scene)
