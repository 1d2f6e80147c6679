"""The scene file's schema: its versions, the limits of its values, and one pydantic class per part (camera,
materials, meshes, lights, environment, render settings), unknown keys refused."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator

from core.errors import FileFormatError

SCENE_VERSION = 2
READABLE_VERSIONS = (1, 2)
"""Schema versions this program reads; it writes :data:`SCENE_VERSION`."""
MESH_FORMATS = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
MEASURED_FORMATS = (".binary", ".bsdf")  # core.measured.FORMATS
ENVMAP_FORMATS = (".exr",)


class SceneError(FileFormatError):
    """A scene file is unreadable, invalid, or names something that does not exist."""


MAX_COORD = 1e6
"""Largest coordinate (positions, translations, edges) in scene units: Embree traces in float32, whose
7 significant digits leave nothing of a scene placed further out."""
MAX_RADIANCE = 1e9
"""Largest radiance, intensity, emission or environment scale per channel: with BRDF peaks of up to ~1e7
and path throughputs above 1, larger values overflow the float32 image (3.4e38) or its running sums."""
MAX_ANGLE_DEG = 3600.0
MIN_SCALE, MAX_SCALE = 1e-6, 1e6
MAX_SPP = 1_000_000
MAX_SECONDS = 7 * 24 * 3600.0
"""The longest time budget a scene may ask for (one week)."""
MAX_SEED = 2**32 - 1

NonNeg = Annotated[float, Field(ge=0.0)]
Coord = Annotated[float, Field(ge=-MAX_COORD, le=MAX_COORD)]
Vec3 = tuple[Coord, Coord, Coord]
Angles = tuple[
    Annotated[float, Field(ge=-MAX_ANGLE_DEG, le=MAX_ANGLE_DEG)],
    Annotated[float, Field(ge=-MAX_ANGLE_DEG, le=MAX_ANGLE_DEG)],
    Annotated[float, Field(ge=-MAX_ANGLE_DEG, le=MAX_ANGLE_DEG)],
]
Radiance = Annotated[float, Field(ge=0.0, le=MAX_RADIANCE)]
RGB = tuple[Radiance, Radiance, Radiance]
Scale = Annotated[float, Field(ge=MIN_SCALE, le=MAX_SCALE)]


class _Strict(BaseModel):
    """Base: unknown keys are errors (a typo must not be silently ignored); no NaN or infinity."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_assignment=True)


def _rgb(v: Any) -> Any:
    """Accept one number as a grey RGB value."""
    if isinstance(v, int | float) and not isinstance(v, bool):
        return (v, v, v)
    return v


class Transform(_Strict):
    """Applied to mesh vertices in the order scale, rotate (about x, then y, then z), translate."""

    translate: Vec3 = (0.0, 0.0, 0.0)
    rotate_deg: Angles = (0.0, 0.0, 0.0)
    scale: tuple[Scale, ...] | Scale = 1.0

    @field_validator("scale")
    @classmethod
    def _scale_len(cls, v: Any) -> Any:
        if isinstance(v, tuple) and len(v) != 3:
            raise ValueError("scale is one positive number or three")
        return v

    def matrix(self) -> list[list[float]]:
        """The 4x4 affine matrix (row-major, acting on column vectors)."""
        sx, sy, sz = self.scale if isinstance(self.scale, tuple) else (self.scale,) * 3
        ax, ay, az = (math.radians(a) for a in self.rotate_deg)
        cx, sxr = math.cos(ax), math.sin(ax)
        cy, syr = math.cos(ay), math.sin(ay)
        cz, szr = math.cos(az), math.sin(az)
        rx = [[1, 0, 0], [0, cx, -sxr], [0, sxr, cx]]
        ry = [[cy, 0, syr], [0, 1, 0], [-syr, 0, cy]]
        rz = [[cz, -szr, 0], [szr, cz, 0], [0, 0, 1]]

        def mul(a: list[list[float]], b: list[list[float]]) -> list[list[float]]:
            return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]

        r = mul(rz, mul(ry, rx))
        s = (sx, sy, sz)
        m = [[r[i][j] * s[j] for j in range(3)] + [self.translate[i]] for i in range(3)]
        return [*m, [0.0, 0.0, 0.0, 1.0]]


class Mesh(_Strict):
    """A mesh file (OBJ, PLY, STL, OFF, GLB/GLTF), relative to the scene file.

    ``material`` applies to the whole file; ``group_materials`` overrides it per group (an OBJ ``g``/``o``
    group or a GLTF node/geometry name). ``exclude_groups`` names groups left out of the scene (version 2;
    a name the file does not hold is an error when the file is read, see :func:`kept_groups`).
    ``smooth`` interpolates vertex normals for shading.
    """

    name: str = ""
    path: str
    material: str
    group_materials: dict[str, str] = Field(default_factory=dict)
    exclude_groups: list[str] = Field(default_factory=list)
    transform: Transform = Field(default_factory=Transform)
    smooth: bool = False


class Material(_Strict):
    """An analytic model with parameters, or a measured (MERL ``.binary`` or RGL ``.bsdf``) file; optionally emissive.

    ``model`` is a registered model's name or a model file (``.brdf``, ``.py``), written relative to the scene
    file and held as an absolute path once the scene is read (:func:`scene_from_dict`); ``params`` then take
    the file's own parameter names.

    An emissive material turns every mesh that uses it into an area light of radiance ``emission``
    (emitting on the side its triangles' normals point to).
    """

    name: str = Field(min_length=1)
    model: str | None = None
    params: dict[str, Any] = Field(default_factory=dict)
    measured: str | None = None
    emission: RGB = (0.0, 0.0, 0.0)
    notes: str = ""
    tags: list[str] = Field(default_factory=list)
    """Free notes and tags the desktop app edits (the renderer ignores them)."""

    _rgb_emission = field_validator("emission", mode="before")(_rgb)

    @property
    def emissive(self) -> bool:
        return max(self.emission) > 0.0


class PointLight(_Strict):
    """An isotropic point light; ``intensity`` in W/sr (radiance at distance d is intensity / d^2)."""

    type: Literal["point"]
    position: Vec3
    intensity: RGB

    _rgb_intensity = field_validator("intensity", mode="before")(_rgb)


class QuadLight(_Strict):
    """A parallelogram ``corner + s edge1 + t edge2`` (s, t in [0, 1]) emitting ``radiance`` on the side of
    ``edge1 x edge2`` (both sides if ``two_sided``). It is visible to camera rays and blocks light."""

    type: Literal["quad"]
    corner: Vec3
    edge1: Vec3
    edge2: Vec3
    radiance: RGB
    two_sided: bool = False

    _rgb_radiance = field_validator("radiance", mode="before")(_rgb)


Light = Annotated[PointLight | QuadLight, Field(discriminator="type")]


class ConstantEnvironment(_Strict):
    """The same radiance from every direction at infinity."""

    type: Literal["constant"]
    radiance: RGB

    _rgb_radiance = field_validator("radiance", mode="before")(_rgb)


class MapEnvironment(_Strict):
    """An HDR lat-long (equirectangular) EXR: row 0 looks up (+y), columns run with ``phi = atan2(z, x)``."""

    type: Literal["map"]
    path: str
    scale: Radiance = 1.0
    rotate_deg: Annotated[float, Field(ge=-MAX_ANGLE_DEG, le=MAX_ANGLE_DEG)] = 0.0
    """Rotation about +y applied to the map."""


Environment = Annotated[ConstantEnvironment | MapEnvironment, Field(discriminator="type")]


class Camera(_Strict):
    """A pinhole camera looking from ``position`` at ``target``; ``fov_deg`` is the vertical field of view."""

    position: Vec3 = (0.0, 1.0, 4.0)
    target: Vec3 = (0.0, 0.0, 0.0)
    up: Vec3 = (0.0, 1.0, 0.0)
    fov_deg: Annotated[float, Field(gt=0.0, lt=180.0)] = 40.0


class RenderSettings(_Strict):
    """How to render: image size, budget (samples per pixel, or seconds if ``time_s`` is set), path length,
    the BRDF sampling strategy and its options, the MIS heuristic, and the seed. The default strategy is
    ``adaptive_warp``: at equal time on the demo scene it beats ``analytic`` and ties the exact adaptive mode,
    with far cheaper tables (``docs/renderer.md`` says why)."""

    width: Annotated[int, Field(ge=1, le=16384)] = 512
    height: Annotated[int, Field(ge=1, le=16384)] = 512
    spp: Annotated[int, Field(ge=1, le=MAX_SPP)] = 64
    time_s: Annotated[float, Field(gt=0.0, le=MAX_SECONDS)] | None = None
    max_depth: Annotated[int, Field(ge=1, le=1000)] = 8
    rr_depth: Annotated[int, Field(ge=1, le=1000)] = 3
    sampler: str = "adaptive_warp"
    sampler_options: dict[str, Any] = Field(default_factory=dict)
    mis: Literal["power", "balance"] = "power"
    seed: Annotated[int, Field(ge=0, le=MAX_SEED)] = 0


class Scene(_Strict):
    """A whole scene. ``version`` is the schema version (currently 2; files of version 1 are read too)."""

    version: int = SCENE_VERSION
    name: str = ""
    camera: Camera = Field(default_factory=Camera)
    materials: list[Material] = Field(default_factory=list)
    meshes: list[Mesh] = Field(default_factory=list)
    lights: list[Light] = Field(default_factory=list)
    environment: Environment | None = None
    render: RenderSettings = Field(default_factory=RenderSettings)

    _base_dir: Path = PrivateAttr(default_factory=Path.cwd)
    _source: str = PrivateAttr(default="scene")

    @property
    def base_dir(self) -> Path:
        """The folder relative paths are resolved against (the scene file's folder)."""
        return self._base_dir

    @property
    def source(self) -> str:
        """How errors name this scene (its file name)."""
        return self._source

    def set_origin(self, base_dir: str | os.PathLike[str], source: str = "scene") -> Scene:
        self._base_dir = Path(base_dir)
        self._source = source
        return self

    def resolve(self, relative: str) -> Path:
        """An absolute path for a path written in the scene (relative to the scene file)."""
        p = Path(relative).expanduser()
        return p if p.is_absolute() else (self._base_dir / p)

    def material_index(self, name: str) -> int:
        for i, m in enumerate(self.materials):
            if m.name == name:
                return i
        raise SceneError(f"{self._source}: no material named '{name}'")

    def error(self, where: str, message: str) -> SceneError:
        """A :class:`SceneError` naming this scene and the field ``where``."""
        return SceneError(f"{self._source}: {where}: {message}")
