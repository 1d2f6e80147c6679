"""RGL .bsdf materials: the tensor-file container, the reader's checks, the export of analytic models, the
lookup, and the file's luminance-warp sampler.

Tolerances:
- write -> read round trip: bit-exact (float32 arrays are copied, never converted).
- at the export's own nodes (a conditioning polar angle of the table and a node of the sample grid) the
  lookup returns the analytic ``f`` to 1e-4 relative: the stored value is ``f`` divided by the reader's own
  ``D / (4 sigma cos)`` factor, so only float32 storage (6e-8) and the angles recomputed from directions
  (a sample-square coordinate moves by ~1e-12) separate them.
- between nodes the lookup interpolates: its error is the table's resolution's, so the test checks that
  doubling every grid halves the median error at least (bilinear interpolation is second order: /4).
- Mitsuba 3's ``measured`` plugin (an independent reader in float32) agrees with ours to 1e-4 relative,
  ``f cos`` against its ``eval`` and the density against its ``pdf``.
- chi-square (core.chi2, Sidak-corrected 1 % over the cases) of the luminance-warp draws.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core.brdf import make_brdf
from core.errors import FileFormatError
from core.geometry import degrees_to_dir
from core.kernels import eval_batch
from core.measured import load_measured, write_measured
from core.rgl.export import ExportOptions, eval_table, tabulate
from core.rgl.material import RGL, RGL_ANISOTROPIC, read_bsdf, rgl_brdf, write_bsdf
from core.rgl.tensor_file import read_tensor_file, write_tensor_file
from core.sampling import make_sampler
from tests.core._rgl_checks import assert_clear_errors, assert_warp_chi2

PHONG = make_brdf("phong", {"n": 100, "ks": 0.4, "kd": 0.6})
WARD = make_brdf("ward", {"sx": 0.05, "sy": 0.25})
SMALL = ExportOptions(n_theta_i=8, n_phi_quadrant=4, vndf=(32, 32), samples=(16, 16), ndf=(32, 32))


def _hemisphere(rng: np.random.Generator, n: int, min_z: float = 0.05) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return v[v[:, 2] > min_z]


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("rgl")
    out = {}
    for name, brdf in (("phong", PHONG), ("ward", WARD)):
        out[name] = folder / f"{name}.bsdf"
        write_bsdf(out[name], brdf)
    return out


# ------------------------------------------------------------------------------------------ container


def test_tensor_file_round_trip_is_bit_exact(tmp_path):
    rng = np.random.default_rng(3)
    fields = {
        "text": "a material",
        "u8": np.arange(5, dtype=np.uint8),
        "f32": rng.random((3, 4, 5)).astype(np.float32),
        "f64": rng.random(7),
        "i32": np.array([[-1, 2], [3, -4]], dtype=np.int32),
    }
    write_tensor_file(tmp_path / "t.bsdf", fields)
    back = read_tensor_file(tmp_path / "t.bsdf")
    assert bytes(back["text"]).decode() == "a material"
    for name in ("u8", "f32", "f64", "i32"):
        assert back[name].dtype == fields[name].dtype and np.array_equal(back[name], fields[name])
    data = (tmp_path / "t.bsdf").read_bytes()
    assert data[:12] == b"tensor_file\0" and data[12:14] == bytes([1, 0])


def test_bsdf_round_trip_is_exact(files, tmp_path):
    table = read_bsdf(files["ward"])
    write_bsdf(tmp_path / "again.bsdf", table)
    again = read_bsdf(tmp_path / "again.bsdf")
    for name, value in table.fields().items():
        other = again.fields()[name]
        assert (value == other) if isinstance(value, str) else np.array_equal(value, other), name
    assert (tmp_path / "again.bsdf").read_bytes() == files["ward"].read_bytes()


def test_models_and_traits(files):
    assert rgl_brdf(files["phong"]).model is RGL
    ward = rgl_brdf(files["ward"])
    assert ward.model is RGL_ANISOTROPIC and ward.table.reduction == 4
    assert load_measured(files["ward"]).model is RGL_ANISOTROPIC


# ------------------------------------------------------------------------------------------ lookups


def _node_pairs(brdf, options: ExportOptions):
    """Every (wi, wo) pair at the export's nodes (the sample grid's nodes warped by the table's VNDF), and
    the table's kernel vector."""
    from core.rgl.export import node_pairs
    from core.rgl.material import kernel_vector

    table = tabulate(brdf, options)
    wi, wo, _ = node_pairs(table)
    keep = wi[:, 2] > 0.05
    return kernel_vector(table), wi[keep], wo[keep]


@pytest.mark.parametrize("brdf", [PHONG, WARD], ids=["phong", "ward"])
def test_lookup_is_the_source_at_the_nodes(brdf):
    p, wi, wo = _node_pairs(brdf, SMALL)
    f = brdf.eval(wo, wi)
    g = eval_table(p, wi, wo)
    big = f > 1e-3 * f.max()
    assert big.sum() > 500
    rel = np.abs(g[big] - f[big]) / f[big]
    assert rel.max() < 1e-4, rel.max()


@pytest.mark.parametrize("brdf", [PHONG, WARD], ids=["phong", "ward"])
def test_lookup_converges_with_the_resolution(brdf, rng):
    """Between nodes the error is the interpolation's: double every grid, the median error falls >= 2x."""
    coarse = SMALL
    fine = ExportOptions(n_theta_i=15, n_phi_quadrant=7, vndf=(64, 64), samples=(32, 32), ndf=(64, 64))
    wi, wo = _hemisphere(rng, 6000, 0.2), _hemisphere(rng, 6000, 0.2)
    n = min(len(wi), len(wo))
    wi, wo = wi[:n], wo[:n]
    keep = np.degrees(np.arccos(wo[:, 2])) < 75.0
    wi, wo = wi[keep], wo[keep]
    f = brdf.eval(wo, wi)[:, 1]
    big = f > 1e-2 * f.max()
    errors = []
    for options in (coarse, fine):
        from core.rgl.material import kernel_vector

        g = eval_table(kernel_vector(tabulate(brdf, options)), wi, wo)[:, 1]
        errors.append(float(np.median(np.abs(g[big] - f[big]) / f[big])))
    assert errors[1] < 0.5 * errors[0], errors
    assert errors[1] < 0.02, errors


def test_lambertian_file_is_lambertian(tmp_path, rng):
    path = tmp_path / "white.bsdf"
    write_measured(path, make_brdf("lambert", {"kd": 0.8}))
    brdf = load_measured(path)
    wi, wo = _hemisphere(rng, 3000, 0.1), _hemisphere(rng, 3000, 0.1)
    n = min(len(wi), len(wo))
    got = brdf.eval(wo[:n], wi[:n])
    rel = np.abs(got / (0.8 / math.pi) - 1.0)
    assert np.median(rel) < 0.01 and np.percentile(rel, 90) < 0.05


def test_dispatch_reaches_the_kernel(files, rng):
    brdf = rgl_brdf(files["ward"])
    wi, wo = _hemisphere(rng, 500), _hemisphere(rng, 500)
    n = min(len(wi), len(wo))
    a = eval_batch(brdf.model.id, wi[:n], wo[:n], brdf.params)
    b = eval_table(brdf.params, wi[:n], wo[:n])
    assert np.array_equal(a, b)


def test_anisotropic_file_mirrors_the_quadrant(files, rng):
    """A quadrant file serves every azimuth: mirrored pairs (x -> -x, y -> -y) give the same value."""
    brdf = rgl_brdf(files["ward"])
    wi, wo = _hemisphere(rng, 800), _hemisphere(rng, 800)
    n = min(len(wi), len(wo))
    wi, wo = wi[:n], wo[:n]
    base = brdf.eval(wo, wi)
    for sx, sy in ((-1, 1), (1, -1), (-1, -1)):
        s = np.array([sx, sy, 1.0])
        assert np.allclose(brdf.eval(wo * s, wi * s), base, rtol=1e-12, atol=0.0)


def test_mitsuba_reads_our_files_as_we_do(files, rng):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    for name in ("phong", "ward"):
        brdf = rgl_brdf(files[name])
        bsdf = mi.load_dict({"type": "measured", "filename": str(files[name])})
        ctx = mi.BSDFContext()
        wi, wo = _hemisphere(rng, 200), _hemisphere(rng, 200)
        n = min(len(wi), len(wo))
        ours = brdf.eval(wo[:n], wi[:n]) * wi[:n, 2:]
        ours_pdf = make_sampler("analytic", brdf).pdf(wo[:n], wi[:n])
        theirs, theirs_pdf = [], []
        for a, c in zip(wi[:n], wo[:n], strict=True):
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*c)
            v = bsdf.eval(ctx, si, mi.Vector3f(*a))
            theirs.append([v[0], v[1], v[2]])
            theirs_pdf.append(bsdf.pdf(ctx, si, mi.Vector3f(*a)))
        theirs = np.array(theirs)
        theirs_pdf = np.array(theirs_pdf)
        scale = np.maximum(np.abs(theirs), 1e-3 * theirs.max())
        assert np.max(np.abs(ours - theirs) / scale) < 1e-4, name
        scale = np.maximum(theirs_pdf, 1e-3 * theirs_pdf.max())
        assert np.max(np.abs(ours_pdf - theirs_pdf) / scale) < 1e-4, name


# ------------------------------------------------------------------------------------------ the sampler

CHI2_CASES = [("phong", 0.0), ("phong", 60.0), ("ward", 30.0), ("ward", 75.0)]


def test_draws_carry_their_pdf(files):
    for name in ("phong", "ward"):
        s = make_sampler("analytic", rgl_brdf(files[name]))
        for theta in (0.0, 45.0, 80.0):
            wo = degrees_to_dir(theta, 30.0)
            drawn = s.sample(wo, 20000, seed=4)
            ok = drawn.pdf > 0.0
            assert ok.mean() > 0.99
            again = s.pdf(np.broadcast_to(wo, drawn.wi[ok].shape), drawn.wi[ok])
            assert np.allclose(again, drawn.pdf[ok], rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("name,theta", CHI2_CASES)
def test_luminance_warp_chi2(files, name, theta):
    """The draws' density integrates to 1 over the sphere and chi-square passes (tests/core/_rgl_checks.py)."""
    sampler = make_sampler("analytic", rgl_brdf(files[name]))
    assert_warp_chi2(sampler, degrees_to_dir(theta, 20.0), n_tests=len(CHI2_CASES), seed=7)


# ------------------------------------------------------------------------------------------ bad files


def _variants(good: Path, folder: Path) -> dict[str, tuple[Path, str]]:
    """Broken copies of a good file, with a phrase the error must contain."""
    data = good.read_bytes()
    fields = read_tensor_file(good)
    out: dict[str, tuple[Path, str]] = {}

    def put(name: str, content: bytes | dict, phrase: str) -> None:
        path = folder / f"{name}.bsdf"
        if isinstance(content, dict):
            write_tensor_file(path, content)
        else:
            path.write_bytes(content)
        out[name] = (path, phrase)

    put("empty", b"", "truncated")
    put("header_only", data[:16], "truncated")
    put("cut_in_headers", data[:60], "truncated")
    put("cut_in_data", data[: len(data) // 2], "truncated")
    put("not_tensor", b"P" * 100, "not a tensor file")
    put("version", data[:12] + bytes([2, 0]) + data[14:], "version")
    put("missing_rgb", {k: v for k, v in fields.items() if k != "rgb"}, "no field 'rgb'")
    put("spectral", {**{k: v for k, v in fields.items() if k != "rgb"}, "spectra": fields["rgb"]}, "spectral")
    put("wrong_type", {**fields, "vndf": fields["vndf"].astype(np.float64)}, "'vndf' is float64")
    put("mismatch", {**fields, "rgb": fields["rgb"][:, :-1]}, "'rgb' has shape")
    nan = fields["luminance"].copy()
    nan[0, 0, 0, 0] = np.nan
    put("nan", {**fields, "luminance": nan}, "NaN")
    neg = fields["sigma"].copy()
    neg[0, 0] = -1.0
    put("negative", {**fields, "sigma": neg}, "negative")
    put("theta", {**fields, "theta_i": fields["theta_i"][::-1].copy()}, "increasing")
    return out


def test_bad_files_give_one_clear_error(files, tmp_path):
    assert_clear_errors(_variants(files["phong"], tmp_path))
    with pytest.raises(FileFormatError, match="does not exist"):
        read_bsdf(tmp_path / "none.bsdf")
    with pytest.raises(FileFormatError, match="not a measured BRDF file"):
        load_measured(tmp_path / "x.txt")


def test_cli_exit_code_2_on_bad_file(files, tmp_path):
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(files["phong"].read_bytes()[:1000])
    run = subprocess.run(
        [sys.executable, "-m", "app.cli", "eval", "--measured", str(bad), "--wi", "30,0", "--wo", "45,180"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 2, run.stderr
    lines = [line for line in run.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "truncated" in lines[0] and "Traceback" not in run.stderr


def test_scene_file_with_a_bsdf_material(files, tmp_path):
    import json
    import shutil

    from core.scene import load_scene

    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    shutil.copy(files["ward"], tmp_path / "steel.bsdf")
    scene = {
        "version": 2,
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 40},
        "materials": [{"name": "steel", "measured": "steel.bsdf"}],
        "meshes": [{"path": "tri.obj", "material": "steel"}],
        "lights": [{"type": "point", "position": [0, 2, 0], "intensity": 1}],
        "render": {"width": 8, "height": 8, "spp": 1},
    }
    (tmp_path / "scene.json").write_text(json.dumps(scene))
    loaded = load_scene(tmp_path / "scene.json")
    brdf = load_measured(loaded.resolve(loaded.materials[0].measured))
    assert brdf.model is RGL_ANISOTROPIC
    (tmp_path / "steel.bsdf").write_bytes(b"tensor_file")
    with pytest.raises(FileFormatError, match="truncated"):
        load_measured(loaded.resolve(loaded.materials[0].measured))


def test_views_on_the_axes_are_continuous(files):
    """A quadrant file folds views exactly on the x and y axes into its stored azimuths (by the sign bit of a
    zero coordinate): the value there is the value a hair away on either side, and the source's, up to the
    table's interpolation (2 %; at the quadrant's edges the two sides read mirrored ``wi``, 0.6 % apart for
    this pair). Folding ``+0`` the wrong way read a slice 90 degrees away: 18 % off."""
    brdf = rgl_brdf(files["ward"])
    t = math.radians(45.0)
    wi = np.array([-0.3, 0.2, 0.93]) / np.linalg.norm([-0.3, 0.2, 0.93])
    for phi in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi):
        values = []
        for d in (0.0, 1e-7, -1e-7):
            wo = np.array([math.sin(t) * math.cos(phi + d), math.sin(t) * math.sin(phi + d), math.cos(t)])
            if d == 0.0:  # exact zeros, as a renderer's frame can produce them
                wo[np.abs(wo) < 1e-12] = 0.0
            values.append(brdf.eval(wo, wi)[0])
        truth = WARD.eval(wo, wi)[0]
        for v in values:
            assert np.allclose(v, truth, rtol=0.02), (phi, v, truth)
