"""Path tracer correctness: white furnace, albedo on a plane, strategies agree, reproducibility, hard cases.

Statistical checks use the pass-to-pass spread: each pass is an unbiased estimate, so the mean over passes has
a standard error ``std / sqrt(passes)``; tests allow 4.5 standard errors (two-sided p ~ 7e-6 per check under a
normal approximation) unless stated otherwise. Pixel and light samples of the first bounces come from a pixel's
Owen-scrambled Sobol sequence, so successive passes are not strictly independent; that the pass-to-pass
spread still predicts the difference between two seeds is itself tested
(``test_two_seeds_agree_within_the_pass_to_pass_error``; over 288 block-channels of six seed pairs the
z-scores have a standard deviation of 0.97).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from core.brdf import all_models
from core.scene import PointLight
from renderer.render import prepare
from tests.renderer.scenes import make_scene, quad, sphere

Z = 4.5


def _pass_means(job, passes: int, mask: np.ndarray | None = None, spp: int = 8) -> np.ndarray:
    """Per-pass mean RGB over the (masked) pixels: ``(passes, 3)`` independent estimates."""
    out = []
    for k in range(passes):
        rad = job.tracer.render_pass(k, spp)
        out.append(rad[mask].mean(axis=0) if mask is not None else rad.mean(axis=0))
    return np.array(out)


def _furnace_scene(tmp_path: Path, model: str, params: dict, sampler: str = "cosine"):
    sphere(tmp_path / "sphere.obj")
    return make_scene(
        tmp_path,
        {
            "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_deg": 30},
            "materials": [{"name": "m", "model": model, "params": params}],
            "meshes": [{"path": "sphere.obj", "material": "m", "smooth": False}],
            "environment": {"type": "constant", "radiance": 1.0},
            "render": {"width": 16, "height": 16, "max_depth": 40, "rr_depth": 40, "sampler": sampler},
        },
    )


@pytest.mark.parametrize("sampler", ["cosine", "uniform"])
def test_white_furnace_lambert(tmp_path: Path, sampler: str) -> None:
    """An albedo-1 Lambert sphere under a constant unit sky is invisible: every pixel is 1."""
    job = prepare(_furnace_scene(tmp_path, "lambert", {"kd": 1.0}, sampler))
    means = _pass_means(job, 16)
    m, se = means.mean(axis=0), means.std(axis=0, ddof=1) / math.sqrt(len(means))
    assert np.all(np.abs(m - 1.0) <= Z * se + 1e-9), (m, se)
    assert np.all(se < 0.05)  # the test has power: 1 +- 0.2 would fail
    assert job.tracer.stats.nonfinite == 0


def _plane_scene(tmp_path: Path, model: str, params: dict, sampler: str, theta_deg: float):
    quad(tmp_path / "plane.obj", size=1000.0)
    t = math.radians(theta_deg)
    return make_scene(
        tmp_path,
        {
            "camera": {
                "position": [20 * math.sin(t), 20 * math.cos(t), 0],
                "target": [0, 0, 0],
                "fov_deg": 0.5,
            },
            "materials": [{"name": "m", "model": model, "params": params}],
            "meshes": [{"path": "plane.obj", "material": "m"}],
            "environment": {"type": "constant", "radiance": 1.0},
            "render": {"width": 8, "height": 8, "max_depth": 3, "rr_depth": 3, "sampler": sampler},
        },
    )


ALBEDO_CASES = [
    ("lambert", {"kd": 0.5}, "cosine"),
    ("lambert", {"kd": [0.2, 0.5, 0.9]}, "uniform"),
    ("ggx", {}, "analytic"),
    ("ward", {}, "analytic"),
    ("phong", {}, "analytic"),
    ("ggx", {}, "adaptive_exact"),
    ("phong", {"n": 1000}, "adaptive_exact"),
]


@pytest.mark.parametrize(
    ("model", "params", "sampler"), ALBEDO_CASES, ids=[f"{c[0]}-{c[2]}" for c in ALBEDO_CASES]
)
def test_plane_renders_its_albedo(tmp_path: Path, model: str, params: dict, sampler: str) -> None:
    """A plane under a constant unit sky, seen at 60 degrees: each pixel is the directional albedo rho(60)
    (no interreflection on a plane), computed independently by quadrature (core.analysis)."""
    from core.sampling import sampler_names

    if model not in {m.name for m in all_models()} or sampler not in sampler_names():
        pytest.skip(f"model {model} or sampler {sampler} not in the library yet")
    from core.analysis import albedo
    from core.brdf import make_brdf

    opts = {"cache": str(tmp_path / "tables")} if sampler == "adaptive_exact" else {}
    job = prepare(_plane_scene(tmp_path, model, params, sampler, 60.0), sampler_options=opts)
    expected = np.array(albedo(make_brdf(model, params), 60.0).value)
    means = _pass_means(job, 24)
    m, se = means.mean(axis=0), means.std(axis=0, ddof=1) / math.sqrt(len(means))
    # 0.5 degree field of view: the view angle varies by +-0.25 degrees over the image
    assert np.all(np.abs(m - expected) <= Z * se + 2e-3), (m, se, expected)


def _mixed_scene(tmp_path: Path, sampler: str, env: dict | None = None, lights: list | None = None):
    sphere(tmp_path / "sphere.obj", subdivisions=2)
    quad(tmp_path / "floor.obj", size=3.0, y=-1.0)
    return make_scene(
        tmp_path,
        {
            "camera": {"position": [0, 0.5, 3.5], "target": [0, -0.2, 0], "fov_deg": 45},
            "materials": [
                {"name": "floor", "model": "lambert", "params": {"kd": [0.6, 0.5, 0.4]}},
                {"name": "ball", "model": "ggx" if "ggx" in {m.name for m in all_models()} else "lambert"},
            ],
            "meshes": [
                {"path": "floor.obj", "material": "floor"},
                {"path": "sphere.obj", "material": "ball", "smooth": True},
            ],
            "lights": lights
            or [
                {
                    "type": "quad",
                    "corner": [-0.5, 2.5, -0.5],
                    "edge1": [0, 0, 1],
                    "edge2": [1, 0, 0],
                    "radiance": 6,
                },
                {"type": "point", "position": [2, 2, 2], "intensity": [3, 3, 3]},
            ],
            "environment": env or {"type": "constant", "radiance": 0.3},
            "render": {"width": 16, "height": 16, "max_depth": 4, "rr_depth": 2, "sampler": sampler},
        },
    )


def test_same_seed_same_image_other_seed_other_image(tmp_path: Path) -> None:
    scene = _mixed_scene(tmp_path, "cosine")
    a = prepare(scene, seed=3).run(spp=2).image
    b = prepare(scene, seed=3).run(spp=2).image
    c = prepare(scene, seed=4).run(spp=2).image
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_strategies_converge_to_the_same_image(tmp_path: Path) -> None:
    """uniform, cosine, analytic and both modes of the adaptive sampler estimate the same image: 4x4-pixel
    blocks agree within a Bonferroni-corrected two-sided z-test at alpha = 0.01 (16 blocks x 3 channels x
    the number of pairs)."""
    others = ["uniform", "analytic", "adaptive_exact", "adaptive_warp"]
    passes = 24
    block_means = {}
    for s in ("cosine", *others):
        # adaptive: the initial layout only (rounds=1) keeps the build short; exactness does not depend on it
        opts = {"rounds": 1, "cache": str(tmp_path / "tables")} if s.startswith("adaptive_exact") else {}
        job = prepare(_mixed_scene(tmp_path, s), sampler_options=opts)
        per = []
        for k in range(passes):
            img = job.tracer.render_pass(k, 16).reshape(4, 4, 4, 4, 3)  # (by, y, bx, x, c)
            per.append(img.mean(axis=(1, 3)))
        block_means[s] = np.array(per)  # (passes, 4, 4, 3)
    from scipy.stats import norm

    tests = 16 * 3 * len(others)
    zcrit = norm.isf(0.01 / (2 * tests))
    ref = block_means["cosine"]
    for s in others:
        x = block_means[s]
        diff = x.mean(0) - ref.mean(0)
        se = np.sqrt(x.var(0, ddof=1) / passes + ref.var(0, ddof=1) / passes)
        z = np.abs(diff) / np.maximum(se, 1e-12)
        assert z.max() < zcrit, (s, z.max(), zcrit)
    # power: the images are not flat, so a wrong estimator would show
    assert ref.mean(0).std() > 0.05


def test_env_map_lit_plane_matches_constant_sky(tmp_path: Path) -> None:
    """A uniform-valued EXR map is the same light as a constant sky: same mean within noise."""
    from renderer.image_io import write_exr

    write_exr(tmp_path / "sky.exr", np.full((16, 32, 3), 0.7, dtype=np.float32))
    quad(tmp_path / "plane.obj", size=1000.0)
    results = {}
    for env in ({"type": "constant", "radiance": 0.7}, {"type": "map", "path": "sky.exr"}):
        scene = make_scene(
            tmp_path,
            {
                "camera": {"position": [0, 10, 10], "target": [0, 0, 0], "fov_deg": 1},
                "materials": [{"name": "m", "model": "lambert", "params": {"kd": 0.5}}],
                "meshes": [{"path": "plane.obj", "material": "m"}],
                "environment": env,
                "render": {"width": 8, "height": 8, "max_depth": 2, "sampler": "cosine"},
            },
        )
        results[env["type"]] = _pass_means(prepare(scene), 16)
    for means in results.values():
        m, se = means.mean(0), means.std(0, ddof=1) / math.sqrt(len(means))
        assert np.all(np.abs(m - 0.35) <= Z * se + 1e-9), (m, se)


HARD = [
    ("phong", {"n": 1e4}),
    ("blinn", {"n": 1e4}),
    ("lewis", {"n": 1e4}),
    ("ward", {"sx": 0.005, "sy": 0.005}),
    ("cook_torrance", {"m": 0.01}),
    ("minnaert", {"k": 0.2}),
    ("ashikhmin_shirley", {"nu": 1e4, "nv": 10.0}),
    ("lafortune", {"n": 10.5, "cz": -0.5}),
    ("oren_nayar", {"sigma": 0.66}),
]


@pytest.mark.parametrize(("model", "params"), HARD, ids=[h[0] for h in HARD])
def test_hard_materials_give_finite_pixels(tmp_path: Path, model: str, params: dict) -> None:
    if model not in {m.name for m in all_models()}:
        pytest.skip(f"model {model} not in the library yet")
    from core.brdf import get_model

    m = get_model(model)
    names = {p.name for p in m.params}
    params = {k: v for k, v in params.items() if k in names}
    if not params:
        pytest.skip(f"model {model} has none of the hard-case parameters")
    scene = _furnace_scene(tmp_path, model, params, "analytic" if m.sample else "cosine")
    scene.lights.append(PointLight(type="point", position=(0.5, 2, 2), intensity=(4, 4, 4)))
    job = prepare(scene, max_depth=4)
    img = job.run(spp=4).image
    assert np.all(np.isfinite(img))
    assert job.tracer.stats.nonfinite == 0
    assert img.min() >= 0.0


def test_ris_for_the_sky_matches_nee_with_mis(tmp_path: Path) -> None:
    """Lighting from a non-uniform sky map by RIS (8 candidates from the BRDF sampler) estimates the same
    image as NEE + MIS: 4x4-pixel blocks agree (Bonferroni-corrected z-test, alpha = 0.01)."""
    from scipy.stats import norm

    from renderer.image_io import write_exr

    sky = np.full((16, 32, 3), 0.2, dtype=np.float32)
    sky[2:5, 4:9] = 30.0  # a bright patch high in the sky
    write_exr(tmp_path / "sky.exr", sky)
    sphere(tmp_path / "ball.obj", subdivisions=2)
    quad(tmp_path / "floor.obj", size=4.0, y=-1.0)
    scene = make_scene(
        tmp_path,
        {
            "camera": {"position": [0, 0.6, 3.5], "target": [0, -0.3, 0], "fov_deg": 45},
            "materials": [
                {"name": "floor", "model": "lambert", "params": {"kd": 0.6}},
                {"name": "ball", "model": "phong", "params": {"n": 30}},
            ],
            "meshes": [
                {"path": "floor.obj", "material": "floor"},
                {"path": "ball.obj", "material": "ball", "smooth": True},
            ],
            "environment": {"type": "map", "path": "sky.exr"},
            "render": {"width": 16, "height": 16, "max_depth": 3, "rr_depth": 3, "sampler": "analytic"},
        },
    )
    passes = 24
    blocks = {}
    for m in (0, 8):
        job = prepare(scene, ris_candidates=m)
        blocks[m] = np.array(
            [job.tracer.render_pass(k, 16).reshape(4, 4, 4, 4, 3).mean(axis=(1, 3)) for k in range(passes)]
        )
    a, b = blocks[0], blocks[8]
    z = np.abs(a.mean(0) - b.mean(0)) / np.sqrt(a.var(0, ddof=1) / passes + b.var(0, ddof=1) / passes)
    assert z.max() < norm.isf(0.01 / (2 * z.size)), z.max()
    assert a.mean(0).std() > 0.05  # the image has structure


def test_image_does_not_depend_on_the_thread_split(tmp_path: Path) -> None:
    """Every random number is keyed by (seed, pass, path, bounce), never drawn in thread order: one thread
    and two threads (64 x 64 x 8 paths: two interleaved wavefronts, one on each thread) give the same image,
    bit for bit."""
    from renderer.wavefront import waves

    scene = _mixed_scene(tmp_path, "analytic")
    assert len(waves(0, 64 * 64 * 8)) == 2
    one = prepare(scene, width=64, height=64, threads=1, seed=5).tracer.render_pass(3, 8)
    two = prepare(scene, width=64, height=64, threads=2, seed=5).tracer.render_pass(3, 8)
    assert np.array_equal(one, two)
    assert one.max() > 0


def test_strategy_with_tables_does_not_depend_on_the_threads(tmp_path: Path) -> None:
    """The samplers with tables draw from generators seeded per wavefront, bounce, material and slice: one
    thread and two give the same image bit for bit for them too (passes of 4 wavefronts at 32 x 32 x 16
    paths when groups hold 8192 paths), and wavefront buffers that held another pass's rows (or garbage)
    change nothing: no stage reads a row it did not write."""
    import renderer.wavefront as wavefront

    scene = _mixed_scene(tmp_path, "adaptive_warp")
    opts = {"rounds": 1, "cache": str(tmp_path / "tables")}
    images = []
    for threads in (1, 2):
        job = prepare(scene, width=32, height=32, threads=threads, seed=7, sampler_options=opts)
        old = wavefront.WAVEFRONT
        wavefront.WAVEFRONT = 8192
        try:
            assert len(wavefront.waves(0, 32 * 32 * 16)) == 4
            images.append(job.tracer.render_pass(1, 16))
            job.tracer.render_pass(2, 16)
            for b in job.tracer.buffers:
                for v in b.arrays():
                    v.fill(-1 if v.dtype.kind in "iu" else True if v.dtype.kind == "b" else np.nan)
            images.append(job.tracer.render_pass(1, 16))
        finally:
            wavefront.WAVEFRONT = old
    for img in images[1:]:
        assert np.array_equal(images[0], img)
    assert images[0].max() > 0


@pytest.mark.parametrize("sampler", ["analytic", "cosine"])
def test_compiled_strategy_agrees_with_its_sampler_object(tmp_path: Path, sampler: str) -> None:
    """Strategies without tables are drawn in the renderer's compiled stage through the model dispatch; the
    same strategy through its sampler object (the path table-based strategies take) estimates the same
    image: 4x4-pixel blocks agree within a Bonferroni-corrected two-sided z-test at alpha = 0.01."""
    from scipy.stats import norm

    from renderer.stages.bsdf import BY_SAMPLER

    passes = 24
    blocks = {}
    for compiled in (True, False):
        job = prepare(_mixed_scene(tmp_path, sampler), seed=11 if compiled else 12)
        if not compiled:
            job.tracer.materials.strategy[:] = BY_SAMPLER
        else:
            assert np.all(job.tracer.materials.strategy != BY_SAMPLER)
        per = [job.tracer.render_pass(k, 16).reshape(4, 4, 4, 4, 3).mean(axis=(1, 3)) for k in range(passes)]
        blocks[compiled] = np.array(per)
    a, b = blocks[True], blocks[False]
    se = np.sqrt(a.var(0, ddof=1) / passes + b.var(0, ddof=1) / passes)
    z = np.abs(a.mean(0) - b.mean(0)) / np.maximum(se, 1e-12)
    assert z.max() < norm.isf(0.01 / (2 * 48)), z.max()
    assert a.mean(0).std() > 0.05


def test_two_seeds_agree_within_the_pass_to_pass_error(tmp_path: Path) -> None:
    """The error bars every statistical test here uses are honest: two renders with different seeds differ by
    what their pass-to-pass spread predicts. Over 4x4-pixel blocks x 3 channels, the sum of squared z-scores
    stays below the chi-square(48) quantile at alpha = 1e-4. Random numbers that repeated from pass to pass
    (a key without the pass) made the passes agree with each other more than with another seed: z ~ 4."""
    from scipy.stats import chi2

    passes = 24
    runs = []
    for seed in (41, 42):
        job = prepare(_mixed_scene(tmp_path, "cosine"), seed=seed)
        runs.append(np.array([job.tracer.render_pass(k, 16).reshape(4, 4, 4, 4, 3).mean(axis=(1, 3))
                              for k in range(passes)]))  # fmt: skip
    a, b = runs
    se = np.sqrt(a.var(0, ddof=1) / passes + b.var(0, ddof=1) / passes)
    z = (a.mean(0) - b.mean(0)) / np.maximum(se, 1e-12)
    assert np.sum(z**2) < chi2.isf(1e-4, z.size), np.sum(z**2)


def test_a_pass_in_several_wavefronts_is_the_same_pass(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A pass larger than ``WAVEFRONT`` paths runs as several groups of wavefronts one after the other
    (bounded memory): for strategies drawn in compiled code every random number is keyed by the path, so the
    image is the same bit for bit, and the per-path buffers never exceed one wavefront (half a group)."""
    import renderer.wavefront as wavefront

    scene = _mixed_scene(tmp_path, "analytic")
    whole = prepare(scene, width=32, height=32, seed=9).tracer.render_pass(2, 4)
    monkeypatch.setattr(wavefront, "WAVEFRONT", 1000)
    job = prepare(scene, width=32, height=32, seed=9)
    split = job.tracer.render_pass(2, 4)
    assert np.array_equal(whole, split)
    assert max(w.n for w in wavefront.waves(0, 32 * 32 * 4)) == 512
    assert 1 <= len(job.tracer.buffers) <= job.tracer.threads
    assert max(len(b) for b in job.tracer.buffers) <= 512


def test_merl_tables_in_float32_evaluate_as_the_model(tmp_path: Path) -> None:
    """A MERL material's table reaches the compiled BRDF stage as float32 (``materials.tables``; half the cache
    footprint): its evaluations equal the model's own (float64 table) to float32 rounding, at random
    direction pairs, and no float64 row of ``materials.params`` is padded to the table's width."""
    from numba import njit

    from core.dispatch import MERL, eval_model
    from renderer.stages.bsdf import _eval

    @njit(cache=False)
    def both(mid, wi, wo, prm, table):  # type: ignore[no-untyped-def]
        out = np.empty((wi.shape[0], 2, 3))
        for i in range(wi.shape[0]):
            a = (wi[i, 0], wi[i, 1], wi[i, 2])
            b = (wo[i, 0], wo[i, 1], wo[i, 2])
            out[i, 0, 0], out[i, 0, 1], out[i, 0, 2] = _eval(mid, a, b, np.zeros(1), table)
            out[i, 1, 0], out[i, 1, 1], out[i, 1, 2] = eval_model(mid, a, b, prm)
        return out

    quad(tmp_path / "quad.obj")
    binary = Path(__file__).resolve().parents[2] / "resources" / "materials" / "red_plastic_ct.binary"
    scene = make_scene(
        tmp_path,
        {
            "camera": {"position": [0, 2, 2], "target": [0, 0, 0], "fov_deg": 40},
            "materials": [{"name": "m", "measured": str(binary)}],
            "meshes": [{"path": "quad.obj", "material": "m"}],
            "environment": {"type": "constant", "radiance": 1.0},
            "render": {"width": 8, "height": 8, "sampler": "cosine"},
        },
    )
    job = prepare(scene, warm_up=False)
    tr = job.tracer
    (m,) = [k for k, rt in enumerate(job.world.materials_by_index) if rt is not None]
    mats = tr.materials
    assert mats.model[m] == MERL and mats.tables.dtype == np.float32
    assert mats.params.shape[1] < 100 and mats.tables.shape[1] == len(
        job.world.materials_by_index[m].brdf.params
    )
    rng = np.random.default_rng(3)
    v = rng.normal(size=(2, 4000, 3))
    v[..., 2] = np.abs(v[..., 2])
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    prm = np.ascontiguousarray(job.world.materials_by_index[m].brdf.params, dtype=np.float64)
    out = both(MERL, v[0], v[1], prm, mats.tables[m])
    assert np.count_nonzero(out[:, 1]) > 1000
    assert np.allclose(out[:, 0], out[:, 1], rtol=1e-6, atol=1e-12)


def test_compiled_hemisphere_samples_are_the_lobes_directions() -> None:
    """The compiled stage's cosine and uniform hemisphere samples (azimuth by an octant table and a Taylor
    series, no sin/cos call) are the directions of core's lobes (sin/cos of 2 pi u2) to 2e-15, unit length,
    at random points and at both sides of every octant's edge."""
    from numba import njit

    from core.models.lobes import cosine_hemisphere, uniform_hemisphere
    from renderer.stages.bsdf import _cosine_hemisphere, _uniform_hemisphere

    @njit(cache=False)
    def directions(u):  # type: ignore[no-untyped-def]
        out = np.empty((u.shape[0], 4, 3))
        for i in range(u.shape[0]):
            out[i, 0, 0], out[i, 0, 1], out[i, 0, 2] = _cosine_hemisphere(u[i, 0], u[i, 1])
            out[i, 1, 0], out[i, 1, 1], out[i, 1, 2] = cosine_hemisphere(u[i, 0], u[i, 1])
            out[i, 2, 0], out[i, 2, 1], out[i, 2, 2] = _uniform_hemisphere(u[i, 0], u[i, 1])
            out[i, 3, 0], out[i, 3, 1], out[i, 3, 2] = uniform_hemisphere(u[i, 0], u[i, 1])
        return out

    rng = np.random.default_rng(5)
    edges = np.concatenate([np.arange(9) / 8 + e for e in (-1e-12, 0.0, 1e-12)])
    u2 = np.clip(np.concatenate([rng.random(50000), edges, [1 - 2**-53]]), 0.0, 1 - 2**-53)
    u = np.stack([rng.random(len(u2)), u2], axis=1)
    d = directions(u)
    assert np.abs(d[:, 0] - d[:, 1]).max() < 2e-15
    assert np.abs(d[:, 2] - d[:, 3]).max() < 2e-15
    assert np.abs(np.linalg.norm(d[:, 0], axis=1) - 1.0).max() < 2e-15
