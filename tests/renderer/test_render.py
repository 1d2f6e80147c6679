"""Progressive rendering (callbacks, cancel, equal-time) and the ``brdf-studio render`` command."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from renderer.film import Film
from renderer.image_io import read_exr
from renderer.render import prepare
from tests.renderer.scenes import quad, sphere

SCENE = {
    "version": 1,
    "camera": {"position": [0, 1, 3], "target": [0, 0, 0], "fov_deg": 45},
    "materials": [
        {"name": "floor", "model": "lambert", "params": {"kd": 0.5}},
        {"name": "ball", "model": "lambert", "params": {"kd": [0.8, 0.3, 0.2]}},
    ],
    "meshes": [
        {"path": "floor.obj", "material": "floor"},
        {"path": "ball.obj", "material": "ball", "smooth": True},
    ],
    "lights": [{"type": "point", "position": [1, 3, 1], "intensity": 5}],
    "environment": {"type": "constant", "radiance": 0.2},
    "render": {"width": 24, "height": 16, "spp": 4, "max_depth": 3, "sampler": "cosine"},
}


@pytest.fixture
def scene_file(tmp_path: Path) -> Path:
    quad(tmp_path / "floor.obj", size=3.0, y=-1.0)
    sphere(tmp_path / "ball.obj", subdivisions=1)
    p = tmp_path / "scene.json"
    p.write_text(json.dumps(SCENE))
    return p


def test_progressive_passes_callback_and_cancel(scene_file: Path) -> None:
    from core.scene import load_scene

    job = prepare(load_scene(scene_file), width=512, height=512)
    assert job.batch == 1  # one sample per pixel per pass at this size
    seen = []
    cancel = threading.Event()

    def on_frame(frame) -> None:  # type: ignore[no-untyped-def]
        seen.append((frame.spp, frame.elapsed))
        if frame.spp == 2:
            cancel.set()

    frames = list(job.passes(spp=10, cancel=cancel, callback=on_frame))
    assert [f.spp for f in frames] == [1, 2] and [s for s, _ in seen] == [1, 2]
    assert seen[1][1] >= seen[0][1] > 0
    assert frames[-1].image.shape == (512, 512, 3)
    # resuming continues where it stopped: the film keeps its samples
    assert job.run(spp=3).spp == 3


def _spy_passes(job) -> list[tuple[int | None, int]]:  # type: ignore[no-untyped-def]
    """Record ``(first_sample, spp)`` of every pass the job's tracer renders (and render it)."""
    used: list[tuple[int | None, int]] = []
    real = job.tracer.render_pass

    def spy(pass_index, spp=1, first_sample=None, **kw):  # type: ignore[no-untyped-def]
        used.append((first_sample, spp))
        return real(pass_index, spp, first_sample, **kw)

    job.tracer.render_pass = spy  # type: ignore[method-assign]
    return used


def test_passes_of_any_size_use_each_sample_number_once(scene_file: Path) -> None:
    """A progressive render numbers its samples by what the film holds, so passes of unequal size (a last
    pass cut to the budget, a resumed render with another batch) never reuse a pixel's low-discrepancy
    points: 3 + 1 + 4 samples in three passes are samples 0-2, 3 and 4-7."""
    from core.scene import load_scene

    job = prepare(load_scene(scene_file), width=32, height=32)
    used = _spy_passes(job)
    job.batch = 3
    job.run(spp=4)
    job.batch = 4
    job.run(spp=8)
    assert used == [(0, 3), (3, 1), (4, 4)]


def test_a_small_first_pass_then_full_passes_numbered_on(scene_file: Path) -> None:
    """``first_spp`` cuts the film's first pass only (the app's first image): 1 + 3 + 3 samples are samples 0,
    1-3 and 4-6; in equal time too the first frame holds ``first_spp`` samples, and a resumed render (film
    not empty) is not cut again."""
    from core.scene import load_scene

    job = prepare(load_scene(scene_file), width=16, height=16)
    used = _spy_passes(job)
    job.batch = 3
    assert [f.spp for f in job.passes(spp=7, first_spp=1)] == [1, 4, 7]
    assert used == [(0, 1), (1, 3), (4, 3)]
    assert job.run(spp=10, first_spp=1).spp == 10 and used[-1] == (7, 3)

    timed = prepare(load_scene(scene_file), width=16, height=16)
    timed.batch = 3
    first = next(timed.passes(time_s=10.0, first_spp=2))
    assert first.spp == 2


def test_kernel_loading_stores_no_table_and_stops_when_asked(tmp_path: Path, monkeypatch) -> None:
    """``load_kernels`` (the render process's idle warm-up) builds small adaptive tables only to load the
    builders' kernels: none reaches the table cache; it takes no step once ``stop()`` is True, and stops
    within a step at the next material."""
    from renderer.tracer_warmup import load_kernels

    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "tables"))
    done = []
    for name, seconds in load_kernels(("uniform", "adaptive_warp", "cosine"), stop=lambda: len(done) == 2):
        done.append(name)
        assert seconds > 0
    assert done == ["uniform", "adaptive_warp"]
    assert not list((tmp_path / "tables").rglob("*.npz"))
    assert list(load_kernels(stop=lambda: True)) == []
    # a render that arrives during a step waits for one material's preparation, not for the whole step
    asked = []
    assert list(load_kernels(("adaptive_exact",), stop=lambda: asked.append(1) or len(asked) > 1)) == []
    assert len(asked) == 2  # before the step, then before its first material: stopped there


def test_pre_pass_finds_the_directions_each_material_is_seen_from(scene_file: Path) -> None:
    """What a lazily built sampler gets asked for before the first pass: local outgoing directions of both
    materials (the floor is also reached by the bounce from the ball), unit length, above the surface."""
    from core.scene import load_scene

    job = prepare(load_scene(scene_file))
    found = job.tracer.incident_directions(max_paths=2000)
    assert set(found) == {0, 1}
    for wo in found.values():
        assert np.allclose(np.linalg.norm(wo, axis=1), 1.0)
        assert np.mean(wo[:, 2] > 0) > 0.99  # shading normals can tilt a few grazing ones below


def test_equal_time_mode_stops_near_the_budget(scene_file: Path) -> None:
    from core.scene import load_scene

    job = prepare(load_scene(scene_file))
    frames = list(job.passes(time_s=0.3))
    # it stops at the first pass that reaches the budget, not before and not later
    assert frames[-1].elapsed >= 0.3
    assert all(f.elapsed < 0.3 for f in frames[:-1])
    assert [f.spp for f in frames] == sorted({f.spp for f in frames})


def test_cli_writes_exr_png_sidecar(scene_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out.exr"
    assert main(["render", str(scene_file), "--spp", "3", "-o", str(out), "--seed", "5", "--quiet"]) == 0
    img = read_exr(out)
    assert img.shape == (16, 24, 3) and np.all(np.isfinite(img)) and img.max() > 0
    info = json.loads(out.with_suffix(".json").read_text())
    assert info["spp"] == 3 and info["settings"]["seed"] == 5 and info["settings"]["sampler"] == "cosine"
    assert info["versions"]["numpy"] == np.__version__
    assert info["ray_queries"] == "embreex"  # the default backend (renderer.accel.DEFAULT_BACKEND)
    assert out.with_suffix(".png").read_bytes()[:4] == b"\x89PNG"
    # the same seed gives the same image
    out2 = tmp_path / "again.exr"
    assert main(["render", str(scene_file), "--spp", "3", "-o", str(out2), "--seed", "5", "--quiet"]) == 0
    assert np.array_equal(read_exr(out2), img)


def test_cli_compare_with_reference(scene_file: Path, tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    ref = tmp_path / "ref.exr"
    assert main(["render", str(scene_file), "--spp", "16", "-o", str(ref), "--quiet"]) == 0
    out = tmp_path / "cmp.exr"
    args = ["render", str(scene_file), "--spp", "4", "-o", str(out), "--compare", "uniform,cosine"]
    assert main([*args, "--reference", str(ref), "--quiet"]) == 0
    for name in ("cmp_uniform.exr", "cmp_cosine.exr", "cmp_compare.png", "cmp_error.csv", "cmp_error.png"):
        assert (tmp_path / name).is_file(), name
    rows = (tmp_path / "cmp_error.csv").read_text().splitlines()
    assert rows[0] == "strategy,spp,seconds,rmse,relmse"
    assert {r.split(",")[0] for r in rows[1:]} == {"uniform", "cosine"}
    assert "RMSE" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--spp", "0"], "--spp: must be a whole number in [1, 1e6], got '0'"),
        (["--sampler", "magic"], "unknown sampler 'magic'"),
        (["--compare", "cosine,cosine"], "twice"),
        (["-o", "out.png"], "must be an .exr file"),
        (["-o", "/no/such/folder/x.exr"], "does not exist"),
        (["--reference", "missing.exr"], "not found"),
    ],
)
def test_cli_bad_input_is_one_line(scene_file: Path, capsys, extra: list[str], message: str) -> None:  # type: ignore[no-untyped-def]
    assert main(["render", str(scene_file), "--quiet", *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_cli_reference_size_mismatch(scene_file: Path, tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    from renderer.image_io import write_exr

    write_exr(tmp_path / "small.exr", np.zeros((4, 4, 3)))
    args = ["render", str(scene_file), "--spp", "1", "-o", str(tmp_path / "o.exr"), "--quiet"]
    assert main([*args, "--reference", str(tmp_path / "small.exr")]) == 2
    assert "reference is 4x4" in capsys.readouterr().err


def test_cli_broken_scene(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    p = tmp_path / "broken.json"
    p.write_text('{"version": 1, "materials": [')
    assert main(["render", str(p), "--quiet"]) == 2
    assert "broken.json: line 1" in capsys.readouterr().err


def test_demo_scene_loads_and_builds() -> None:
    """The bundled demo is valid: meshes, measured material file and sky map all load (no compile)."""
    from app.commands.render import demo_scene_path
    from core.scene import load_scene
    from renderer.world import World

    scene = load_scene(demo_scene_path())
    assert any(m.measured for m in scene.materials)
    w = World(scene)
    assert w.n_triangles > 1000 and len(w.emit_ids) == 2 and w.env is not None
    w.accel.close()


@pytest.mark.slow
def test_demo_renders(tmp_path: Path) -> None:
    out = tmp_path / "demo.exr"
    assert (
        main(["render", "--demo", "--spp", "2", "--width", "48", "--height", "32", "-o", str(out), "--quiet"])
        == 0
    )
    img = read_exr(out)
    assert np.all(np.isfinite(img)) and img.mean() > 0.05


def test_bad_measured_file_names_the_material(scene_file: Path, tmp_path: Path) -> None:
    from core.scene import SceneError, load_scene

    (tmp_path / "broken.binary").write_bytes(b"\x5a\x00\x00\x00" * 3 + b"\x00" * 100)
    data = json.loads(scene_file.read_text())
    data["materials"][1] = {"name": "ball", "measured": "broken.binary"}
    scene_file.write_text(json.dumps(data))
    with pytest.raises(SceneError, match=r"scene\.json: materials\[1\]\.measured: .*broken\.binary"):
        prepare(load_scene(scene_file))


def test_per_material_sampler_override(scene_file: Path) -> None:
    from core.scene import SceneError, load_scene

    scene = load_scene(scene_file)
    job = prepare(scene, sampler="uniform", material_samplers={"ball": "cosine"})
    mats = job.prepare_report["materials"]
    assert mats["ball"]["sampler"] == "cosine" and mats["floor"]["sampler"] == "uniform"
    assert "set for this material" in mats["ball"]["note"]
    with pytest.raises(SceneError, match="no material named nope"):
        prepare(scene, material_samplers={"nope": "cosine"})


def test_cli_says_whether_a_table_was_built_or_loaded(
    scene_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The render summary's table lines tell a table this run built from one it read from the table cache
    (whose build time is the first run's, not this one's)."""
    from core.sampling.adaptive import sampler as adaptive_sampler

    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "tables"))
    argv = ["render", str(scene_file), "--spp", "1", "--sampler", "adaptive_warp", "--quiet"]
    lines = []
    for k in range(2):
        monkeypatch.setattr(adaptive_sampler, "_TABLES", {})  # each run as a new process: no table in memory
        assert main([*argv, "-o", str(tmp_path / f"run{k}.exr")]) == 0
        lines.append([s for s in capsys.readouterr().out.splitlines() if "tables: material" in s])
    assert lines[0] and all("KB, built (its build took" in s for s in lines[0])
    assert len(lines[1]) == len(lines[0])
    assert all("KB, loaded from the table cache (its build took" in s for s in lines[1])


def _loaded_signatures() -> int:
    """Signatures compiled or loaded from numba's cache so far, over the renderer's compiled stages."""
    import numba

    from renderer import embree
    from renderer.stages import bsdf, camera, continuation, hits, surface

    found = 0
    for module in (camera, hits, surface, bsdf, continuation, embree):
        for obj in vars(module).values():
            if isinstance(obj, numba.core.registry.CPUDispatcher):
                found += len(obj.overloads)
    return found


def test_prepare_loads_the_kernels_and_buffers_a_pass_uses(scene_file: Path) -> None:
    """After ``prepare`` the first pass loads no compiled stage (every one its paths call was loaded by the
    preparation's few paths) and allocates no wavefront buffers; the preparation's paths change neither the
    statistics nor what the passes draw (the same image as a tracer that traced them twice)."""
    from core.scene import load_scene

    job = prepare(load_scene(scene_file), width=64, height=48, seed=4)
    rep = job.prepare_report
    assert job.tracer.stats.paths == 0 and rep["kernel_load_seconds"] >= 0.0
    parts = ("geometry_seconds", "compile_seconds", "warm_up_seconds", "kernel_load_seconds")
    assert rep["seconds"] >= sum(rep.get(k, 0.0) for k in parts) - 0.004  # the whole, each part rounded
    buffers = list(job.tracer.buffers)
    before = _loaded_signatures()
    first = job.tracer.render_pass(0, 2)
    assert _loaded_signatures() == before
    assert job.tracer.buffers == buffers and len(buffers) == job.tracer.threads
    again = prepare(load_scene(scene_file), width=64, height=48, seed=4)
    again.tracer.load_kernels(paths=1000)
    assert np.array_equal(again.tracer.render_pass(0, 2), first)


def test_a_pass_traces_into_the_reserved_radiance_rows_and_returns_the_callers_own(scene_file: Path) -> None:
    """``reserve`` maps a whole-image pass's radiance rows once, and every pass of the job's size traces into
    them (their pages are not faulted in by the first passes' paths). What ``render_pass`` returns stays the
    caller's: the same image as a tracer without the rows, not changed by the next pass; only ``borrow=True``
    at one sample per pixel hands out the rows themselves (``RenderJob.passes`` adds them to its film at
    once), and a band of pixels never uses them."""
    from core.scene import load_scene

    job = prepare(load_scene(scene_file), width=64, height=48, seed=4)
    tr = job.tracer
    rows = tr._radiance
    assert rows is not None and rows.shape == (64 * 48 * job.batch, 3)
    first = tr.render_pass(0, job.batch)
    kept = first.copy()
    tr.render_pass(1, job.batch)
    assert tr._radiance is rows and not np.shares_memory(first, rows)
    np.testing.assert_array_equal(first, kept)
    plain = prepare(load_scene(scene_file), width=64, height=48, seed=4)
    plain.tracer._radiance = None
    np.testing.assert_array_equal(plain.tracer.render_pass(0, job.batch), first)
    mean = tr.render_pass(0, job.batch, borrow=True)  # the pass's mean, in the tracer's own rows too
    assert mean is tr._mean
    np.testing.assert_array_equal(mean, first)
    film, plain_film = job.film, Film(64, 48)  # the reserved film adds passes as a new one does
    assert film._sum is not None and film.spp == 0
    for k, spp in enumerate((job.batch, 3)):
        film.add_pass(tr.render_pass(k, spp, borrow=True), spp)
        plain_film.add_pass(plain.tracer.render_pass(k, spp), spp)
    np.testing.assert_array_equal(film.image(), plain_film.image())

    tr.reserve(64 * 48)
    own = tr.render_pass(2, 1)
    borrowed = tr.render_pass(2, 1, borrow=True)
    assert not np.shares_memory(own, tr._radiance) and borrowed is tr._radiance
    np.testing.assert_array_equal(own, borrowed)
    band = tr.render_pass(2, 1, pixels=(64, 640))
    assert not np.shares_memory(band, tr._radiance)
    np.testing.assert_array_equal(band, own[64:640])


def test_embreex_fallback_renders_the_same_image(
    scene_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``BRDF_STUDIO_EMBREE=embreex`` renders through embreex's ``run`` (the sidecar says so) and the image is
    the direct backend's up to the rounding of the hits' barycentrics (the same triangles, paths and samples)."""
    images, sidecars = {}, {}
    for backend in ("direct", "embreex"):
        monkeypatch.setenv("BRDF_STUDIO_EMBREE", backend)
        out = tmp_path / f"{backend}.exr"
        assert main(["render", str(scene_file), "--spp", "4", "-o", str(out), "--seed", "2", "--quiet"]) == 0
        images[backend] = read_exr(out)
        sidecars[backend] = json.loads(out.with_suffix(".json").read_text())["ray_queries"]
    assert sidecars == {"direct": "direct", "embreex": "embreex"}
    a, b = images["direct"], images["embreex"]
    assert np.abs(a - b).max() <= 1e-4 * max(1.0, float(a.max()))
