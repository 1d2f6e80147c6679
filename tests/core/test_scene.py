"""The scene file: round trip, and every kind of bad file gives an error naming the file and the field."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from core.errors import FormerSamplerName
from core.scene import Scene, SceneError, load_scene, save_scene, scene_digest, scene_from_dict


def _write(folder: Path, data: object, name: str = "scene.json") -> Path:
    p = folder / name
    p.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return p


def _base(tmp_path: Path) -> dict:
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    return {
        "version": 1,
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 40},
        "materials": [
            {"name": "white", "model": "lambert", "params": {"kd": 0.5}},
            {"name": "lamp", "model": "lambert", "params": {"kd": 0.0}, "emission": 4.0},
        ],
        "meshes": [{"path": "tri.obj", "material": "white"}],
        "lights": [
            {"type": "point", "position": [0, 2, 0], "intensity": [1, 2, 3]},
            {"type": "quad", "corner": [0, 2, 0], "edge1": [1, 0, 0], "edge2": [0, 0, 1], "radiance": 5},
        ],
        "environment": {"type": "constant", "radiance": [0.1, 0.2, 0.3]},
        "render": {"width": 16, "height": 8, "spp": 4, "sampler": "cosine"},
    }


def test_valid_scene_loads_and_round_trips(tmp_path: Path) -> None:
    p = _write(tmp_path, _base(tmp_path))
    scene = load_scene(p)
    assert scene.materials[1].emission == (4.0, 4.0, 4.0)  # one number means grey
    assert scene.resolve("tri.obj") == tmp_path.resolve() / "tri.obj"
    out = tmp_path / "copy.json"
    save_scene(scene, out)
    again = load_scene(out)
    assert again.model_dump() == scene.model_dump()
    assert not list(tmp_path.glob(".copy.json.*"))  # the atomic write left no temporary file


def test_digest_follows_the_scene_its_files_and_the_extra_values(tmp_path: Path) -> None:
    """The key of a cached render changes with a setting, an extra value or a byte of a mesh file, and only
    then (a saved copy of the same scene has the same key)."""
    scene = load_scene(_write(tmp_path, _base(tmp_path)))
    key = scene_digest(scene, 256, 16)
    assert scene_digest(scene, 256, 16) == key
    save_scene(scene, tmp_path / "copy.json")
    assert scene_digest(load_scene(tmp_path / "copy.json"), 256, 16) == key
    assert scene_digest(scene, 256, 32) != key
    data = _base(tmp_path)
    data["render"]["spp"] = 8
    assert scene_digest(load_scene(_write(tmp_path, data, "other.json")), 256, 16) != key
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n")
    assert scene_digest(scene, 256, 16) != key


def test_transform_matrix_rotates_then_translates() -> None:
    from core.scene import Transform

    m = Transform(translate=(1, 2, 3), rotate_deg=(0, 0, 90), scale=2.0).matrix()
    # (1, 0, 0) scaled by 2 -> (2, 0, 0), rotated 90 deg about z -> (0, 2, 0), translated -> (1, 4, 3)
    x = [sum(m[i][j] * v for j, v in enumerate((1.0, 0.0, 0.0, 1.0))) for i in range(3)]
    assert x == pytest.approx([1.0, 4.0, 3.0])


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (lambda d: d["materials"][0]["params"].update(kd=2.0), "materials[0].params.kd"),
        (lambda d: d["materials"][0]["params"].update(shininess=3), "materials[0].params.shininess"),
        (lambda d: d["materials"][1].update(model="no-such-model"), "materials[1].model: unknown model"),
        (lambda d: d["materials"][1].update(name="white"), "materials[1].name"),
        (lambda d: d["materials"][0].update(colour=1), "materials[0].colour: unknown field"),
        (lambda d: d["materials"][0].update(measured="x.binary"), "materials[0]: give either"),
        (lambda d: d["meshes"][0].update(path="missing.obj"), "meshes[0].path: file 'missing.obj' not found"),
        (lambda d: d["meshes"][0].update(path="tri.xyz"), "meshes[0].path: 'tri.xyz' has an unsupported"),
        (lambda d: d["meshes"][0].update(material="gold"), "meshes[0].material: no material named 'gold'"),
        (lambda d: d["meshes"][0].update(group_materials={"g": "x"}), "meshes[0].group_materials.g"),
        (
            lambda d: d["lights"][0].update(intensity=[1, -1, 1]),
            "lights[0].intensity[1]: Input should be greater than or equal to 0",
        ),
        (lambda d: d["lights"][1].update(edge2=[2, 0, 0]), "lights[1]: edge1 and edge2 span no area"),
        (lambda d: d["lights"].append({"type": "spot"}), "lights[2]"),
        (
            lambda d: d.update(environment={"type": "map", "path": "sky.exr"}),
            "environment.path: file 'sky.exr'",
        ),
        (lambda d: d["camera"].update(fov_deg=180), "camera.fov_deg"),
        (lambda d: d["camera"].update(target=[0, 0, 3]), "camera.target"),
        (lambda d: d["camera"].update(up=[0, 0, 1]), "camera.up"),
        (lambda d: d["render"].update(sampler="magic"), "render.sampler: unknown sampler 'magic'"),
        (lambda d: d["render"].update(spp=0), "render.spp"),
        (
            lambda d: d["lights"][0].update(intensity=1e308),
            "lights[0].intensity[0]: Input should be less than",
        ),
        (lambda d: d["lights"][1].update(radiance=[1, 1e10, 1]), "lights[1].radiance[1]"),
        (lambda d: d["lights"][0].update(position=[0, 1e300, 0]), "lights[0].position[1]"),
        (lambda d: d["materials"][1].update(emission=1e308), "materials[1].emission[0]"),
        (lambda d: d.update(environment={"type": "constant", "radiance": 1e308}), "environment.radiance[0]"),
        (lambda d: d["meshes"][0].update(transform={"translate": [1e300, 0, 0]}), "transform.translate[0]"),
        (lambda d: d["meshes"][0].update(transform={"scale": 1e200}), "meshes[0].transform.scale"),
        (lambda d: d["meshes"][0].update(transform={"scale": 1e-300}), "meshes[0].transform.scale"),
        (lambda d: d["meshes"][0].update(transform={"rotate_deg": [1e300, 0, 0]}), "transform.rotate_deg[0]"),
        (lambda d: d["camera"].update(position=[0, 0, 1e300]), "camera.position[2]"),
        (
            lambda d: d["render"].update(spp=10**20),
            "render.spp: Input should be less than or equal to 1000000",
        ),
        (lambda d: d["render"].update(time_s=1e300), "render.time_s"),
        (lambda d: d["render"].update(seed=-1), "render.seed"),
        (lambda d: d["render"].update(seed=2**70), "render.seed"),
        (lambda d: d["render"].update(rr_depth=10**9), "render.rr_depth"),
        (
            lambda d: d["render"].update(sampler_options={"n_max": 0.5}),
            "render.sampler_options: the sampler 'cosine' takes no options, got 'n_max'",
        ),
        (
            lambda d: d["render"].update(sampler="adaptive_exact", sampler_options={"m_theta": 0}),
            "render.sampler_options: the sampler 'adaptive_exact' has no option 'm_theta'; its options: ",
        ),
        (
            lambda d: d["render"].update(
                sampler="adaptive_exact", sampler_options={"min_spacing_deg": float("nan")}
            ),
            "option 'min_spacing_deg' of the sampler 'adaptive_exact' must be a number in [0.001, 10], got nan",
        ),
        (
            lambda d: d["render"].update(sampler="adaptive_warp", sampler_options={"cache": 5}),
            "option 'cache' of the sampler 'adaptive_warp' must be true, false or a folder, got 5",
        ),
        (
            lambda d: d.update(
                name=[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]
            ),
            "nested too",
        ),
        (lambda d: d.pop("version"), "version: required"),
        (lambda d: d.update(version=99), "version: schema version 99"),
    ],
)
def test_bad_field_is_named(tmp_path: Path, edit, expected: str) -> None:
    data = _base(tmp_path)
    edit(data)
    p = _write(tmp_path, data)
    with pytest.raises(SceneError) as info:
        load_scene(p)
    message = str(info.value)
    assert message.startswith("scene.json: ")
    assert expected in message


def test_nan_parameter_is_rejected(tmp_path: Path) -> None:
    # json.dumps writes NaN as a bare token, which Python's json (and hand-edited files) accept
    data = _base(tmp_path)
    data["materials"][0]["params"]["kd"] = float("nan")
    with pytest.raises(SceneError, match=r"materials\[0\]\.params\.kd: .*finite"):
        load_scene(_write(tmp_path, data))


def test_json_nested_deeper_than_the_interpreter_recurses_is_refused(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="scene.json: the JSON is nested too deeply"):
        load_scene(_write(tmp_path, "[" * 100_000 + "]" * 100_000))


def test_broken_json_gives_line_and_column(tmp_path: Path) -> None:
    p = _write(tmp_path, '{\n  "version": 1,\n  "camera": {,}\n}')
    with pytest.raises(SceneError, match=r"scene\.json: line 3, column 14: invalid JSON"):
        load_scene(p)


@pytest.mark.parametrize("content", ["[1, 2]", "42", '"scene"'])
def test_non_object_json(tmp_path: Path, content: str) -> None:
    with pytest.raises(SceneError, match="JSON object"):
        load_scene(_write(tmp_path, content))


def test_missing_scene_file(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="scene file not found"):
        load_scene(tmp_path / "nope.json")


def test_files_need_not_exist_when_not_checked(tmp_path: Path) -> None:
    data = _base(tmp_path)
    data["meshes"][0]["path"] = "later.obj"
    scene = scene_from_dict(data, "draft.json", base_dir=tmp_path, check_files=False)
    assert scene.meshes[0].path == "later.obj"


def test_default_scene_is_valid_data() -> None:
    scene = Scene()
    again = scene_from_dict(scene.model_dump(mode="json"), check_files=False)
    assert again == scene


# ---- version 2: exclude_groups, and version-1 files still load ---------------------------------------


def test_version_1_file_loads_and_is_saved_as_the_current_version(tmp_path: Path) -> None:
    from core.scene import SCENE_VERSION

    data = _base(tmp_path)
    assert data["version"] == 1
    scene = load_scene(_write(tmp_path, data))
    assert scene.meshes[0].exclude_groups == []
    out = tmp_path / "copy.json"
    save_scene(scene, out)
    assert json.loads(out.read_text())["version"] == SCENE_VERSION == 2


def test_exclude_groups_round_trip(tmp_path: Path) -> None:
    data = _base(tmp_path)
    data["version"] = 2
    data["meshes"][0]["exclude_groups"] = ["wheel", "door"]
    scene = load_scene(_write(tmp_path, data))
    assert scene.meshes[0].exclude_groups == ["wheel", "door"]
    save_scene(scene, tmp_path / "copy.json")
    assert load_scene(tmp_path / "copy.json").meshes[0].exclude_groups == ["wheel", "door"]


@pytest.mark.parametrize(
    ("version", "groups", "expected"),
    [
        (1, ["wheel"], r"meshes\[0\]\.exclude_groups: needs scene version 2"),
        (2, ["wheel", "wheel"], r"meshes\[0\]\.exclude_groups: group 'wheel' is listed twice"),
        (2, "wheel", r"meshes\[0\]\.exclude_groups: Input should be a valid list"),
        (2, [3], r"meshes\[0\]\.exclude_groups\[0\]: Input should be a valid string"),
    ],
)
def test_bad_exclude_groups_are_named(tmp_path: Path, version: int, groups, expected: str) -> None:
    data = _base(tmp_path)
    data["version"] = version
    data["meshes"][0]["exclude_groups"] = groups
    with pytest.raises(SceneError, match=expected):
        load_scene(_write(tmp_path, data))


def test_kept_groups_checks_names_against_the_file(tmp_path: Path) -> None:
    from core.scene import kept_groups

    data = _base(tmp_path)
    data["version"] = 2
    data["meshes"][0]["exclude_groups"] = ["b"]
    scene = load_scene(_write(tmp_path, data))
    assert kept_groups(scene, 0, ["a", "b", "c", "b"]) == [True, False, True, False]
    with pytest.raises(SceneError, match=r"scene\.json: meshes\[0\]\.exclude_groups: 'tri\.obj' has no group "
                       r"named 'b' \(its groups: 'x', 'y'\)"):  # fmt: skip
        kept_groups(scene, 0, ["y", "x"])


# ---- one item at a time (what the app validates an edit with) ----------------------------------------


def test_parse_items_accept_valid_data(tmp_path: Path) -> None:
    from core.scene import parse_camera, parse_environment, parse_light

    quad = parse_light({"type": "quad", "corner": [0, 1, 0], "edge1": [1, 0, 0], "edge2": [0, 0, 1],
                        "radiance": 2})  # fmt: skip
    assert quad.radiance == (2.0, 2.0, 2.0)
    assert parse_camera({"position": [0, 0, 5], "fov_deg": 30}).fov_deg == 30.0
    (tmp_path / "sky.exr").write_bytes(b"")
    env = parse_environment({"type": "map", "path": str(tmp_path / "sky.exr"), "rotate_deg": 90})
    assert env.rotate_deg == 90.0


@pytest.mark.parametrize(
    ("kind", "data", "expected"),
    [
        ("light", {"type": "point", "position": [0, 1, 0], "intensity": [1, -1, 1]},
         "lights[0].intensity[1]: Input should be greater than or equal to 0"),
        ("light", {"type": "point", "position": [0, float("nan"), 0], "intensity": 1},
         "lights[0].position[1]: Input should be a finite number"),
        ("light", {"type": "quad", "corner": [0, 1, 0], "edge1": [1, 0, 0], "edge2": [2, 0, 0], "radiance": 1},
         "lights[0]: edge1 and edge2 span no area"),
        ("light", {"type": "spot", "position": [0, 0, 0]}, "lights[0]: "),
        ("camera", {"position": [0, 0, 0], "target": [0, 0, 0]}, "camera.target: the target coincides"),
        ("camera", {"up": [0, 0, 1], "position": [0, 0, 4]}, "camera.up: the up vector is zero or parallel"),
        ("camera", {"fov_deg": 0}, "camera.fov_deg: Input should be greater than 0"),
        ("environment", {"type": "constant", "radiance": -1}, "environment.radiance[0]: Input should be"),
        ("environment", {"type": "map", "path": "/nowhere/sky.exr"}, "environment.path: file '/nowhere/sky.exr' not"),
        ("environment", {"type": "map", "path": "sky.png"}, "environment.path: 'sky.png' has an unsupported"),
        ("environment", {"type": "map", "path": "x.exr", "scale": -1}, "environment.scale: Input should be"),
    ],
)  # fmt: skip
def test_parse_items_name_the_field(kind: str, data: dict, expected: str) -> None:
    from core.scene import parse_camera, parse_environment, parse_light

    parse = {"light": lambda d: parse_light(d, "lights[0]"), "camera": parse_camera,
             "environment": parse_environment}[kind]  # fmt: skip
    with pytest.raises(SceneError) as info:
        parse(data)
    assert str(info.value).startswith(expected)


def test_a_scene_naming_the_former_sampler_adaptive_loads_as_adaptive_exact_with_a_notice(
    tmp_path: Path,
) -> None:
    data = _base(tmp_path)
    data["render"].update(sampler="adaptive", sampler_options={"n_max": 3})
    with pytest.warns(FormerSamplerName, match="'adaptive' is a former name of the sampler 'adaptive_exact'"):
        scene = load_scene(_write(tmp_path, data))
    assert scene.render.sampler == "adaptive_exact" and scene.render.sampler_options == {"n_max": 3}
    data["render"].update(sampler="adaptive", sampler_options={"mode": "warp"})
    with pytest.warns(
        FormerSamplerName, match="'adaptive' with mode='warp' is a former name of the sampler 'adaptive_warp'"
    ):
        scene = load_scene(_write(tmp_path, data))
    assert scene.render.sampler == "adaptive_warp" and scene.render.sampler_options == {}
