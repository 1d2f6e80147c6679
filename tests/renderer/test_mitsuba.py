"""Cross-check against Mitsuba 3 (scalar_rgb): its Cornell box, rebuilt as our scene, renders the same image
within noise. Slow (a few hundred spp on both sides): run with ``pytest -m slow``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

SIZE = 32
DEPTH = 6  # bounces; Mitsuba counts path vertices, so its max_depth is DEPTH + 1


def _cornell_dict() -> dict:
    mi.set_variant("scalar_rgb")
    d = mi.cornell_box()
    d["sensor"]["film"].update(width=SIZE, height=SIZE, rfilter={"type": "box"})
    d["integrator"] = {"type": "path", "max_depth": DEPTH + 1}
    return d


def _write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    path.write_text("\n".join(lines) + "\n")


def build_our_scene(folder: Path) -> Path:
    """Our scene file for Mitsuba's Cornell box: rectangles and the merged boxes exported as OBJ meshes,
    diffuse reflectances as Lambert, the area emitter as an emissive material, the same pinhole camera."""
    d = _cornell_dict()
    scene = mi.load_dict(d)
    materials: dict[str, dict] = {}
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
        materials[name] = {"name": name, "model": "lambert", "params": {"kd": rgb}, "emission": emit}
        _write_obj(folder / f"shape{k}.obj", v, f)
        meshes.append({"path": f"shape{k}.obj", "material": name})
    sensor = scene.sensors()[0]
    m = np.array(mi.traverse(sensor)["to_world"].matrix, dtype=float)
    pos = m[:3, 3]
    fwd = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
    up = m[:3, :3] @ np.array([0.0, 1.0, 0.0])
    data = {
        "version": 1,
        "camera": {
            "position": pos.tolist(),
            "target": (pos + fwd).tolist(),
            "up": up.tolist(),
            "fov_deg": float(d["sensor"]["fov"]),
        },  # fmt: skip
        "materials": list(materials.values()),
        "meshes": meshes,
        "render": {"width": SIZE, "height": SIZE, "max_depth": DEPTH, "rr_depth": 5, "sampler": "cosine"},
    }
    path = folder / "cornell.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.slow
def test_cornell_box_matches_mitsuba(tmp_path: Path) -> None:
    from scipy.stats import norm

    from core.scene import load_scene
    from renderer.render import prepare

    d = _cornell_dict()
    mscene = mi.load_dict(d)
    runs = 8
    theirs = np.array([np.array(mi.render(mscene, spp=128, seed=s)) for s in range(runs)])  # (runs, h, w, 3)

    job = prepare(load_scene(build_our_scene(tmp_path)))
    passes = 32
    ours = np.array([job.tracer.render_pass(k, 16).reshape(SIZE, SIZE, 3) for k in range(passes)])

    def blocks(x: np.ndarray) -> np.ndarray:  # (n, 8, 8, 3): means over 4x4-pixel blocks
        return x.reshape(len(x), 8, 4, 8, 4, 3).mean(axis=(2, 4))

    a, b = blocks(ours), blocks(theirs)
    diff = a.mean(0) - b.mean(0)
    se = np.sqrt(a.var(0, ddof=1) / len(a) + b.var(0, ddof=1) / len(b))
    z = np.abs(diff) / np.maximum(se, 1e-12)
    tests = z.size
    zcrit = norm.isf(0.01 / (2 * tests))  # Bonferroni, alpha = 0.01 two-sided
    assert z.max() < zcrit, (float(z.max()), zcrit, float(np.abs(diff).max()))
    # and the mean brightness agrees to 1 %
    assert np.allclose(a.mean((0, 1, 2)), b.mean((0, 1, 2)), rtol=0.01)
    assert math.isfinite(float(z.max()))
