"""A scene made ready to render: triangles in one Embree BVH, per-triangle materials and emission, light
selection tables, the environment, and one BRDF + sampler per material.

"Model only what a scene needs": only the scene's materials get a BRDF and a sampler (an adaptive sampler
builds its tables for them alone), in :meth:`World.compile`. The compiled loops serve every model by its id
and are compiled once per machine at setup (``python -m core.warmup``); here they are loaded, or compiled if
the warm-up did not run.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from core.brdf import BRDF, LUMINANCE, make_brdf
from core.errors import BrdfStudioError, UnknownNameError
from core.sampling import Sampler, make_sampler
from core.sampling.base import current_sampler, current_sampler_name
from core.scene import Material, QuadLight, Scene, kept_groups
from renderer.accel import Accel
from renderer.envmap import ConstantEnvironment, EnvironmentMap, load_environment
from renderer.mesh import MeshPart, load_mesh_file

NO_MATERIAL = -1  # a surface that only emits (a quad light): it reflects nothing

StepCallback = Callable[[str, int, int], None]


@dataclass
class MaterialRuntime:
    """A scene material bound for rendering: its BRDF and the sampler that draws its directions."""

    name: str
    brdf: BRDF
    sampler: Sampler
    sampler_name: str
    note: str = ""
    info: dict[str, Any] = field(default_factory=dict)


def load_brdf(scene: Scene, index: int, mat: Material) -> BRDF:
    where = f"materials[{index}]"
    try:
        if mat.measured is not None:
            from core.measured import load_measured

            return load_measured(scene.resolve(mat.measured))
        return make_brdf(mat.model or "", mat.params)
    except BrdfStudioError as exc:
        if str(exc).startswith(scene.source):
            raise
        raise scene.error(f"{where}.measured" if mat.measured else f"{where}.params", str(exc)) from None


def bind_sampler(brdf: BRDF, name: str, options: dict[str, Any]) -> tuple[Sampler, str, str]:
    """The sampler ``name`` for ``brdf``; a model with no analytic sampler falls back to cosine (and says so)."""
    try:
        return make_sampler(name, brdf, **options), name, ""
    except UnknownNameError:
        if name != "analytic":
            raise
        note = f"model '{brdf.name}' has no analytic sampler: cosine used instead"
        return make_sampler("cosine", brdf), "cosine", note


class World:
    """Everything the integrator reads, as flat arrays indexed by triangle."""

    def __init__(
        self,
        scene: Scene,
        sampler: str | None = None,
        sampler_options: dict[str, Any] | None = None,
        threads: int = 2,
        material_samplers: dict[str, str] | None = None,
    ):
        self.scene = scene
        # a former strategy name (``adaptive``) is read as the current one, with the notice that names it
        self.sampler_name, self.sampler_options = current_sampler(
            sampler or scene.render.sampler,
            scene.render.sampler_options if sampler_options is None else sampler_options,
        )
        self.threads = threads
        self.material_samplers = {k: current_sampler_name(v) for k, v in (material_samplers or {}).items()}
        """Per-material strategy overrides by material name (others use ``sampler_name``)."""
        unknown = set(self.material_samplers) - {m.name for m in scene.materials}
        if unknown:
            raise scene.error(
                "materials", f"no material named {', '.join(sorted(unknown))} (sampler override)"
            )
        self.materials: list[MaterialRuntime] = []
        self._build_geometry()
        self._build_lights()

    # --------------------------------------------------------------------------------------- geometry
    def _build_geometry(self) -> None:
        scene = self.scene
        verts: list[np.ndarray] = []
        faces: list[np.ndarray] = []
        vnorm: list[np.ndarray] = []
        tri_mat: list[np.ndarray] = []
        tri_smooth: list[np.ndarray] = []
        tri_emit: list[np.ndarray] = []
        tri_two: list[np.ndarray] = []
        offset = 0

        def add(part: MeshPart, material: int, smooth: bool, emission: np.ndarray, two_sided: bool) -> None:
            nonlocal offset
            verts.append(part.vertices)
            faces.append(part.faces + offset)
            vnorm.append(part.normals)
            m = len(part.faces)
            tri_mat.append(np.full(m, material, dtype=np.int64))
            tri_smooth.append(np.full(m, smooth))
            tri_emit.append(np.tile(emission, (m, 1)))
            tri_two.append(np.full(m, two_sided))
            offset += len(part.vertices)

        for i, mesh in enumerate(scene.meshes):
            parts = load_mesh_file(
                scene.resolve(mesh.path), mesh.transform, f"{scene.source}: meshes[{i}].path"
            )
            keep = kept_groups(scene, i, [part.name for part in parts])
            parts = [part for part, kept in zip(parts, keep, strict=True) if kept]
            for part in parts:
                mname = mesh.group_materials.get(part.name, mesh.material)
                mi = scene.material_index(mname)
                emission = np.asarray(scene.materials[mi].emission, dtype=np.float64)
                add(part, mi, mesh.smooth, emission, False)
        for i, light in enumerate(scene.lights):
            if isinstance(light, QuadLight):
                c, e1, e2 = (
                    np.asarray(x, dtype=np.float64) for x in (light.corner, light.edge1, light.edge2)
                )
                v = np.stack([c, c + e1, c + e1 + e2, c + e2])
                f = np.array([[0, 1, 2], [0, 2, 3]])
                n = np.cross(e1, e2)
                n = n / np.linalg.norm(n)
                add(MeshPart(f"lights[{i}]", v, f, np.tile(n, (4, 1))), NO_MATERIAL, False,
                    np.asarray(light.radiance, dtype=np.float64), light.two_sided)  # fmt: skip
        if not faces:
            raise scene.error("meshes", "the scene has no geometry (add a mesh or a quad light)")
        v = np.concatenate(verts)
        f = np.concatenate(faces)
        self.tri_material = np.concatenate(tri_mat)
        self.tri_smooth = np.concatenate(tri_smooth)
        self.tri_emission = np.concatenate(tri_emit)
        self.tri_two_sided = np.concatenate(tri_two)
        self.tri_emissive = self.tri_emission.max(axis=1) > 0.0
        self.v0 = v[f[:, 0]]
        self.e1 = v[f[:, 1]] - self.v0
        self.e2 = v[f[:, 2]] - self.v0
        cross = np.cross(self.e1, self.e2)
        length = np.linalg.norm(cross, axis=1)
        self.tri_area = 0.5 * length
        self.tri_normal = cross / length[:, None]
        vn = np.concatenate(vnorm)
        self.tri_vnormals = vn[f]  # (T, 3, 3)
        lo, hi = v.min(axis=0), v.max(axis=0)
        self.bounds = (lo, hi)
        extent = float(np.linalg.norm(hi - lo) + np.abs(np.concatenate([lo, hi])).max())
        self.eps = max(1e-6, 5e-6 * extent)
        self.accel = Accel(v, f, threads=self.threads)
        self.n_triangles = len(f)

    # ----------------------------------------------------------------------------------------- lights
    def _build_lights(self) -> None:
        scene = self.scene
        emit = np.nonzero(self.tri_emissive)[0]
        w = self.tri_area[emit] * (self.tri_emission[emit] @ LUMINANCE)
        self.emit_ids = emit
        self.emit_cdf = np.cumsum(w) / w.sum() if len(emit) else np.zeros(0)
        # probability of picking a triangle, per unit area (0 for non-emitters): the area-light pdf
        self.emit_pmf_per_area = np.zeros(self.n_triangles)
        if len(emit):
            self.emit_pmf_per_area[emit] = (w / w.sum()) / self.tri_area[emit]

        pts = [lt for lt in scene.lights if lt.type == "point"]
        self.point_pos = np.array([p.position for p in pts], dtype=np.float64).reshape(-1, 3)
        self.point_intensity = np.array([p.intensity for p in pts], dtype=np.float64).reshape(-1, 3)
        pw = self.point_intensity @ LUMINANCE if len(pts) else np.zeros(0)
        keep = pw > 0
        self.point_pos, self.point_intensity, pw = self.point_pos[keep], self.point_intensity[keep], pw[keep]
        self.point_pmf = pw / pw.sum() if len(pw) else np.zeros(0)
        self.point_cdf = np.cumsum(self.point_pmf)

        self.env: ConstantEnvironment | EnvironmentMap | None = load_environment(scene.environment, scene)
        if self.env is not None and self.env.power_weight <= 0.0:
            self.env = None
        # the choice between light types (and RIS for the sky) belongs to the integrator

    # ------------------------------------------------------------------------------------- materials
    def refresh_samplers(self) -> int:
        """Let every material's sampler swap in a better table built in the background (see
        :meth:`core.sampling.Sampler.refresh`); returns how many changed."""
        return sum(bool(rt.sampler.refresh()) for rt in self.materials_by_index if rt is not None)

    def compile(self, on_step: StepCallback | None = None, parallel: bool = False) -> dict[str, Any]:
        """Bind each used material's BRDF and sampler, load (or compile) the kernels they use and build sampler
        tables. Reports each step through ``on_step``. ``parallel`` also loads the multi-threaded evaluation
        (only worth it for large batches)."""
        scene = self.scene
        used = sorted({int(m) for m in np.unique(self.tri_material) if m != NO_MATERIAL})
        steps = len(used)
        report: dict[str, Any] = {"materials": {}, "compile_seconds": 0.0}
        compiled_models: set[str] = set()
        runtimes: list[MaterialRuntime | None] = [None] * len(scene.materials)
        t_all = time.perf_counter()
        for k, mi in enumerate(used):
            mat = scene.materials[mi]
            if on_step:
                on_step(f"material '{mat.name}'", k, steps)
            t0 = time.perf_counter()
            brdf = load_brdf(scene, mi, mat)
            override = self.material_samplers.get(mat.name)
            if override is not None:
                sampler, used_name, note = bind_sampler(brdf, override, {})
                note = (note + "; " if note else "") + f"sampler '{used_name}' set for this material"
            else:
                sampler, used_name, note = bind_sampler(brdf, self.sampler_name, self.sampler_options)
            # one call of each kernel on one direction compiles it (eval, sample, pdf)
            wo = np.array([[0.0, 0.6, 0.8]])
            brdf.eval(wo, wo)
            if parallel:
                brdf.eval(wo, wo, threads=True)
            sampler.sample_each(wo, seed=0)
            sampler.pdf(wo, np.array([[0.0, -0.6, 0.8]]))
            seconds = time.perf_counter() - t0
            info = dict(sampler.info())
            info.update(
                model=brdf.name,
                sampler=used_name,
                prepare_seconds=round(seconds, 3),
                first_model_use=brdf.name not in compiled_models,
            )
            if note:
                info["note"] = note
            compiled_models.add(brdf.name)
            runtimes[mi] = MaterialRuntime(mat.name, brdf, sampler, used_name, note, info)
            report["materials"][mat.name] = info
        if on_step:
            on_step("ready", steps, steps)
        self.materials_by_index = runtimes
        report["compile_seconds"] = round(time.perf_counter() - t_all, 3)
        report["models_compiled"] = sorted(compiled_models)
        return report
