"""A scene whose materials are model files (``"model": "materials/plastic.brdf"``): read relative to the scene
file, held as absolute paths, saved relative again, and rendered with every sampling strategy that applies to
them (and with the sky's light by RIS), all through the one compiled dispatch of the built-in models."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.sampling import sampler_names
from core.scene import load_scene, save_scene
from renderer.image_io import read_exr
from renderer.render import prepare
from tests.renderer.scenes import quad, sphere

ROOT = Path(__file__).resolve().parents[2]
SHADER = ROOT / "tests" / "app" / "fixtures" / "cli_plastic.brdf"
PYTHON = ROOT / "resources" / "models" / "blinn_phong.py"

SMALL_TABLES: dict[str, dict] = {
    "adaptive_exact": {"cache": False, "max_thetas": 7, "phi_count": 2, "capacity": 256, "warp_tol": 1e-2},
    "adaptive_warp": {"cache": False, "max_thetas": 7, "phi_count": 2, "capacity": 256, "warp_tol": 1e-2},
    "uniform_cdf": {"n_theta_o": 4, "n_phi_o": 1, "n_theta": 16, "n_phi": 32},
    "compress_cdf": {"n_theta_o": 4, "n_phi_o": 1, "n_theta": 16, "n_phi": 32},
    "factored": {"n_theta_o": 4, "n_phi_o": 1, "n_theta_p": 16, "n_phi_p": 32},
    "rgl_warp": {"n_theta": 4, "vndf": 16, "samples": 8},
}
"""Small tables: the test is that each strategy builds and draws for a model file, not how well."""


def write_scene(folder: Path) -> Path:
    """``folder/scene.json`` naming ``materials/blinn_phong.py`` and ``materials/plastic.brdf``."""
    (folder / "materials").mkdir(parents=True)
    shutil.copy(SHADER, folder / "materials" / "plastic.brdf")
    shutil.copy(PYTHON, folder / "materials" / "blinn_phong.py")
    quad(folder / "floor.obj", size=3.0, y=-1.0)
    sphere(folder / "ball.obj", subdivisions=1)
    scene = {
        "version": 2,
        "camera": {"position": [0, 1, 3], "target": [0, 0, 0], "fov_deg": 45},
        "materials": [
            {"name": "floor", "model": "materials/blinn_phong.py", "params": {"n": 30}},
            {"name": "ball", "model": "materials/plastic.brdf", "params": {"diffuse": [0.6, 0.2, 0.1]}},
        ],
        "meshes": [
            {"path": "floor.obj", "material": "floor"},
            {"path": "ball.obj", "material": "ball", "smooth": True},
        ],
        "lights": [{"type": "point", "position": [1, 3, 1], "intensity": 5}],
        "environment": {"type": "constant", "radiance": 0.3},
        "render": {"width": 12, "height": 8, "spp": 2, "max_depth": 2, "sampler": "adaptive_warp"},
    }
    path = folder / "scene.json"
    path.write_text(json.dumps(scene))
    return path


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One scene for the module (a model file's path is its identity: each copy loads and compiles anew)."""
    return write_scene(tmp_path_factory.mktemp("model_files") / "scene")


def test_model_paths_are_read_relative_to_the_scene_and_saved_relative(
    scene_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # not the scene's folder: the paths are the scene file's
    scene = load_scene(scene_file)
    folder = scene_file.parent
    assert [m.model for m in scene.materials] == [
        str(folder / "materials" / "blinn_phong.py"),
        str(folder / "materials" / "plastic.brdf"),
    ]
    again = folder / "again.json"
    save_scene(scene, again)
    saved = json.loads(again.read_text())
    assert [m["model"] for m in saved["materials"]] == ["materials/blinn_phong.py", "materials/plastic.brdf"]
    assert [m.model for m in load_scene(again).materials] == [m.model for m in scene.materials]
    # saved in another folder, the model files are written relative to that one (meshes are not moved)
    elsewhere = folder.parent / "copies" / "again.json"
    elsewhere.parent.mkdir(exist_ok=True)
    save_scene(scene, elsewhere)
    saved = json.loads(elsewhere.read_text())
    assert [m["model"] for m in saved["materials"]] == [
        "../scene/materials/blinn_phong.py",
        "../scene/materials/plastic.brdf",
    ]
    moved = load_scene(elsewhere, check_files=False)
    assert [m.model for m in moved.materials] == [m.model for m in scene.materials]
    assert scene.materials[0].model is not None and Path(scene.materials[0].model).is_absolute()


def test_a_missing_model_file_names_the_material(tmp_path: Path) -> None:
    from core.scene import SceneError

    scene_file = write_scene(tmp_path)
    (tmp_path / "materials" / "plastic.brdf").unlink()
    with pytest.raises(
        SceneError, match=r"scene\.json: materials\[1\]\.model: .*plastic\.brdf.*no such model"
    ):
        load_scene(scene_file)


def test_the_render_command_renders_a_scene_of_model_files(scene_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out.exr"
    assert main(["render", str(scene_file), "--spp", "2", "-o", str(out), "--quiet"]) == 0
    image = read_exr(out)
    assert image.shape == (8, 12, 3) and np.all(np.isfinite(image)) and image.max() > 0


@pytest.mark.parametrize("strategy", sampler_names())
def test_every_strategy_renders_model_files(scene_file: Path, strategy: str) -> None:
    """``analytic`` draws from the Python file's own sampler; the shader has none and takes ``cosine``."""
    scene = load_scene(scene_file)
    job = prepare(scene, sampler=strategy, sampler_options=SMALL_TABLES.get(strategy, {}), warm_up=False)
    mats = job.prepare_report["materials"]
    assert mats["floor"]["sampler"] == strategy
    assert mats["ball"]["sampler"] == ("cosine" if strategy == "analytic" else strategy)
    image = job.tracer.render_pass(0, 1)
    assert np.all(np.isfinite(image)) and image.max() > 0


def test_ris_lights_a_scene_of_model_files(scene_file: Path) -> None:
    scene = load_scene(scene_file)
    job = prepare(scene, sampler="cosine", ris_candidates=4, warm_up=False)
    image = job.tracer.render_pass(0, 1)
    assert np.all(np.isfinite(image)) and image.max() > 0
