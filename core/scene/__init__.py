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

The package's steps: :mod:`core.scene.schema` (the classes and their limits), :mod:`core.scene.messages`
(validation errors as lines a user reads), :mod:`core.scene.checks` (what spans fields and files),
:mod:`core.scene.parsing` (a scene or one item from parsed JSON) and :mod:`core.scene.files` (reading,
saving, the digest). Their public names are imported here.
"""

from core.scene.checks import kept_groups, model_file_path, validate_scene
from core.scene.files import (
    MAX_SCENE_BYTES,
    DuplicateKeyError,
    load_scene,
    parse_scene_json,
    read_scene_json,
    save_scene,
    scene_digest,
    scene_to_dict,
    unique_keys,
)
from core.scene.parsing import MAX_JSON_DEPTH, parse_camera, parse_environment, parse_light, scene_from_dict
from core.scene.schema import (
    ENVMAP_FORMATS,
    MAX_ANGLE_DEG,
    MAX_COORD,
    MAX_RADIANCE,
    MAX_SCALE,
    MAX_SECONDS,
    MAX_SEED,
    MAX_SPP,
    MEASURED_FORMATS,
    MESH_FORMATS,
    MIN_SCALE,
    READABLE_VERSIONS,
    RGB,
    SCENE_VERSION,
    Angles,
    Camera,
    ConstantEnvironment,
    Coord,
    Environment,
    Light,
    MapEnvironment,
    Material,
    Mesh,
    NonNeg,
    PointLight,
    QuadLight,
    Radiance,
    RenderSettings,
    Scale,
    Scene,
    SceneError,
    Transform,
    Vec3,
)

__all__ = [
    "SCENE_VERSION",
    "READABLE_VERSIONS",
    "MESH_FORMATS",
    "MEASURED_FORMATS",
    "ENVMAP_FORMATS",
    "SceneError",
    "MAX_COORD",
    "MAX_RADIANCE",
    "MAX_ANGLE_DEG",
    "MIN_SCALE",
    "MAX_SCALE",
    "MAX_SPP",
    "MAX_SECONDS",
    "MAX_SEED",
    "NonNeg",
    "Coord",
    "Vec3",
    "Angles",
    "Radiance",
    "RGB",
    "Scale",
    "Transform",
    "Mesh",
    "Material",
    "PointLight",
    "QuadLight",
    "Light",
    "ConstantEnvironment",
    "MapEnvironment",
    "Environment",
    "Camera",
    "RenderSettings",
    "Scene",
    "MAX_JSON_DEPTH",
    "scene_from_dict",
    "model_file_path",
    "validate_scene",
    "kept_groups",
    "parse_light",
    "parse_camera",
    "parse_environment",
    "MAX_SCENE_BYTES",
    "DuplicateKeyError",
    "unique_keys",
    "parse_scene_json",
    "read_scene_json",
    "load_scene",
    "scene_to_dict",
    "scene_digest",
    "save_scene",
]
