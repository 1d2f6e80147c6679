"""Every input a user can give gets a clear answer (issue 18): a generated corpus of bad inputs swept over every
command, scene field, MERL header and mesh file.

A bad input must end with exit code 2 and one line ``brdf-studio COMMAND: error: ...`` on stderr that names
no Python exception and shows no traceback; a scene that validation lets through must render (exit 0) to a
finite image. Run in-process through ``app.cli.main`` (the console script's code path); the generated scene,
MERL and mesh corpora use hypothesis with a fixed derandomized seed, a small set here and a larger one under
``-m slow``.
"""

from __future__ import annotations

import json
import os
import re
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from tests.renderer.scenes import quad, sphere

EXCEPTION_NAME = re.compile(r"\b[A-Z][A-Za-z]*(Error|Exception|Warning|Interrupt)\b|Traceback|internal error")

BAD_NUMBERS = ["nan", "inf", "-inf", "1e308", "-1e308", "1e400", "x", "", "0x10", "1e20", "-1e20"]
BAD_NAMES = ["nope", "", " ", "../../etc/passwd", "a" * 300, "adaptive;rm"]
BAD_ANGLE_PAIRS = ["nan,0", "0,inf", "91,0", "1e308,0", "x", "", ",", "0,0,0", "-1,0"]
BAD_PARAMS = ["kd=nan", "kd=1e308", "kd", "=1", "zz=1", "kd=1,2", "kd=-1", "kd=x", "kd=inf"]


@pytest.fixture(autouse=True)
def _machine_of_4_gib(monkeypatch):
    """Budget refusals must not depend on the machine running the tests."""
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(4 << 30))


def run_cli(capsys, argv: list[str]) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def problem(command: str, code: int, err: str) -> str | None:
    """What is wrong with the answer to a bad input (``None``: a clear one)."""
    lines = err.strip().splitlines()
    if code != 2:
        return f"exit code {code}"
    if len(lines) != 1:
        return f"{len(lines)} lines on stderr"
    if not lines[0].startswith(f"brdf-studio {command}: error: "):
        return "not a 'brdf-studio COMMAND: error:' line"
    if EXCEPTION_NAME.search(lines[0]):
        return "names a Python exception"
    return None


def sweep(capsys, command: str, cases: list[list[str]]) -> None:
    """Run every case; fail once, listing every case whose answer is not a clear one."""
    failures = []
    for argv in cases:
        code, _, err = run_cli(capsys, argv)
        why = problem(command, code, err)
        if why:
            failures.append(f"{' '.join(argv)!r}: {why}: {err.strip()[:300]!r}")
    assert not failures, f"{len(failures)} of {len(cases)} bad inputs:\n" + "\n".join(failures)


def substitute(base: list[str], option: str, values: list[str]) -> list[list[str]]:
    """``base`` with ``option``'s value replaced by (or, if absent, ``option`` added with) each of ``values``."""
    out = []
    for v in values:
        argv = list(base)
        if option in argv:
            argv[argv.index(option) + 1] = v
        else:
            argv += [option, v]
        out.append(argv)
    return out


# ------------------------------------------------------------------------------------------- the commands
EVAL = ["eval", "--model", "lambert", "--wi", "30,0", "--wo", "30,0"]
ALBEDO = ["albedo", "--model", "lambert", "--theta", "30"]
CHECK = ["check", "--model", "lambert", "--sampler", "cosine", "--theta", "30", "--samples", "1000"]


def corpus_eval(tmp_path: Path) -> list[list[str]]:
    cases = [*substitute(EVAL, "--wi", BAD_ANGLE_PAIRS), *substitute(EVAL, "--wo", BAD_ANGLE_PAIRS)]
    cases += substitute(EVAL, "--model", BAD_NAMES) + substitute(EVAL, "--param", BAD_PARAMS)
    cases += [["eval", "--wi", "0,0", "--wo", "0,0"], [*EVAL, "--measured", "x.binary"], [*EVAL, "--bogus"]]
    return cases


def corpus_albedo(tmp_path: Path) -> list[list[str]]:
    cases = [*substitute(ALBEDO, "--theta", BAD_NUMBERS), *substitute(ALBEDO, "--phi", BAD_NUMBERS)]
    cases += substitute(ALBEDO, "--rtol", [*BAD_NUMBERS, "0", "1", "-0.5"])
    cases += substitute(ALBEDO, "--param", BAD_PARAMS) + substitute(ALBEDO, "--model", BAD_NAMES)
    cases += [
        ["albedo", "--measured", str(tmp_path)],
        ["albedo", "--measured", str(tmp_path / "none.binary")],
    ]
    cases += [[*ALBEDO[:-1], "30,", ","], ["albedo", "--model", "lambert", "--theta"]]
    return cases


def corpus_sample(tmp_path: Path) -> list[list[str]]:
    base = ["sample", "--model", "lambert", "--sampler", "cosine", "--theta", "30", "-n", "10"]
    base += ["-o", str(tmp_path / "x.csv")]
    cases = [*substitute(base, "--theta", BAD_NUMBERS), *substitute(base, "--phi", BAD_NUMBERS)]
    cases += substitute(base, "-n", [*BAD_NUMBERS, "0", "-5", "2.5", "1e16"])
    cases += substitute(base, "--seed", [*BAD_NUMBERS, "-1", "4294967296"])
    cases += substitute(base, "--n-max", [*BAD_NUMBERS, "1", "0.5", "1001"])
    cases += substitute(base, "--sampler", BAD_NAMES)
    folder = tmp_path / "folder.csv"
    folder.mkdir(exist_ok=True)
    outs = [str(tmp_path), str(folder), str(tmp_path / "no" / "x.csv"), "x.txt", "", str(tmp_path / "x")]
    cases += substitute(base, "-o", outs)
    # the budget: a request this large is refused before any work, naming the need
    cases += substitute(base, "-n", ["1e15"])
    cases += [[*base[:-2], "--n-max", "3", "-o", str(tmp_path / "y.csv")]]  # n_max: cosine takes no options
    return cases


def corpus_check(tmp_path: Path) -> list[list[str]]:
    cases = [*substitute(CHECK, "--theta", BAD_NUMBERS), *substitute(CHECK, "--phi", BAD_NUMBERS)]
    cases += substitute(CHECK, "--samples", [*BAD_NUMBERS, "0", "1e13", "2.5"])
    cases += substitute(CHECK, "--seed", ["-1", "nan", "1e300"])
    cases += substitute(CHECK, "--n-max", ["1", "nan", "0.5", "1e308"]) + substitute(
        CHECK, "--sampler", BAD_NAMES
    )
    cases += [[*CHECK, "--n-max", "2"], [*CHECK, "--theta", "0", "30", "95"], [*CHECK, "--theta", ",,"]]
    return cases


def corpus_bench(tmp_path: Path) -> list[list[str]]:
    base = ["bench", "samplers", "--quick", "--out", str(tmp_path / "study")]
    cases = substitute(base, "--theta", BAD_NUMBERS) + substitute(base, "--models", ["nope", ",,"])
    return cases + substitute(base, "--samplers", ["nope", ",,"]) + [["bench", "nope"], ["bench"]]


def corpus_demo(tmp_path: Path) -> list[list[str]]:
    return [["demo", "--material", m] for m in ("nope", "", "a" * 300)]


def corpus_models(tmp_path: Path) -> list[list[str]]:
    return [["models", "--bogus"], ["models", "extra"]]


def corpus_fit(tmp_path: Path) -> list[list[str]]:
    from resources.materials import demo_materials

    merl = next(m["measured"] for m in demo_materials() if "measured" in m)
    base = ["fit", "--measured", str(merl), "--model", "phong"]
    cases = substitute(base, "--starts", [*BAD_NUMBERS, "0", "101"])
    cases += substitute(base, "--seed", [*BAD_NUMBERS, "-1"]) + substitute(base, "--fix", BAD_PARAMS)
    cases += substitute(base, "--model", [*BAD_NAMES, "merl"]) + substitute(base, "--metric", ["x", ""])
    cases += substitute(base, "--measured", [str(tmp_path), str(tmp_path / "none.binary"), "x.txt"])
    folder = tmp_path / "fit_folder.json"
    folder.mkdir(exist_ok=True)
    return cases + substitute(
        base, "--out", [str(tmp_path), str(folder), str(tmp_path / "no" / "x.json"), ""]
    )


def corpus_export(tmp_path: Path) -> list[list[str]]:
    base = ["export", "--model", "lambert", "-o", str(tmp_path / "x.binary")]
    folder = tmp_path / "export_folder.binary"
    folder.mkdir(exist_ok=True)
    cases = substitute(
        base, "-o", [str(tmp_path), str(folder), str(tmp_path / "no" / "x.binary"), "x.txt", ""]
    )
    cases += substitute(base, "--param", BAD_PARAMS) + substitute(base, "--model", BAD_NAMES)
    return cases + [["export", "-o", str(tmp_path / "y.binary")], ["export", "--model", "lambert"]]


def corpus_open(tmp_path: Path) -> list[list[str]]:
    return [["open", "--quit-after", "x"], ["open", "a.json", "b.json"], ["open", "--bogus"]]


def corpus_setup(tmp_path: Path) -> list[list[str]]:
    return [["setup", "--bogus"], ["setup", "now"], ["setup", str(tmp_path)]]


def corpus_check_models(tmp_path: Path) -> list[list[str]]:
    folder = tmp_path / "models"
    folder.mkdir(exist_ok=True)
    shader = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(0.3); }"
    (folder / "grey.brdf").write_text(f"analytic\n::begin shader\n{shader}\n::end shader\n")
    empty = tmp_path / "no_models"
    empty.mkdir(exist_ok=True)
    base = ["check-models", str(folder)]
    cases = [["check-models"], ["check-models", str(tmp_path / "none")], ["check-models", str(empty)]]
    cases += [["check-models", str(folder / "grey.brdf")], [*base, "--bogus"]]
    cases += substitute(base, "--grid", [*BAD_NUMBERS, "1", "17", "2.5", "-3"])
    table = tmp_path / "table.csv"
    table.mkdir(exist_ok=True)
    return cases + substitute(base, "--csv", [str(tmp_path), str(table), str(tmp_path / "no" / "x.csv"), ""])


@pytest.mark.parametrize(
    "command",
    [
        "eval",
        "albedo",
        "sample",
        "check",
        "bench",
        "demo",
        "models",
        "open",
        "fit",
        "export",
        "check-models",
        "setup",
    ],
)
def test_bad_arguments_of_each_command(capsys, tmp_path, command):
    sweep(capsys, command, CORPORA[command](tmp_path))


# ------------------------------------------------------------------------------------------------ render
SCENE = {
    "version": 2,
    "camera": {"position": [0, 1, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 45},
    "materials": [
        {"name": "floor", "model": "lambert", "params": {"kd": 0.5}},
        {"name": "ball", "model": "phong", "params": {"n": 50}},
    ],
    "meshes": [
        {"path": "floor.obj", "material": "floor"},
        {"path": "ball.obj", "material": "ball", "transform": {"translate": [0, 0, 0], "scale": 1.0}},
    ],
    "lights": [
        {"type": "point", "position": [1, 3, 1], "intensity": 5},
        {"type": "quad", "corner": [-1, 2, -1], "edge1": [1, 0, 0], "edge2": [0, 0, 1], "radiance": 2},
    ],
    "environment": {"type": "constant", "radiance": 0.2},
    "render": {"width": 8, "height": 6, "spp": 1, "max_depth": 2, "sampler": "cosine", "sampler_options": {}},
}


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory) -> Path:
    return write_scene_dir(tmp_path_factory.mktemp("inputs"))


def corpus_render(tmp_path: Path, scene_dir: Path) -> list[list[str]]:
    base = ["render", str(scene_dir / "scene.json"), "--quiet", "-o", str(tmp_path / "out.exr")]
    cases = []
    for option in ("--spp", "--time", "--width", "--height", "--max-depth", "--ris", "--seed", "--exposure"):
        cases += substitute(base, option, BAD_NUMBERS)
    cases += substitute(base, "--spp", ["0", "1000001", "2.5"]) + substitute(
        base, "--time", ["0", "-1", "1e7"]
    )
    cases += substitute(base, "--max-depth", ["0", "100000"]) + substitute(base, "--ris", ["-1", "1e9"])
    cases += substitute(base, "--width", ["0", "100000"]) + substitute(base, "--n-max", ["1", "nan", "3"])
    cases += substitute(base, "--compare", [",,", "nope", "cosine,cosine", ","]) + substitute(
        base, "--sampler", BAD_NAMES
    )
    cases += [[*base, "--spp", "1", "--time", "1"], [*base, "--spp", "1", "--until-cancelled"]]
    cases += [
        [*base, "--sampler", "cosine", "--compare", "uniform"],
        ["render"],
        ["render", "--demo", "x.json"],
    ]
    folder = tmp_path / "folder.exr"
    folder.mkdir(exist_ok=True)
    outs = [str(tmp_path), str(folder), str(tmp_path / "no" / "o.exr"), "o.png", "o", ""]
    cases += substitute(base, "-o", outs)
    cases += substitute(
        base, "--reference", [str(tmp_path / "missing.exr"), str(tmp_path), str(scene_dir / "ball.obj")]
    )
    for scene in ("missing.json", str(tmp_path), str(scene_dir / "ball.obj")):
        cases.append(["render", scene, "--quiet", "-o", str(tmp_path / "o.exr")])
    # memory budgets: refused before any work, naming what is needed and what the machine has; a film too
    # large for the machine is rendered in bands, which take --spp and one strategy only
    big = [*base, "--width", "16384", "--height", "16384"]
    cases += [
        [*big, "--time", "1"],
        [*big, "--until-cancelled"],
        [*big, "--spp", "1", "--compare", "uniform,cosine"],
        [*base, "--width", "16384", "--height", "1024", "--ris", "1024"],
    ]
    return cases


def test_render_bad_arguments(capsys, scene_dir, tmp_path):
    t0 = time.perf_counter()
    sweep(capsys, "render", corpus_render(tmp_path, scene_dir))
    assert time.perf_counter() - t0 < 60.0  # every one refused before preparing the scene


CORPORA = {
    "eval": corpus_eval,
    "albedo": corpus_albedo,
    "sample": corpus_sample,
    "check": corpus_check,
    "bench": corpus_bench,
    "demo": corpus_demo,
    "models": corpus_models,
    "open": corpus_open,
    "fit": corpus_fit,
    "export": corpus_export,
    "check-models": corpus_check_models,
    "setup": corpus_setup,
}
"""Each command's corpus of bad arguments (``render``'s, which needs a scene, is :func:`corpus_render`)."""


def test_every_command_has_a_corpus():
    """A new command must come with its bad inputs (render's corpus is corpus_render)."""
    from app.cli import build_parser

    _, handlers = build_parser()
    assert set(handlers) - {"render"} == set(CORPORA)


def write_scene_dir(folder: Path) -> Path:
    """The small valid scene every render case starts from."""
    quad(folder / "floor.obj", size=3.0, y=-1.0)
    sphere(folder / "ball.obj", subdivisions=1)
    (folder / "scene.json").write_text(json.dumps(SCENE))
    return folder


def test_budget_messages_name_the_need_the_machine_and_the_option(capsys, scene_dir, tmp_path, monkeypatch):
    code, _, err = run_cli(capsys, [*CHECK[:-1], "1e12"])
    assert code == 2 and re.search(
        r"needs [\d.]+ TiB; this machine has [\d.]+ [GMT]iB available; use --samples", err
    )
    big = ["render", str(scene_dir / "scene.json"), "--quiet", "--width", "16384", "--height", "16384"]
    # too large for one film on this 4 GiB machine: rendered in bands, which need a sample count
    code, _, err = run_cli(capsys, [*big, "--time", "5"])
    assert code == 2 and re.search(
        r"16384x16384 render needs [\d.]+ GiB as one film .* in bands of rows.*: give --spp N instead of --time",
        err,
    )
    # not even a band of one row fits a 4 MiB machine
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(4 << 20))
    code, _, err = run_cli(capsys, [*big, "--spp", "1"])
    assert code == 2 and re.search(
        r"16384x16384 render in bands of one row needs .*available; use --width \d+ or smaller", err
    )


def test_output_names_keep_every_dot_but_the_extension(capsys, scene_dir, tmp_path):
    (tmp_path / "shot.png").write_bytes(b"unrelated")
    for name in ("out_t1.1.exr", "shot.final.exr"):
        code, _, err = run_cli(
            capsys, ["render", str(scene_dir / "scene.json"), "--quiet", "-o", str(tmp_path / name)]
        )
        assert code == 0, err
        stem = name[: -len(".exr")]
        for ext in (".exr", ".png", ".json"):
            assert (tmp_path / (stem + ext)).is_file(), stem + ext
    assert (tmp_path / "shot.png").read_bytes() == b"unrelated"
    assert not (tmp_path / "out_t1.exr").exists()


# --------------------------------------------------------------------- generated scene, MERL, mesh corpora
LEAF_VALUES = st.sampled_from(
    [float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 1e300, -1.0, 0.0, 1e12, 10**400, "x", "", None,
     True, [], {}, [1.0], [1.0, 2.0, 3.0, 4.0], {"a": 1}, -(2**70), 2**70, 1e-320]
)  # fmt: skip


def _leaves(data, path=()):
    """Every path to a value in ``data`` (a scene dict), containers included."""
    yield path
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _leaves(v, (*path, i))


PATHS = [p for p in _leaves(SCENE) if p]


@st.composite
def broken_scenes(draw):
    """The test scene with one to three fields replaced by bad values, keys added or removed."""
    scene = json.loads(json.dumps(SCENE))
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(PATHS))
        parent = scene
        try:
            for k in path[:-1]:
                parent = parent[k]
            kind = draw(st.sampled_from(["replace", "replace", "replace", "delete", "add"]))
            if kind == "replace":
                parent[path[-1]] = draw(LEAF_VALUES)
            elif kind == "delete" and isinstance(parent, dict):
                del parent[path[-1]]
            elif isinstance(parent, dict):
                parent[draw(st.sampled_from(["extra", "radiance", "scale", "type"]))] = draw(LEAF_VALUES)
        except (KeyError, IndexError, TypeError):
            continue  # an earlier mutation removed or replaced the container
    return scene


def render_scene_json(capsys, folder: Path, text: str, out: Path) -> tuple[int, str]:
    path = folder / "broken.json"
    path.write_text(text)
    code, _, err = run_cli(capsys, ["render", str(path), "--quiet", "-o", str(out), "--spp", "1"])
    return code, err


def check_answer(code: int, err: str, out: Path) -> None:
    if code == 0:
        from renderer.image_io import read_exr

        assert np.all(np.isfinite(read_exr(out)))  # read_exr refuses non-finite pixels too
        assert not EXCEPTION_NAME.search(err), err  # no warning or exception printed on the way either
    else:
        assert problem("render", code, err) is None, err


def _scene_sweep(capsys, scene_dir, scene) -> None:
    out = scene_dir / "broken_out.exr"
    out.unlink(missing_ok=True)
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), out)
    check_answer(code, err, out)


SWEEP_SETTINGS = dict(
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@settings(max_examples=30, **SWEEP_SETTINGS)
@given(scene=broken_scenes())
def test_generated_broken_scenes(capsys, scene_dir, scene):
    _scene_sweep(capsys, scene_dir, scene)


@pytest.mark.slow
@settings(max_examples=400, **SWEEP_SETTINGS)
@given(scene=broken_scenes())
def test_generated_broken_scenes_large(capsys, scene_dir, scene):
    _scene_sweep(capsys, scene_dir, scene)


@pytest.mark.parametrize(
    ("edit", "where"),
    [
        ({"lights": [{"type": "point", "position": [0, 3, 0], "intensity": 1e308}]}, "lights[0].intensity"),
        ({"environment": {"type": "constant", "radiance": 1e308}}, "environment.radiance"),
        (
            {"meshes": [{"path": "ball.obj", "material": "ball", "transform": {"translate": [1e300, 0, 0]}}]},
            "translate",
        ),
        ({"meshes": [{"path": "ball.obj", "material": "ball", "transform": {"scale": 1e200}}]}, "scale"),
        ({"render": {"sampler": "cosine", "sampler_options": {"n_max": 0.5}}}, "takes no options"),
        (
            {"render": {"sampler": "adaptive_exact", "sampler_options": {"theta_step": 0}}},
            "no option 'theta_step'",
        ),
        ({"render": {"sampler": "adaptive_exact", "sampler_options": {"cache": 5}}}, "'cache'"),
        ({"render": {"sampler": "adaptive_exact", "sampler_options": {"threads": "x"}}}, "'threads'"),
        ({"render": {"sampler": "adaptive_exact", "sampler_options": {"max_level": -3}}}, "[2, 14]"),
        ({"render": {"spp": 10**20}}, "render.spp"),
        ({"render": {"time_s": 1e300}}, "render.time_s"),
    ],
)
def test_absurd_scene_values_are_refused_with_the_field_and_range(capsys, scene_dir, edit, where):
    scene = {**json.loads(json.dumps(SCENE)), **edit}
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), scene_dir / "absurd.exr")
    assert problem("render", code, err) is None, err
    assert where in err


def test_a_scene_too_large_even_for_bands_is_refused(capsys, scene_dir, monkeypatch):
    """A 16384x16384 scene is rendered in bands where its film does not fit (this 4 GiB machine); on a 4 MiB
    machine not even a band of one row fits: refused before any work, naming the need."""
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(4 << 20))
    scene = {
        **json.loads(json.dumps(SCENE)),
        "render": {"width": 16384, "height": 16384, "sampler": "cosine"},
    }
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), scene_dir / "absurd.exr")
    assert problem("render", code, err) is None and code == 2, err
    assert "in bands of one row needs" in err


def test_deeply_nested_json_is_refused(capsys, scene_dir):
    code, err = render_scene_json(capsys, scene_dir, "[" * 100_000 + "]" * 100_000, scene_dir / "deep.exr")
    assert problem("render", code, err) is None and "nested too deeply" in err
    deep = {**SCENE, "name": "x"}
    text = json.dumps(deep)[:-1] + ', "extra": ' + "[" * 5000 + "]" * 5000 + "}"
    code, err = render_scene_json(capsys, scene_dir, text, scene_dir / "deep.exr")
    assert problem("render", code, err) is None and "nested too deeply" in err


def _exr(path: Path, image: np.ndarray) -> None:
    from renderer.image_io import write_exr

    write_exr(path, image.astype(np.float32))


@pytest.mark.parametrize(("value", "expected"), [(-0.5, "negative"), (3e38, "brightest")])
def test_environment_maps_with_negative_or_overflowing_pixels(capsys, scene_dir, value, expected):
    img = np.full((8, 16, 3), 0.5)
    img[2, 3, 1] = value
    _exr(scene_dir / "sky_bad.exr", img)
    scene = {**json.loads(json.dumps(SCENE)), "environment": {"type": "map", "path": "sky_bad.exr"}}
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), scene_dir / "sky_out.exr")
    assert problem("render", code, err) is None and expected in err, err


@settings(max_examples=25, **SWEEP_SETTINGS)
@given(
    dims=st.tuples(st.integers(-3, 400), st.integers(-3, 400), st.integers(-3, 400)),
    body=st.integers(0, 5000),
)
def test_generated_corrupt_merl_files(capsys, tmp_path_factory, dims, body):
    path = tmp_path_factory.mktemp("merl") / "bad.binary"
    path.write_bytes(np.array(dims, dtype="<i4").tobytes() + np.ones(body).tobytes())
    code, _, err = run_cli(capsys, ["albedo", "--measured", str(path), "--theta", "30"])
    assert problem("albedo", code, err) is None, err


MESH_TEXT = st.lists(
    st.sampled_from(
        ["v 0 0 0", "v 1 0 0", "v 0 1 0", "v nan 0 0", "v 1e300 0 0", "f 1 2 3", "f 1 2 9", "f 0 0 0", "f 1 1 1",
         "vn 0 0 1", "g part", "o obj", "f 1/1 2/2 3/3", "v x y z", "garbage", "f -1 -2 -3", "usemtl m", ""]
    ),
    max_size=12,
)  # fmt: skip


@settings(max_examples=25, **SWEEP_SETTINGS)
@given(lines=MESH_TEXT, suffix=st.sampled_from([".obj", ".ply", ".stl", ".off"]))
def test_generated_broken_meshes(capsys, scene_dir, lines, suffix):
    (scene_dir / f"bad{suffix}").write_text("\n".join(lines) + "\n")
    scene = json.loads(json.dumps(SCENE))
    scene["meshes"][1]["path"] = f"bad{suffix}"
    out = scene_dir / "mesh_out.exr"
    out.unlink(missing_ok=True)
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), out)
    check_answer(code, err, out)


# ------------------------------------------------------------------------- the last inputs that slipped through
def _one_line(command: str, code: int, err: str, *expected: str) -> None:
    """A clear answer (exit 2, one line) that says each of ``expected``."""
    assert problem(command, code, err) is None, err
    for text in expected:
        assert text in err, err


@pytest.mark.parametrize(
    ("variable", "value", "expected"),
    [
        ("BRDF_STUDIO_EMBREE", "bogus", "BRDF_STUDIO_EMBREE='bogus': expected one of direct, embreex"),
        ("BRDF_STUDIO_CACHE", "{file}", "is a file, not a folder"),
        ("BRDF_STUDIO_CACHE", "{file}/below", "cannot be written"),
        ("BRDF_STUDIO_CACHE", "/proc/brdf-studio-cache", "cannot be written"),
        ("BRDF_STUDIO_NUMBA_CACHE", "{file}", "is a file, not a folder"),
        ("BRDF_STUDIO_NUMBA_CACHE", "/proc/brdf-studio-numba", "cannot be written"),
    ],
)
def test_a_bad_environment_variable_is_refused_before_any_command(
    capsys, tmp_path, monkeypatch, variable, value, expected
):
    (tmp_path / "a_file").write_text("not a folder")
    monkeypatch.setenv(variable, value.format(file=tmp_path / "a_file"))
    code, _, err = run_cli(capsys, ["models"])
    _one_line("models", code, err, variable, expected, "unset")


def test_an_unusable_numba_cache_never_puts_kernels_in_the_package(tmp_path):
    """Kernels of a program that imports the packages itself (no command line to refuse the variable) go to
    the default folder, not to the packages' __pycache__."""
    import subprocess
    import sys

    (tmp_path / "a_file").write_text("")
    env = {**os.environ, "BRDF_STUDIO_NUMBA_CACHE": str(tmp_path / "a_file"), "HOME": str(tmp_path)}
    folder = subprocess.run(
        [sys.executable, "-c", "import core, numba; print(numba.config.CACHE_DIR)"],
        env=env, capture_output=True, text=True, check=True, cwd=Path(__file__).resolve().parents[2],
    ).stdout.strip()  # fmt: skip
    assert folder == str(tmp_path / ".cache" / "brdf-studio" / "numba")


def test_the_folder_study_refuses_junk_files_in_one_line(capsys, tmp_path):
    """Every file is read before any task is submitted; the refusal names the first few with their reasons."""
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "a.binary").write_bytes(np.arange(300, dtype="<i4").tobytes())
    (junk / "b.bsdf").write_text("hello")
    (junk / "c.bsdf").write_bytes(bytes(range(256)))
    (junk / "d.binary").write_bytes(b"")
    (junk / "notes.txt").write_text("not a material: not listed")
    code, _, err = run_cli(
        capsys, ["bench", "samplers", "--quick", "--materials", str(junk), "--out", str(tmp_path / "out")]
    )
    said = ("4 of 4 measured files", "a.binary", "b.bsdf", "c.bsdf", "and 1 more", "fix or move")
    _one_line("bench", code, err, *said)
    assert "d.binary" not in err and "notes.txt" not in err
    assert not (tmp_path / "out").exists()  # refused before any work


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (
            ["--scheduler", "tcp://127.0.0.1:1"],
            "--scheduler runs the folder study on Dask: it needs --materials",
        ),
        (["--workers", "4"], "--workers runs the folder study on Dask: it needs --materials"),
        (
            ["--materials", "{folder}", "--scheduler", "tcp://127.0.0.1:1", "--workers", "2"],
            "one or the other",
        ),
        (["--materials", "{folder}", "--workers", "0"], "--workers: must be a whole number in [1, 1e6]"),
    ],
)
def test_cluster_options_without_the_folder_study_are_refused(capsys, tmp_path, extra, expected):
    argv = ["bench", "samplers", "--quick", "--out", str(tmp_path / "out")]
    argv += [e.format(folder=tmp_path) for e in extra]
    code, _, err = run_cli(capsys, argv)
    _one_line("bench", code, err, expected)


def test_workers_are_capped_to_what_the_machine_holds(capsys, monkeypatch):
    from app.commands._folder_study import local_workers
    from core.study_folder import local_worker_limit

    limit, _ = local_worker_limit()
    cores = len(os.sched_getaffinity(0))
    assert 1 <= limit <= cores  # and this test's machine has 4 GiB (the fixture): at most 4 of 768 MiB
    assert local_workers(1000) == limit
    note = capsys.readouterr().err.strip()
    assert note.startswith(
        f"brdf-studio bench: note: --workers 1000 capped to {limit}, what this machine holds"
    )
    assert f"{cores} core" in note and "GiB of memory available" in note
    assert local_workers(1) == 1 and local_workers(None) == min(2, limit)
    assert capsys.readouterr().err == ""  # nothing to say when nothing was capped
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(1 << 30))  # 0.8 GiB of room: one worker of 768 MiB
    assert local_workers(8) == 1


@pytest.mark.parametrize("cache", ["{file}", "{file}/tables", "/proc/brdf-studio-tables"])
def test_a_scene_cache_folder_that_cannot_be_written_is_refused(capsys, scene_dir, tmp_path, cache):
    (tmp_path / "a_file").write_text("")
    scene = json.loads(json.dumps(SCENE))
    scene["render"] = {**scene["render"], "sampler": "adaptive_exact"}
    scene["render"]["sampler_options"] = {"cache": cache.format(file=tmp_path / "a_file")}
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), tmp_path / "o.exr")
    _one_line("render", code, err, "render.sampler_options", "option 'cache'")
    assert "is a file, not a folder" in err or "cannot be" in err


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_an_endless_device_is_refused_before_it_is_read(capsys, scene_dir, tmp_path, device):
    t0 = time.perf_counter()
    code, _, err = run_cli(capsys, ["render", device, "--quiet", "-o", str(tmp_path / "o.exr")])
    _one_line("render", code, err, f"scene file '{device}' is a device, not a file")
    (scene_dir / "endless.obj").unlink(missing_ok=True)
    (scene_dir / "endless.obj").symlink_to(device)
    scene = json.loads(json.dumps(SCENE))
    scene["meshes"][1]["path"] = "endless.obj"
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), tmp_path / "o.exr")
    _one_line("render", code, err, "meshes[1].path", "'endless.obj' is not a regular file")
    (tmp_path / "endless.bsdf").symlink_to(device)
    code, _, err = run_cli(capsys, ["albedo", "--measured", str(tmp_path / "endless.bsdf"), "--theta", "30"])
    _one_line("albedo", code, err, "endless.bsdf' is not a regular file")
    assert time.perf_counter() - t0 < 30.0  # nothing was read


def test_files_larger_than_their_kind_are_refused_before_they_are_read(capsys, scene_dir, tmp_path):
    """Sparse files (no disk used): their size is read, never their content."""
    from core.rgl.tensor_file import MAX_BYTES
    from core.scene import MAX_SCENE_BYTES

    big_scene = tmp_path / "big.json"
    with open(big_scene, "wb") as fh:
        fh.truncate(MAX_SCENE_BYTES + 1)
    code, _, err = run_cli(capsys, ["render", str(big_scene), "--quiet", "-o", str(tmp_path / "o.exr")])
    _one_line(
        "render", code, err, f"big.json' is too large: 64 MiB ({MAX_SCENE_BYTES + 1} bytes); at most 64 MiB"
    )
    big_bsdf = tmp_path / "big.bsdf"
    with open(big_bsdf, "wb") as fh:
        fh.truncate(2 * MAX_BYTES)
    code, _, err = run_cli(capsys, ["albedo", "--measured", str(big_bsdf), "--theta", "30"])
    _one_line("albedo", code, err, "big.bsdf' is too large: 2 GiB", "at most 1 GiB")


def test_messages_say_what_is_wrong(capsys, scene_dir, tmp_path):
    sample = ["sample", "--model", "lambert", "--sampler", "cosine", "-n", "10"]
    code, _, err = run_cli(capsys, [*sample, "--theta", "30", "-o", "/proc/brdf-studio.csv"])
    _one_line("sample", code, err, "folder '/proc' is not writable")
    assert "-n" not in err
    for value in ("-inf", "-nan", "-1e5"):
        code, _, err = run_cli(capsys, [*sample, "--theta", value, "-o", str(tmp_path / "x.csv")])
        _one_line("sample", code, err, "--theta: must be", f"got '{value}'")
    code, _, err = run_cli(capsys, [*sample, "--theta", "-inf", "-o", str(tmp_path / "x.csv")])
    assert "must be a finite number in [0, 90]" in err
    for scale, expected in ((1e200, "scale: Input should be less than or equal to 1000000"),
                            ([1, 2, 1e200], "scale[2]: Input should be less than or equal to 1000000"),
                            ("big", "scale: expected a list of numbers or a number")):  # fmt: skip
        scene = json.loads(json.dumps(SCENE))
        scene["meshes"][1]["transform"] = {"scale": scale}
        code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), tmp_path / "o.exr")
        _one_line("render", code, err, f"meshes[1].transform.{expected}")
        assert "constrained" not in err and "tuple[" not in err


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('{"version": 2, "version": 1}', "version"),
        (json.dumps(SCENE)[:-1] + ', "render": {"spp": 1}}', "render"),
        (json.dumps(SCENE).replace('"spp": 1', '"spp": 1, "spp": 2'), "spp"),
    ],
)
def test_duplicate_json_keys_are_refused_naming_the_key(capsys, scene_dir, tmp_path, text, key):
    code, err = render_scene_json(capsys, scene_dir, text, tmp_path / "o.exr")
    _one_line("render", code, err, f"broken.json: the key '{key}' appears twice in one object")


def test_a_black_material_exports_and_renders_with_rgl_warp(capsys, scene_dir, tmp_path):
    from core.measured import load_measured

    out = tmp_path / "black.bsdf"
    code, stdout, err = run_cli(capsys, ["export", "--model", "lambert", "--param", "kd=0", "-o", str(out)])
    assert code == 0 and out.is_file() and "-> rgl" in stdout, err
    back = load_measured(out)
    wi = np.array([[0.0, 0.0, 1.0], [0.5, 0.0, 0.866], [0.0, -0.6, 0.8]])
    assert np.all(back.eval(wi, wi[::-1]) == 0.0)
    scene = json.loads(json.dumps(SCENE))
    scene["materials"][1] = {"name": "ball", "model": "lambert", "params": {"kd": 0}}
    options = {"n_theta": 4, "vndf": 16, "samples": 8}  # small tables: a test of validity, not of quality
    scene["render"] = {**scene["render"], "sampler": "rgl_warp", "sampler_options": options}
    (scene_dir / "black.json").write_text(json.dumps(scene))
    image = tmp_path / "black.exr"
    argv = ["render", str(scene_dir / "black.json"), "--sampler", "rgl_warp", "--quiet", "-o", str(image)]
    code, _, err = run_cli(capsys, [*argv, "--spp", "2"])
    assert code == 0, err
    check_answer(code, err, image)


def corpus_last_inputs(tmp_path: Path, scene_dir: Path) -> list[tuple[str, list[str], dict[str, str]]]:
    """The inputs issue 38 lists, as ``(command, argv, environment)``: each must be
    exit 2 and one line (the tests above check each one's words; ``bench/budgets.py --parts sweep`` runs them
    with the rest of the corpus)."""
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder")
    junk = tmp_path / "junk"
    junk.mkdir(exist_ok=True)
    (junk / "a.binary").write_bytes(np.arange(300, dtype="<i4").tobytes())
    (junk / "b.bsdf").write_text("hello")
    for name, device in (("zero", "/dev/zero"), ("urandom", "/dev/urandom")):
        for suffix in (".obj", ".bsdf"):
            link = (scene_dir if suffix == ".obj" else tmp_path) / f"endless_{name}{suffix}"
            link.unlink(missing_ok=True)
            link.symlink_to(device)
    big_scene, big_bsdf = tmp_path / "big.json", tmp_path / "big.bsdf"
    with open(big_scene, "wb") as fh:
        fh.truncate((64 << 20) + 1)
    with open(big_bsdf, "wb") as fh:
        fh.truncate(2 << 30)

    def scene_file(name: str, edit, text: str | None = None) -> str:  # type: ignore[no-untyped-def]
        scene = json.loads(json.dumps(SCENE))
        if edit is not None:
            edit(scene)
        path = scene_dir / f"last_{name}.json"
        path.write_text(text if text is not None else json.dumps(scene))
        return str(path)

    def cache(folder: str):  # type: ignore[no-untyped-def]
        def edit(scene: dict) -> None:
            scene["render"] = {
                **scene["render"],
                "sampler": "adaptive_exact",
                "sampler_options": {"cache": folder},
            }

        return edit

    def mesh(path: str):  # type: ignore[no-untyped-def]
        return lambda scene: scene["meshes"][1].update(path=path)

    def scale(value):  # type: ignore[no-untyped-def]
        return lambda scene: scene["meshes"][1].update(transform={"scale": value})

    out = str(tmp_path / "o.exr")
    bench = ["bench", "samplers", "--quick", "--out", str(tmp_path / "study")]
    sample = ["sample", "--model", "lambert", "--sampler", "cosine", "-n", "10"]
    cases: list[tuple[str, list[str], dict[str, str]]] = [
        ("models", ["models"], {variable: value})
        for variable, value in (
            ("BRDF_STUDIO_EMBREE", "bogus"),
            ("BRDF_STUDIO_CACHE", str(a_file)),
            ("BRDF_STUDIO_CACHE", f"{a_file}/below"),
            ("BRDF_STUDIO_CACHE", "/proc/brdf-studio-cache"),
            ("BRDF_STUDIO_NUMBA_CACHE", str(a_file)),
            ("BRDF_STUDIO_NUMBA_CACHE", f"{a_file}/below"),
            ("BRDF_STUDIO_NUMBA_CACHE", "/proc/brdf-studio-numba"),
        )
    ]
    cases += [
        ("bench", [*bench, "--materials", str(junk)], {}),
        ("bench", [*bench, "--materials", str(junk), "--workers", "1000"], {}),
        ("bench", [*bench, "--scheduler", "tcp://127.0.0.1:1"], {}),
        ("bench", [*bench, "--workers", "1000"], {}),
        (
            "bench",
            [*bench, "--materials", str(junk), "--scheduler", "tcp://127.0.0.1:1", "--workers", "2"],
            {},
        ),
    ]
    render = [
        scene_file("cache_file", cache(str(a_file))),
        scene_file("cache_below_file", cache(f"{a_file}/tables")),
        scene_file("cache_proc", cache("/proc/brdf-studio-tables")),
        "/dev/zero",
        "/dev/urandom",
        str(big_scene),
        scene_file("mesh_zero", mesh("endless_zero.obj")),
        scene_file("mesh_urandom", mesh("endless_urandom.obj")),
        scene_file("scale", scale(1e200)),
        scene_file("scale_list", scale([1, 2, 1e200])),
        scene_file("scale_word", scale("big")),
        scene_file("dup_version", None, '{"version": 2, "version": 1}'),
        scene_file("dup_render", None, json.dumps(SCENE)[:-1] + ', "render": {"spp": 1}}'),
        scene_file("dup_spp", None, json.dumps(SCENE).replace('"spp": 1', '"spp": 1, "spp": 2')),
    ]
    cases += [("render", ["render", path, "--quiet", "-o", out, "--spp", "1"], {}) for path in render]
    cases += [
        ("albedo", ["albedo", "--measured", str(p), "--theta", "30"], {})
        for p in (tmp_path / "endless_zero.bsdf", tmp_path / "endless_urandom.bsdf", big_bsdf)
    ]
    cases += [
        ("sample", [*sample, "--theta", "30", "-o", "/proc/brdf-studio.csv"], {}),
        ("sample", [*sample, "--theta", "30", "-o", f"{a_file}/x.csv"], {}),
        *[
            ("sample", [*sample, "--theta", v, "-o", str(tmp_path / "x.csv")], {})
            for v in ("-inf", "-nan", "-1e5")
        ],
    ]
    return cases


def test_the_last_inputs_are_one_line_each(capsys, scene_dir, tmp_path, monkeypatch):
    cases = corpus_last_inputs(tmp_path, scene_dir)
    assert len(cases) == 34
    found = []
    for command, argv, env in cases:
        with monkeypatch.context() as m:
            for variable, value in env.items():
                m.setenv(variable, value)
            code, _, err = run_cli(capsys, argv)
        why = problem(command, code, err)
        if why is not None:
            found.append(f"{env} {argv}: {why}: {err.strip()[:300]}")
    assert found == []


def test_a_scene_naming_the_former_sampler_adaptive_renders_with_a_notice(capsys, scene_dir, tmp_path):
    """An older scene file's ``"sampler": "adaptive"`` renders as ``adaptive_exact``, with one notice line
    naming the current name; ``--sampler adaptive`` the same."""
    from renderer.image_io import read_exr

    scene = json.loads(json.dumps(SCENE))
    small = {"cache": False, "max_thetas": 7, "phi_count": 2, "capacity": 256, "warp_tol": 1e-2}
    scene["render"] = {**scene["render"], "sampler": "adaptive", "sampler_options": small}
    notice = "brdf-studio render: notice: 'adaptive' is a former name of the sampler 'adaptive_exact'; use 'adaptive_exact'"
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), tmp_path / "old.exr")
    assert code == 0 and err.strip().splitlines() == [notice], err
    scene["render"]["sampler"] = "adaptive_exact"
    code, err = render_scene_json(capsys, scene_dir, json.dumps(scene), tmp_path / "new.exr")
    assert code == 0 and err.strip() == "", err
    assert np.array_equal(read_exr(tmp_path / "old.exr"), read_exr(tmp_path / "new.exr"))  # the same strategy
    path = scene_dir / "broken.json"
    code, _, err = run_cli(capsys, ["render", str(path), "--quiet", "-o", str(tmp_path / "cli.exr"), "--spp", "1",
                                    "--sampler", "adaptive"])  # fmt: skip
    assert code == 0 and err.strip().splitlines() == [notice], err
    assert np.array_equal(read_exr(tmp_path / "cli.exr"), read_exr(tmp_path / "new.exr"))
