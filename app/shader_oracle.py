"""BRDF Explorer shaders run by Mesa's software OpenGL: the reference an imported ``.brdf`` model is checked against.

:func:`evaluate_glsl` compiles a file's GLSL as BRDF Explorer does (``#version 410``, the uniforms of its plot
template, one uniform per parameter, then the file's code) in a headless EGL context on Mesa's llvmpipe, and
returns ``BRDF(L, V, N=(0,0,1), X=(1,0,0), Y=(0,1,0))`` for every pair of directions, one pair per texel of a
float32 render target. llvmpipe evaluates in IEEE float32: :mod:`app.float32_agreement` compares our float64
kernels with it ("How imported shaders are checked" in ``docs/model-files.md``).

One deliberate departure from stock Mesa: ``acos``, ``asin`` and ``atan`` are Mesa's low-order polynomial
approximations (absolute errors up to 4e-4 rad); the oracle replaces them by float32 implementations accurate
to a few units in the last place (:data:`PRECISE_INVERSE_TRIG`), so that the reference is the GLSL's meaning
and not one driver's shortcut. ``precise_inverse_trig=False`` runs Mesa's own.

The OpenGL context is created on first use and kept; use the oracle from one thread.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from core.errors import BrdfStudioError

ParamKind = Literal["float", "color", "bool"]
ParamValue = float | bool | tuple[float, float, float]

TEXELS_PER_ROW = 4096
ROWS_PER_DRAW = 1024

HOST_UNIFORMS = """\
uniform mat4 projectionMatrix;
uniform mat4 modelViewMatrix;
uniform vec3 incidentVector;
uniform float incidentTheta;
uniform float incidentPhi;
uniform float useLogPlot;
uniform float useNDotL;
uniform vec3 colorMask;
"""
"""What BRDF Explorer's polar-plot template (``src/shaderTemplates/brdftemplate2D.vert``) declares before a
file's code: a file that declares one of these names again does not compile there either."""

PRECISE_INVERSE_TRIG = """\
const float brdf_studio_pi = 3.14159265358979323846;
const float brdf_studio_half_pi = 1.57079632679489661923;
float brdf_studio_atan(float x)
{
    // Cephes' atanf: a reduction to |x| <= tan(pi/8), then a degree-9 odd polynomial (about 2 ulps)
    float a = abs(x);
    float offset = 0.0;
    if (a > 2.414213562373095) { offset = brdf_studio_half_pi; a = -1.0 / a; }
    else if (a > 0.4142135623730950) { offset = 0.25 * brdf_studio_pi; a = (a - 1.0) / (a + 1.0); }
    float z = a * a;
    float r = offset + ((((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
                        - 3.33329491539e-1) * z * a + a);
    return x < 0.0 ? -r : r;
}
float brdf_studio_atan(float y, float x)
{
    float ax = abs(x);
    float ay = abs(y);
    float r = ax >= ay ? (ax == 0.0 ? 0.0 : brdf_studio_atan(ay / ax))
                       : brdf_studio_half_pi - brdf_studio_atan(ax / ay);
    if (x < 0.0) r = brdf_studio_pi - r;
    return y < 0.0 ? -r : r;
}
float brdf_studio_acos(float x) { return 2.0 * brdf_studio_atan(sqrt((1.0 - x) / (1.0 + x))); }
float brdf_studio_asin(float x) { return brdf_studio_atan(x, sqrt((1.0 - x) * (1.0 + x))); }
vec2 brdf_studio_atan(vec2 x) { return vec2(brdf_studio_atan(x.x), brdf_studio_atan(x.y)); }
vec3 brdf_studio_atan(vec3 x) { return vec3(brdf_studio_atan(x.xy), brdf_studio_atan(x.z)); }
vec4 brdf_studio_atan(vec4 x) { return vec4(brdf_studio_atan(x.xy), brdf_studio_atan(x.zw)); }
vec2 brdf_studio_atan(vec2 y, vec2 x) { return vec2(brdf_studio_atan(y.x, x.x), brdf_studio_atan(y.y, x.y)); }
vec3 brdf_studio_atan(vec3 y, vec3 x) { return vec3(brdf_studio_atan(y.xy, x.xy), brdf_studio_atan(y.z, x.z)); }
vec4 brdf_studio_atan(vec4 y, vec4 x) { return vec4(brdf_studio_atan(y.xy, x.xy), brdf_studio_atan(y.zw, x.zw)); }
vec2 brdf_studio_acos(vec2 x) { return vec2(brdf_studio_acos(x.x), brdf_studio_acos(x.y)); }
vec3 brdf_studio_acos(vec3 x) { return vec3(brdf_studio_acos(x.xy), brdf_studio_acos(x.z)); }
vec4 brdf_studio_acos(vec4 x) { return vec4(brdf_studio_acos(x.xy), brdf_studio_acos(x.zw)); }
vec2 brdf_studio_asin(vec2 x) { return vec2(brdf_studio_asin(x.x), brdf_studio_asin(x.y)); }
vec3 brdf_studio_asin(vec3 x) { return vec3(brdf_studio_asin(x.xy), brdf_studio_asin(x.z)); }
vec4 brdf_studio_asin(vec4 x) { return vec4(brdf_studio_asin(x.xy), brdf_studio_asin(x.zw)); }
"""
"""Float32 ``atan``, ``acos`` and ``asin`` of a few ulps, put in place of Mesa's by a ``#define`` of each name
that the file does not define itself."""

_INVERSE_TRIG = ("acos", "asin", "atan")
HEADER_FIRST_LINE = 1_000_000
"""The line number of the header's first line, after ``#version``: Mesa's messages name no source string, so
the header's lines are numbered past any file's."""
_VERSION_LINE = re.compile(r"^[ \t]*#[ \t]*version\b.*$", re.MULTILINE)
"""A ``#version`` line of the file, left out (its line stays, empty): GLSL takes one only on the first line of
the program, which holds BRDF Explorer's ``#version 410``, and ``core.glsl`` ignores it."""

_VERTEX_SHADER = """\
#version 410
void main()
{
    // one triangle over the whole viewport
    gl_Position = vec4(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID >> 1) * 4 - 1), 0.0, 1.0);
}
"""

_HOST_MAIN = """\
uniform sampler2D brdf_studio_L;
uniform sampler2D brdf_studio_V;
out vec4 brdf_studio_value;
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y);
void main()
{
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec3 L = texelFetch(brdf_studio_L, texel, 0).xyz;
    vec3 V = texelFetch(brdf_studio_V, texel, 0).xyz;
    brdf_studio_value = vec4(BRDF(L, V, vec3(0.0, 0.0, 1.0), vec3(1.0, 0.0, 0.0), vec3(0.0, 1.0, 0.0)), 1.0);
}
"""

# Debian packages of the libraries a headless Mesa context loads (see .ci/system-deps.sh)
_LIBRARIES = (
    ("EGL", "libEGL.so.1", "libegl1"),
    ("GL", "libGL.so.1", "libgl1"),
    ("EGL_mesa", "libEGL_mesa.so.0", "libegl-mesa0"),
)
_DRI_FOLDERS = (
    "/usr/lib/x86_64-linux-gnu/dri",
    "/usr/lib/aarch64-linux-gnu/dri",
    "/usr/lib64/dri",
    "/usr/lib/dri",
)


class OracleUnavailableError(BrdfStudioError):
    """No software OpenGL context can be made: a library is missing, or the renderer is not Mesa's."""


class MesaShaderError(BrdfStudioError):
    """Mesa's GLSL compiler refused a shader. ``log`` is Mesa's messages, one a line, each placed as
    ``path:line:column: message`` in the file (``first_line`` of :func:`evaluate_glsl` is the file line of the
    shader's first line)."""

    def __init__(self, source_name: str, log: str) -> None:
        self.source_name = source_name
        self.log = log
        super().__init__(f"Mesa's GLSL compiler refused the shader:\n{log}")


def version_line(shader: str) -> bool:
    """Whether ``shader`` has a ``#version`` line (which the oracle leaves out, see :data:`_VERSION_LINE`)."""
    return _VERSION_LINE.search(shader) is not None


def glsl_program(
    shader: str,
    params: Sequence[tuple[ParamKind, str, Any]],
    *,
    first_line: int = 1,
    precise_inverse_trig: bool = True,
) -> str:
    """The fragment shader the oracle compiles: BRDF Explorer's header and the file's parameters as uniforms,
    our ``main`` (one pair of directions per texel), then ``shader`` numbered from ``first_line``, without a
    ``#version`` line of its own."""
    parts = ["#version 410", f"#line {HEADER_FIRST_LINE}", HOST_UNIFORMS]
    # declared in BRDF Explorer's order: the floats, the bools, the colors (BRDFBase::getShaderString)
    for kind, glsl_type in (("float", "float"), ("bool", "bool"), ("color", "vec3")):
        parts += [f"uniform {glsl_type} {name};" for k, name, _ in params if k == kind]
    if precise_inverse_trig:
        parts.append(PRECISE_INVERSE_TRIG)
        for name in _INVERSE_TRIG:
            if not re.search(rf"\b(?:float|vec[234])\s+{name}\s*\(", shader):  # the file's own wins
                parts.append(f"#define {name} brdf_studio_{name}")
    parts += [_HOST_MAIN, f"#line {first_line}", _VERSION_LINE.sub("", shader), ""]
    return "\n".join(parts)


class ShaderOracle:
    """A headless OpenGL context on Mesa's llvmpipe that evaluates BRDF Explorer shaders."""

    def __init__(self) -> None:
        self._ctx = _create_context()
        self.renderer: str = self._ctx.info["GL_RENDERER"]
        """``GL_RENDERER``, e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``."""
        self.version: str = self._ctx.info["GL_VERSION"]

    def evaluate(
        self,
        shader: str,
        params: Sequence[tuple[ParamKind, str, Any]],
        L: np.ndarray,
        V: np.ndarray,
        *,
        source_name: str = "shader",
        first_line: int = 1,
        precise_inverse_trig: bool = True,
    ) -> np.ndarray:
        """See :func:`evaluate_glsl`."""
        import moderngl

        lights = _directions(L, "L")
        views = _directions(V, "V")
        if lights.shape != views.shape:
            raise ValueError(f"L and V must have the same shape, got {lights.shape} and {views.shape}")
        if len(lights) == 0:
            return np.empty((0, 3), dtype=np.float32)
        source = glsl_program(
            shader, params, first_line=first_line, precise_inverse_trig=precise_inverse_trig
        )
        try:
            program = self._ctx.program(vertex_shader=_VERTEX_SHADER, fragment_shader=source)
        except moderngl.Error as error:
            raise MesaShaderError(source_name, _compiler_log(str(error), source_name)) from None
        try:
            for kind, name, value in params:
                if name in program:  # a parameter the shader never reads is not an active uniform
                    program[name].value = uniform_value(kind, name, value)
            for unit, name in enumerate(("brdf_studio_L", "brdf_studio_V")):
                if name in program:
                    program[name].value = unit
            vao = self._ctx.vertex_array(program, [])
            try:
                out = np.empty((len(lights), 3), dtype=np.float32)
                step = TEXELS_PER_ROW * ROWS_PER_DRAW
                for start in range(0, len(lights), step):
                    stop = min(start + step, len(lights))
                    out[start:stop] = self._draw(vao, lights[start:stop], views[start:stop])
                return out
            finally:
                vao.release()
        finally:
            program.release()

    def _draw(self, vao: Any, lights: np.ndarray, views: np.ndarray) -> np.ndarray:
        import moderngl

        n = len(lights)
        width = min(n, TEXELS_PER_ROW)
        height = -(-n // width)
        textures = []
        for unit, data in enumerate((lights, views)):
            padded = np.zeros((width * height, 3), dtype=np.float32)
            padded[:n] = data
            texture = self._ctx.texture((width, height), 3, padded.tobytes(), dtype="f4")
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            texture.use(unit)
            textures.append(texture)
        target = self._ctx.texture((width, height), 4, dtype="f4")
        framebuffer = self._ctx.framebuffer(color_attachments=[target])
        try:
            framebuffer.use()
            vao.render(moderngl.TRIANGLES, vertices=3)
            pixels = np.frombuffer(framebuffer.read(components=4, dtype="f4"), dtype=np.float32)
            return pixels.reshape(-1, 4)[:n, :3]
        finally:
            for obj in (framebuffer, target, *textures):
                obj.release()


_ORACLE: ShaderOracle | None = None


def shader_oracle() -> ShaderOracle:
    """The process's oracle, its context created on first use."""
    global _ORACLE
    if _ORACLE is None:
        _ORACLE = ShaderOracle()
    return _ORACLE


def evaluate_glsl(
    shader: str,
    params: Sequence[tuple[ParamKind, str, Any]],
    L: np.ndarray,
    V: np.ndarray,
    *,
    source_name: str = "shader",
    first_line: int = 1,
    precise_inverse_trig: bool = True,
) -> np.ndarray:
    """The shader's ``BRDF(L, V, N=(0,0,1), X=(1,0,0), Y=(0,1,0))``, evaluated by Mesa in float32.

    Parameters
    ----------
    shader : str
        GLSL defining ``vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)`` (a ``.brdf`` file's shader block).
    params : sequence of (kind, name, value)
        Every parameter of the file, each a uniform: ``("float", name, x)``, ``("color", name, (r, g, b))``,
        ``("bool", name, b)``.
    L, V : (n, 3) float
        Toward the light and toward the viewer, passed as given (rounded to float32, not normalized).
    source_name, first_line
        The file and the file line of the shader's first line, for Mesa's messages.
    precise_inverse_trig
        Replace Mesa's ``acos``/``asin``/``atan`` by accurate ones (see the module docstring).

    Returns
    -------
    (n, 3) float32

    Raises
    ------
    MesaShaderError
        Mesa refuses the shader (its log, with line numbers in the file).
    OracleUnavailableError
        No software OpenGL context: the message names the missing library and its Debian package.
    """
    return shader_oracle().evaluate(
        shader,
        params,
        L,
        V,
        source_name=source_name,
        first_line=first_line,
        precise_inverse_trig=precise_inverse_trig,
    )


def _directions(a: np.ndarray, what: str) -> np.ndarray:
    array = np.asarray(a)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{what} must be an (n, 3) array, got shape {array.shape}")
    return np.ascontiguousarray(array, dtype=np.float32)


def uniform_value(kind: str, name: str, value: Any) -> ParamValue:
    """A parameter's value as its uniform takes it: a float, a bool, or an (r, g, b) tuple."""
    if kind == "float":
        return float(value)
    if kind == "bool":
        return bool(value)
    if kind == "color":
        r, g, b = (float(c) for c in np.broadcast_to(np.asarray(value, dtype=float), (3,)))
        return r, g, b
    raise ValueError(f"parameter '{name}': unknown kind '{kind}' (expected float, color or bool)")


def _compiler_log(message: str, source_name: str) -> str:
    """Mesa's messages out of moderngl's ``GLSL Compiler failed`` text, each placed as ``path:line:column:``
    in the file, or said to be in the header before it."""
    lines = []
    for raw in message.splitlines():
        line = raw.strip()
        if not line or line in ("GLSL Compiler failed", "GLSL Linker failed", "fragment_shader"):
            continue
        if set(line) == {"="}:
            continue
        place = _MESA_PLACE.match(line)
        if place is None:
            lines.append(line)
        elif int(place["line"]) < HEADER_FIRST_LINE:
            lines.append(f"{source_name}:{place['line']}:{place['column']}: {place['message']}")
        else:
            lines.append(f"{source_name}: in the header put before the shader: {place['message']}")
    return "\n".join(lines)


_MESA_PLACE = re.compile(r"(?P<source>\d+):(?P<line>\d+)\((?P<column>\d+)\): (?P<message>.*)")


def _create_context() -> Any:
    """A standalone EGL context on Mesa's software renderer, or :class:`OracleUnavailableError`."""
    try:
        import moderngl
    except ImportError as error:
        raise OracleUnavailableError(
            f"the shader oracle needs the Python package moderngl ({error}); pip install 'moderngl>=5.8'"
        ) from None
    from ctypes.util import find_library

    # software rendering even where a GPU driver exists: llvmpipe's IEEE float32 is what the tolerances assume
    saved = os.environ.get("LIBGL_ALWAYS_SOFTWARE")
    os.environ["LIBGL_ALWAYS_SOFTWARE"] = "1"
    try:
        ctx = moderngl.create_standalone_context(
            backend="egl", require=410, libegl=find_library("EGL"), libgl=find_library("GL")
        )
    except Exception as error:
        missing = _missing_library()
        raise OracleUnavailableError(
            f"no software OpenGL context through EGL: {missing or error}; install the system packages "
            "of .ci/system-deps.sh"
        ) from None
    finally:
        if saved is None:
            del os.environ["LIBGL_ALWAYS_SOFTWARE"]
        else:
            os.environ["LIBGL_ALWAYS_SOFTWARE"] = saved
    renderer = ctx.info["GL_RENDERER"]
    if "llvmpipe" not in renderer:
        ctx.release()
        raise OracleUnavailableError(
            f"the OpenGL context runs on '{renderer}', not on Mesa's software renderer llvmpipe"
        )
    return ctx


def _missing_library() -> str:
    """The first library of a headless Mesa context that is absent, with its Debian package ('' if none)."""
    from ctypes.util import find_library

    for name, soname, package in _LIBRARIES:
        if find_library(name) is None:
            return f"{soname} is missing (Debian package {package})"
    folders = [os.environ.get("LIBGL_DRIVERS_PATH", ""), *_DRI_FOLDERS]
    if not any(os.path.exists(os.path.join(f, "swrast_dri.so")) for f in folders if f):
        return "Mesa's software driver swrast_dri.so is missing (Debian package libgl1-mesa-dri)"
    return ""
