"""The scene (project) file: a versioned JSON schema, loading with readable errors, atomic saving.

Plain data only: this module knows nothing of the renderer. The desktop app edits a :class:`Scene` and saves
it; the renderer loads meshes and images from the paths it names. Paths are relative to the scene file. A
material's model may be a model file (``"model": "materials/my.brdf"``, :mod:`core.model_files`): its path is
made absolute when the scene is read, so that every consumer (the renderer's ``make_brdf(mat.model, ...)``,
the samplers, the app) opens the same file whatever the working directory, and :func:`save_scene` writes it
relative to the saved file again.

A minimal scene::

    {
      "version": 2,
      "camera": {"position": [0, 1, 4], "target": [0, 0.5, 0], "up": [0, 1, 0], "fov_deg": 40},
      "materials": [{"name": "white", "model": "lambert", "params": {"kd": 0.8}}],
      "meshes": [{"path": "floor.obj", "material": "white"}],
      "lights": [{"type": "point", "position": [0, 3, 0], "intensity": [10, 10, 10]}],
      "environment": {"type": "constant", "radiance": [0.2, 0.2, 0.2]},
      "render": {"width": 256, "height": 256, "spp": 64, "sampler": "analytic"}
    }

Conventions: right-handed world, y is up for the environment map (lat-long: ``theta`` measured from +y,
``phi = atan2(z, x)``); lengths in scene units; radiance and intensity in linear RGB.

Errors name the file and the field: ``scene.json: materials[2].params.n: ...``.

Versions: 2 added ``meshes[].exclude_groups``. Version 1 files are read as they are (a version-1 file is a
version-2 file without that field) and saved as version 2.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    TypeAdapter,
    ValidationError,
    field_validator,
)

from core.errors import BrdfStudioError, FileFormatError
from core.io import atomic_write_text, read_bounded
from core.model_files import is_model_file, load_model_file

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


# --------------------------------------------------------------------------------------------- loading


def _loc_text(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif part in ("point", "quad", "constant", "map") and (
            out == "" or out.startswith(("lights", "environment"))
        ):
            continue  # pydantic adds the discriminator value as a path step; it is not a field
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


_UNION_TAG = re.compile(r"^(constrained-[a-z]+|[a-z][a-z-]*\[.*\])$")
"""The step pydantic adds to the location of an error in one member of a union (``scale`` is one number or
a list: ``scale.constrained-float``, ``scale.tuple[constrained-float, ...]``); a type's name, not a field."""
_UNION_WORDS = {"tuple": "a list of numbers", "list": "a list", "constrained-float": "a number",
                "constrained-int": "a whole number", "constrained-str": "text"}  # fmt: skip


def _union_errors(errors: list[Any]) -> list[Any]:
    """``errors`` with each union's members merged into what the user meant: the member whose form the value
    has (its error, the member's name left out of the location: ``scale: Input should be less than or equal
    to 1000000``), or, when the value has none of their forms, ``scale: expected a list of numbers or a
    number``."""
    out: list[Any] = []
    groups: dict[tuple[Any, ...], list[Any]] = {}
    for err in errors:
        loc = tuple(err["loc"])
        at = next((i for i, p in enumerate(loc) if isinstance(p, str) and _UNION_TAG.match(p)), None)
        if at is None:
            out.append(err)
            continue
        field = loc[:at]
        if field not in groups:
            groups[field] = []
            out.append(field)  # the union's place among the errors: its first member's
        groups[field].append({**err, "loc": field + loc[at + 1 :], "member": loc[at]})
    merged: list[Any] = []
    for item in out:
        if not isinstance(item, tuple):
            merged.append(item)
            continue
        members = groups[item]
        formed = [e for e in members if not e["type"].endswith(("_type", "_parsing"))]
        if formed:
            merged += formed
            continue
        words = dict.fromkeys(_UNION_WORDS.get(e["member"].split("[")[0], e["member"]) for e in members)
        merged.append({"loc": item, "type": "union", "msg": "expected " + " or ".join(words)})
    return merged


def _format_validation(source: str, exc: ValidationError) -> str:
    lines = []
    errors = _union_errors(list(exc.errors()))
    for err in errors[:6]:
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown field (check the spelling)"
        elif err["type"] == "missing":
            msg = "required field is missing"
        lines.append(f"{source}: {_loc_text(tuple(err['loc']))}: {msg}")
    more = len(errors) - len(lines)
    if more > 0:
        lines.append(f"... and {more} more problem(s)")
    return "\n".join(lines)


MAX_JSON_DEPTH = 32
"""A scene file is at most six levels deep; deeper data is refused before validation recurses into it."""


def _depth(data: Any, limit: int = MAX_JSON_DEPTH) -> int:
    """How deeply ``data`` nests lists and dicts, counted up to ``limit + 1`` (without recursion)."""
    deepest, stack = 0, [(data, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            if depth > limit:
                return depth
            deepest = max(deepest, depth)
            stack.extend((v, depth + 1) for v in (item.values() if isinstance(item, dict) else item))
    return deepest


def scene_from_dict(
    data: Any, source: str = "scene", base_dir: str | os.PathLike[str] | None = None, check_files: bool = True
) -> Scene:
    """Validate a parsed JSON object and return a :class:`Scene`; raises :class:`SceneError`."""
    if not isinstance(data, dict):
        raise SceneError(f"{source}: a scene file holds a JSON object {{...}}, got {type(data).__name__}")
    version = data.get("version", None)
    if version is None:
        raise SceneError(
            f"{source}: version: required field is missing (this program writes version {SCENE_VERSION})"
        )
    if isinstance(version, bool) or version not in READABLE_VERSIONS:
        raise SceneError(
            f"{source}: version: schema version {version!r} is not supported (this program reads versions "
            f"{', '.join(map(str, READABLE_VERSIONS))})"
        )
    if version < 2:
        for i, mesh in enumerate(data.get("meshes") or []):
            if isinstance(mesh, dict) and mesh.get("exclude_groups"):
                raise SceneError(
                    f"{source}: meshes[{i}].exclude_groups: needs scene version 2 (the file says version "
                    f'{version}); set "version": 2'
                )
    if _depth(data) > MAX_JSON_DEPTH:
        raise SceneError(f"{source}: the JSON is nested too deeply (a scene is a few levels deep)")
    try:
        scene = Scene.model_validate(data)
    except ValidationError as exc:
        raise SceneError(_format_validation(source, exc)) from None
    scene.version = SCENE_VERSION  # read as the current version; saved as such
    scene.set_origin(base_dir if base_dir is not None else Path.cwd(), source)
    for mat in scene.materials:
        if mat.model is not None and is_model_file(mat.model):
            mat.model = model_file_path(scene, mat.model)
    validate_scene(scene, check_files=check_files)
    return scene


def model_file_path(scene: Scene, written: str) -> str:
    """The absolute, normalized path of a model file that ``scene`` names as ``written`` (relative to the
    scene file's folder, or absolute)."""
    return os.path.normpath(scene.resolve(written))


def validate_scene(scene: Scene, check_files: bool = True) -> None:
    """Checks beyond the field types: models and their parameters, names that refer to each other,
    samplers, and (with ``check_files``) that every referenced file exists with a known extension."""
    from core.model import get_model
    from core.sampling import sampler_names
    from core.sampling.base import check_sampler_options

    names: dict[str, int] = {}
    for i, mat in enumerate(scene.materials):
        where = f"materials[{i}]"
        if mat.name in names:
            raise scene.error(
                f"{where}.name", f"'{mat.name}' is already the name of materials[{names[mat.name]}]"
            )
        names[mat.name] = i
        if (mat.model is None) == (mat.measured is None):
            raise scene.error(
                where, "give either 'model' (with 'params') or 'measured' (a MERL or RGL file), not both"
            )
        if mat.model is not None:
            try:
                model = get_model(
                    model_file_path(scene, mat.model) if is_model_file(mat.model) else mat.model
                )
            except BrdfStudioError as exc:
                raise scene.error(f"{where}.model", str(exc)) from None
            for key, value in mat.params.items():
                try:
                    model.param(key).validate(model.name, value)
                except BrdfStudioError as exc:
                    raise scene.error(f"{where}.params.{key}", str(exc)) from None
        else:
            if mat.params:
                raise scene.error(f"{where}.params", "a measured material takes no parameters")
            _check_file(scene, f"{where}.measured", mat.measured or "", MEASURED_FORMATS, check_files)

    for i, mesh in enumerate(scene.meshes):
        where = f"meshes[{i}]"
        if mesh.material not in names:
            raise scene.error(f"{where}.material", _unknown_material(mesh.material, names))
        for group, mname in mesh.group_materials.items():
            if mname not in names:
                raise scene.error(f"{where}.group_materials.{group}", _unknown_material(mname, names))
        seen: set[str] = set()
        for group in mesh.exclude_groups:
            if group in seen:
                raise scene.error(f"{where}.exclude_groups", f"group '{group}' is listed twice")
            seen.add(group)
        _check_file(scene, f"{where}.path", mesh.path, MESH_FORMATS, check_files)

    for i, light in enumerate(scene.lights):
        problem = _light_problem(light)
        if problem:
            raise scene.error(f"lights[{i}]", problem)

    if isinstance(scene.environment, MapEnvironment):
        _check_file(scene, "environment.path", scene.environment.path, ENVMAP_FORMATS, check_files)

    camera_problem = _camera_problem(scene.camera)
    if camera_problem:
        raise scene.error(f"camera.{camera_problem[0]}", camera_problem[1])

    if scene.render.sampler not in sampler_names():
        raise scene.error(
            "render.sampler",
            f"unknown sampler '{scene.render.sampler}'; known samplers: {', '.join(sampler_names())}",
        )
    try:
        check_sampler_options(scene.render.sampler, scene.render.sampler_options)
    except BrdfStudioError as exc:
        raise scene.error("render.sampler_options", str(exc)) from None


def _cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _norm(a: Vec3) -> float:
    return math.sqrt(sum(c * c for c in a))


def _light_problem(light: PointLight | QuadLight) -> str | None:
    """What makes a light unusable beyond its field types (``None``: nothing)."""
    if isinstance(light, QuadLight) and _norm(_cross(light.edge1, light.edge2)) <= 1e-12:
        return "edge1 and edge2 span no area (zero or parallel edges)"
    return None


def _camera_problem(cam: Camera) -> tuple[str, str] | None:
    """The field and the reason when a camera cannot form an image (``None``: nothing)."""
    view: Vec3 = (
        cam.target[0] - cam.position[0],
        cam.target[1] - cam.position[1],
        cam.target[2] - cam.position[2],
    )
    if _norm(view) <= 1e-12:
        return "target", "the target coincides with the camera position"
    if _norm(_cross(view, cam.up)) <= 1e-12 * max(1e-300, _norm(view)):
        return "up", "the up vector is zero or parallel to the viewing direction"
    return None


def kept_groups(scene: Scene, index: int, group_names: list[str]) -> list[bool]:
    """Which of the groups read from the file of ``scene.meshes[index]`` stay in the scene: ``False`` for
    those its ``exclude_groups`` names. Groups are only known once the file is read, so this is where an
    excluded name the file does not hold becomes a :class:`SceneError` naming the group and the file."""
    mesh = scene.meshes[index]
    for group in mesh.exclude_groups:
        if group not in group_names:
            listed = ", ".join(f"'{n}'" for n in sorted(set(group_names))) or "(none)"
            raise scene.error(
                f"meshes[{index}].exclude_groups",
                f"'{mesh.path}' has no group named '{group}' (its groups: {listed})",
            )
    excluded = set(mesh.exclude_groups)
    return [name not in excluded for name in group_names]


# ----------------------------------------------------------------------- one item at a time (the app)

_LIGHT_ADAPTER: TypeAdapter[PointLight | QuadLight] = TypeAdapter(Light)
_ENVIRONMENT_ADAPTER: TypeAdapter[ConstantEnvironment | MapEnvironment] = TypeAdapter(Environment)


def _parse_item(adapter: TypeAdapter[Any], data: Any, where: str) -> Any:
    """Validate one item; errors read ``<where>.<field>: reason`` as they would inside a whole scene."""
    try:
        return adapter.validate_python(data)
    except ValidationError as exc:
        lines = []
        for line in _format_validation("", exc).splitlines():
            text = line.removeprefix(": ")
            if text.startswith("(top level)"):
                text = where + text.removeprefix("(top level)")
            elif not text.startswith("..."):
                text = where + ("" if text.startswith("[") else ".") + text
            lines.append(text)
        raise SceneError("\n".join(lines)) from None


def parse_light(data: Any, where: str = "light") -> PointLight | QuadLight:
    """Validate one light as a scene file holds it (a dict with ``type``); :class:`SceneError` names
    ``where`` and the field, e.g. ``lights[0]: radiance[1]: Input should be greater than or equal to 0``."""
    light = _parse_item(_LIGHT_ADAPTER, data, where)
    problem = _light_problem(light)
    if problem:
        raise SceneError(f"{where}: {problem}")
    return light  # type: ignore[no-any-return]


def parse_camera(data: Any, where: str = "camera") -> Camera:
    """Validate a camera (the same checks as a whole scene's); :class:`SceneError` names the field."""
    cam = _parse_item(TypeAdapter(Camera), data, where)
    problem = _camera_problem(cam)
    if problem:
        raise SceneError(f"{where}.{problem[0]}: {problem[1]}")
    return cam  # type: ignore[no-any-return]


def parse_environment(
    data: Any, where: str = "environment", check_file: bool = True
) -> ConstantEnvironment | MapEnvironment:
    """Validate an environment; a map's ``path`` (absolute here) must name an existing EXR file when
    ``check_file``."""
    env = _parse_item(_ENVIRONMENT_ADAPTER, data, where)
    if isinstance(env, MapEnvironment):
        if Path(env.path).suffix.lower() not in ENVMAP_FORMATS:
            raise SceneError(
                f"{where}.path: '{env.path}' has an unsupported extension; expected one of "
                f"{', '.join(ENVMAP_FORMATS)}"
            )
        if check_file and not Path(env.path).expanduser().is_file():
            raise SceneError(f"{where}.path: file '{env.path}' not found")
    return env  # type: ignore[no-any-return]


def _unknown_material(name: str, names: dict[str, int]) -> str:
    known = ", ".join(f"'{n}'" for n in names) or "(none defined)"
    return f"no material named '{name}'; materials defined: {known}"


def _check_file(scene: Scene, where: str, rel: str, formats: tuple[str, ...], check_files: bool) -> None:
    if not rel:
        raise scene.error(where, "a file path is required")
    if Path(rel).suffix.lower() not in formats:
        raise scene.error(
            where, f"'{rel}' has an unsupported extension; expected one of {', '.join(formats)}"
        )
    if check_files:
        full = scene.resolve(rel)
        if not full.is_file():
            if full.exists():
                raise scene.error(where, f"'{rel}' is not a regular file (looked at {full})")
            raise scene.error(where, f"file '{rel}' not found (looked for {full})")


MAX_SCENE_BYTES = 64 << 20
"""The largest scene file read (a scene names its meshes and images; its own JSON is a few kilobytes)."""


class DuplicateKeyError(ValueError):
    """A JSON object names the same key twice (``json`` would keep the last value without a word)."""

    def __init__(self, key: str):
        super().__init__(f"the key '{key}' appears twice in one object (each key once)")
        self.key = key


def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``json``'s ``object_pairs_hook`` refusing a key given twice (:class:`DuplicateKeyError`)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise DuplicateKeyError(key)
        out[key] = value
    return out


def parse_scene_json(text: str, source: str) -> Any:
    """The JSON value of a scene file's ``text``; :class:`SceneError` naming ``source`` and the line for
    invalid JSON, and the key for a key given twice in one object."""
    try:
        return json.loads(text, object_pairs_hook=unique_keys)
    except DuplicateKeyError as exc:
        raise SceneError(f"{source}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise SceneError(
            f"{source}: line {exc.lineno}, column {exc.colno}: invalid JSON: {exc.msg}"
        ) from None
    except RecursionError:
        raise SceneError(f"{source}: the JSON is nested too deeply (a scene is a few levels deep)") from None


def read_scene_json(path: str | os.PathLike[str]) -> Any:
    """The JSON value of the scene (project) file at ``path``, read within :data:`MAX_SCENE_BYTES` (a device
    such as ``/dev/zero`` is refused before it is read); :class:`SceneError` saying what is wrong."""
    p = Path(path)
    try:
        text = read_bounded(p, MAX_SCENE_BYTES, "scene file", SceneError).decode("utf-8")
    except FileNotFoundError:
        raise SceneError(f"{path}: scene file not found") from None
    except IsADirectoryError:
        raise SceneError(f"{path}: is a folder, not a scene file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot read the scene file: {exc}") from None
    return parse_scene_json(text, p.name)


def load_scene(path: str | os.PathLike[str], check_files: bool = True) -> Scene:
    """Read and validate a scene file; raises :class:`SceneError` with the file and field at fault."""
    p = Path(path)
    data = read_scene_json(p)
    return scene_from_dict(data, source=p.name, base_dir=p.resolve().parent, check_files=check_files)


def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """The JSON form of ``scene``; an empty ``exclude_groups`` is left out (as in files written by hand)."""
    data = scene.model_dump(mode="json")
    for mesh in data["meshes"]:
        if not mesh["exclude_groups"]:
            del mesh["exclude_groups"]
    return data


def scene_digest(scene: Scene, *extra: Any) -> str:
    """A hex key of what renders ``scene``: its JSON form, ``extra`` (JSON values: size, spp, seed, ...) and the
    bytes of every file it names (meshes, measured materials, the sky map), so that a cached render of it is
    not used once any of them changes."""
    h = hashlib.sha1(json.dumps([scene.model_dump(mode="json"), *extra], sort_keys=True).encode())
    files = {m.path for m in scene.meshes} | {m.measured for m in scene.materials if m.measured}
    if scene.environment is not None and getattr(scene.environment, "path", None):
        files.add(scene.environment.path)
    for rel in sorted(files):
        h.update(scene.resolve(rel).read_bytes())
    for model in sorted({m.model for m in scene.materials if m.model and is_model_file(m.model)}):
        h.update(load_model_file(model_file_path(scene, model)).source.digest.encode())  # type: ignore[union-attr]
    return h.hexdigest()


def save_scene(scene: Scene, path: str | os.PathLike[str]) -> None:
    """Write ``scene`` as indented JSON, atomically (a crash never leaves a half-written file); a material's
    model file is written relative to ``path``'s folder (as it was read)."""
    data = scene_to_dict(scene)
    folder = Path(path).resolve().parent
    for mat in data["materials"]:
        model = mat.get("model")
        if model and is_model_file(model) and Path(model).is_absolute():
            mat["model"] = _relative_to(model, folder)
    atomic_write_text(path, json.dumps(data, indent=2) + "\n")


def _relative_to(path: str, folder: Path) -> str:
    """``path`` relative to ``folder``, with '/' (as a scene file holds paths); unchanged across drives."""
    try:
        return Path(os.path.relpath(path, folder)).as_posix()
    except ValueError:  # another drive (Windows)
        return path
