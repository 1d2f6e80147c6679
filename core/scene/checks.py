"""The checks of a scene beyond its field types: models and their parameters, names that refer to each other,
lights with area, cameras that form an image, samplers, and the files a scene names."""

from __future__ import annotations

import math
import os
from pathlib import Path

from core.errors import BrdfStudioError
from core.model_files import is_model_file
from core.scene.schema import (
    ENVMAP_FORMATS,
    MEASURED_FORMATS,
    MESH_FORMATS,
    Camera,
    MapEnvironment,
    PointLight,
    QuadLight,
    Scene,
    Vec3,
)


def model_file_path(scene: Scene, written: str) -> str:
    """The absolute, normalized path of a model file that ``scene`` names as ``written`` (relative to the
    scene file's folder, or absolute)."""
    return os.path.normpath(scene.resolve(written))


def validate_scene(scene: Scene, check_files: bool = True) -> None:
    """Checks beyond the field types: models and their parameters, names that refer to each other,
    samplers, and (with ``check_files``) that every referenced file exists with a known extension."""
    from core.brdf import get_model
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
        problem = light_problem(light)
        if problem:
            raise scene.error(f"lights[{i}]", problem)

    if isinstance(scene.environment, MapEnvironment):
        _check_file(scene, "environment.path", scene.environment.path, ENVMAP_FORMATS, check_files)

    problem_at = camera_problem(scene.camera)
    if problem_at:
        raise scene.error(f"camera.{problem_at[0]}", problem_at[1])

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


def light_problem(light: PointLight | QuadLight) -> str | None:
    """What makes a light unusable beyond its field types (``None``: nothing)."""
    if isinstance(light, QuadLight) and _norm(_cross(light.edge1, light.edge2)) <= 1e-12:
        return "edge1 and edge2 span no area (zero or parallel edges)"
    return None


def camera_problem(cam: Camera) -> tuple[str, str] | None:
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
