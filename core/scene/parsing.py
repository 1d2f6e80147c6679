"""A scene, or one of its items (a light, the camera, the environment), validated from parsed JSON, with
errors that name the scene and the field."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from pydantic import TypeAdapter, ValidationError

from core.model_files import is_model_file
from core.scene.checks import camera_problem, light_problem, model_file_path, validate_scene
from core.scene.messages import format_validation
from core.scene.schema import (
    ENVMAP_FORMATS,
    READABLE_VERSIONS,
    SCENE_VERSION,
    Camera,
    ConstantEnvironment,
    Environment,
    Light,
    MapEnvironment,
    PointLight,
    QuadLight,
    Scene,
    SceneError,
)

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
        raise SceneError(format_validation(source, exc)) from None
    scene.version = SCENE_VERSION  # read as the current version; saved as such
    scene.set_origin(base_dir if base_dir is not None else Path.cwd(), source)
    for mat in scene.materials:
        if mat.model is not None and is_model_file(mat.model):
            mat.model = model_file_path(scene, mat.model)
    _current_sampler(scene)
    validate_scene(scene, check_files=check_files)
    return scene


def _current_sampler(scene: Scene) -> None:
    """A former sampler name (``"adaptive"``) read as the current one, with the notice that names it
    (:func:`core.sampling.base.current_sampler`)."""
    from core.sampling.base import current_sampler

    render = scene.render
    render.sampler, render.sampler_options = current_sampler(render.sampler, render.sampler_options)


_LIGHT_ADAPTER: TypeAdapter[PointLight | QuadLight] = TypeAdapter(Light)


_ENVIRONMENT_ADAPTER: TypeAdapter[ConstantEnvironment | MapEnvironment] = TypeAdapter(Environment)


def _parse_item(adapter: TypeAdapter[Any], data: Any, where: str) -> Any:
    """Validate one item; errors read ``<where>.<field>: reason`` as they would inside a whole scene."""
    try:
        return adapter.validate_python(data)
    except ValidationError as exc:
        lines = []
        for line in format_validation("", exc).splitlines():
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
    problem = light_problem(light)
    if problem:
        raise SceneError(f"{where}: {problem}")
    return light  # type: ignore[no-any-return]


def parse_camera(data: Any, where: str = "camera") -> Camera:
    """Validate a camera (the same checks as a whole scene's); :class:`SceneError` names the field."""
    cam = _parse_item(TypeAdapter(Camera), data, where)
    problem = camera_problem(cam)
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
