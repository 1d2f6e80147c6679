"""GLSL's built-in functions against numpy on random arguments (hypothesis): every overload family, applied
component-wise on vectors and with scalar arguments spread over vectors, following GLSL's own definitions.
One shader holds every expression tested, picked by a parameter; each example is a batch of rows."""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from core.glsl import CompiledBrdf, compile_brdf, parse_brdf_text
from core.glsl.builtin_functions import BUILTINS
from tests.core.glsl._shaders import brdf_text, compile_shader, shader_value

# the parameter `which` picks the expression; a third vector argument arrives as the color parameter t
PARAMS = "float which 0 1000 0\ncolor t 0 0 0"

ROWS = 8
finite = st.floats(min_value=-40.0, max_value=40.0, allow_nan=False, allow_infinity=False, width=64)
vectors = arrays(np.float64, (ROWS, 3), elements=finite)
EXAMPLES = settings(max_examples=12, deadline=None)


def glsl_min(x, y):
    return np.where(y < x, y, x)


def glsl_max(x, y):
    return np.where(x < y, y, x)


def glsl_clamp(x, lo, hi):
    return glsl_min(glsl_max(x, lo), hi)


def smoothstep(e0, e1, x):
    t = glsl_clamp((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


UNARY: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "radians": lambda x: x * (np.pi / 180.0),
    "degrees": lambda x: x * (180.0 / np.pi),
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "asin": np.arcsin,
    "acos": np.arccos,
    "atan": np.arctan,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "tanh": np.tanh,
    "exp": np.exp,
    "log": np.log,
    "exp2": np.exp2,
    "log2": np.log2,
    "sqrt": np.sqrt,
    "inversesqrt": lambda x: 1.0 / np.sqrt(x),
    "abs": np.abs,
    "sign": np.sign,
    "floor": np.floor,
    "ceil": np.ceil,
    "fract": lambda x: x - np.floor(x),
}

BINARY: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "pow": lambda x, y: np.where(x < 0.0, np.nan, np.power(np.abs(x), y)),
    "atan": np.arctan2,
    "mod": lambda x, y: x - y * np.floor(x / y),
    "min": glsl_min,
    "max": glsl_max,
    "step": lambda edge, x: np.where(x < edge, 0.0, 1.0),
}

TERNARY: dict[str, Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]] = {
    "clamp": glsl_clamp,
    "mix": lambda x, y, a: x * (1.0 - a) + y * a,
    "smoothstep": smoothstep,
}


def dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def spread(value: np.ndarray) -> np.ndarray:
    """A scalar per row as the rows of a vec3."""
    return np.repeat(value[:, None], 3, axis=1)


GEOMETRIC: dict[str, tuple[str, Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]]] = {
    "dot": ("vec3(dot(L, V))", lambda a, b, c: spread(dot(a, b))),
    "length": ("vec3(length(L))", lambda a, b, c: spread(np.sqrt(dot(a, a)))),
    "distance": ("vec3(distance(L, V))", lambda a, b, c: spread(np.sqrt(dot(a - b, a - b)))),
    "normalize": ("normalize(L)", lambda a, b, c: a / np.sqrt(dot(a, a))[:, None]),
    "cross": ("cross(L, V)", lambda a, b, c: np.cross(a, b)),
    "reflect": ("reflect(L, V)", lambda a, b, c: a - (2.0 * dot(b, a))[:, None] * b),
    "faceforward": ("faceforward(L, V, t)", lambda a, b, c: np.where((dot(c, b) < 0)[:, None], a, -a)),
    "refract": ("refract(L, V, t.x)", None),  # below, with its own case split
}


def expressions_under_test() -> list[str]:
    expressions = []
    for name in UNARY:
        expressions += [f"{name}(L)", f"vec3({name}(L.y))"]
    for name in BINARY:
        expressions.append(f"{name}(L, V)")
    expressions += ["mod(L, V.z)", "min(L, V.z)", "max(L, V.z)", "step(L.x, V)"]
    for name in TERNARY:
        expressions.append(f"{name}(L, V, t)")
    expressions += ["clamp(L, V.x, t.y)", "mix(L, V, t.z)", "smoothstep(L.x, V.y, t)"]
    expressions += [expression for expression, _ in GEOMETRIC.values()]
    return expressions


EXPRESSIONS = expressions_under_test()


@cache
def compiled() -> CompiledBrdf:
    cases = "\n".join(f"    if (k == {i}) return {e};" for i, e in enumerate(EXPRESSIONS))
    shader = f"vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{{\n    int k = int(which);\n{cases}\n    return vec3(0);\n}}"
    return compile_shader(shader, PARAMS)


def run(expression: str, a: np.ndarray, b: np.ndarray, c: np.ndarray | None = None) -> np.ndarray:
    """The expression for each row of ``a`` (L) and ``b`` (V); ``c`` (t) is one vector for all rows."""
    params = np.array([EXPRESSIONS.index(expression), *(np.zeros(3) if c is None else c)], dtype=float)
    return compiled().evaluate(a, b, params)


def assert_close(got: np.ndarray, expected: np.ndarray) -> None:
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-300, equal_nan=True)


def test_every_builtin_is_tested():
    assert set(BUILTINS) == set(UNARY) | set(BINARY) | set(TERNARY) | set(GEOMETRIC)


@pytest.mark.parametrize("name", sorted(UNARY))
@EXAMPLES
@given(x=vectors)
def test_unary(name, x):
    with np.errstate(all="ignore"):
        expected = UNARY[name](x)
    assert_close(run(f"{name}(L)", x, x), expected)
    assert_close(run(f"vec3({name}(L.y))", x, x), spread(expected[:, 1]))


@pytest.mark.parametrize("name", sorted(BINARY))
@EXAMPLES
@given(x=vectors, y=vectors)
def test_binary(name, x, y):
    with np.errstate(all="ignore"):
        assert_close(run(f"{name}(L, V)", x, y), BINARY[name](x, y))
        if name in ("mod", "min", "max"):  # genType f(genType, float)
            assert_close(run(f"{name}(L, V.z)", x, y), BINARY[name](x, y[:, 2:3]))
        if name == "step":  # genType step(float, genType)
            assert_close(run("step(L.x, V)", x, y), BINARY[name](x[:, 0:1], y))


@pytest.mark.parametrize("name", sorted(TERNARY))
@EXAMPLES
@given(x=vectors, y=vectors, z=vectors)
def test_ternary(name, x, y, z):
    function = TERNARY[name]
    t = z[0]
    with np.errstate(all="ignore"):
        assert_close(run(f"{name}(L, V, t)", x, y, t), function(x, y, t))
        if name == "clamp":
            assert_close(run("clamp(L, V.x, t.y)", x, y, t), function(x, y[:, 0:1], t[1]))
        if name == "mix":
            assert_close(run("mix(L, V, t.z)", x, y, t), function(x, y, t[2]))
        if name == "smoothstep":
            assert_close(run("smoothstep(L.x, V.y, t)", x, y, t), function(x[:, 0:1], y[:, 1:2], t))


@pytest.mark.parametrize("name", sorted(set(GEOMETRIC) - {"refract"}))
@EXAMPLES
@given(x=vectors, y=vectors, z=vectors)
def test_geometric(name, x, y, z):
    expression, function = GEOMETRIC[name]
    with np.errstate(all="ignore"):
        assert_close(run(expression, x, y, z[0]), function(x, y, z[0]))


@settings(max_examples=30, deadline=None)
@given(
    incident=vectors,
    normal=vectors,
    eta=st.floats(min_value=0.2, max_value=3.0, allow_nan=False, width=64),
)
def test_refract(incident, normal, eta):
    """GLSL's refract: zero under total internal reflection, else eta I - (eta N.I + sqrt(k)) N."""
    with np.errstate(all="ignore"):
        i = incident / np.linalg.norm(incident, axis=1, keepdims=True)
        n = normal / np.linalg.norm(normal, axis=1, keepdims=True)
        cosine = dot(n, i)
        k = 1.0 - eta * eta * (1.0 - cosine * cosine)
        refracted = eta * i - (eta * cosine + np.sqrt(k))[:, None] * n
        expected = np.where((k < 0)[:, None], 0.0, refracted)
    assert_close(run("refract(L, V, t.x)", i, n, np.array([eta, 0.0, 0.0])), expected)


def test_vec2_and_vec4_overloads():
    got = shader_value(
        "vec4 a = vec4(-1, 4, 9, 0.25); vec2 b = vec2(3, 4); return vec3(sqrt(a).yz, length(b)) + vec3(dot(a, a), 0, 0);"
    )
    assert got.tolist() == [2.0 + 1 + 16 + 81 + 0.0625, 3.0, 5.0]


def test_integer_arguments_convert_to_float():
    got = shader_value(
        "return vec3(max(0, -1.5), clamp(1 - 2, 0, 1), mix(0, 10, 0.25)) + vec3(step(1, 2), pow(2, 3), 0);"
    )
    assert got.tolist() == [1.0, 8.0, 2.5]


def test_pow_of_a_negative_base_is_nan_as_on_gpus():
    """pow(x, y) for x < 0 is NaN (GPUs compute exp2(y log2 x)) unless y is a constant 1, 2 or 4 or both
    are constants; otherwise C's pow."""
    got = shader_value("float b = L.z - 3.0;\nreturn vec3(pow(b, 3.0), pow(b, 0.5), pow(0.0, 0.0));")
    assert np.isnan(got[0]) and np.isnan(got[1]) and got[2] == 1.0
    # a constant base and exponent are folded as C computes them, as GPU compilers do
    assert shader_value("return vec3(pow(-2.0, 3.0), pow(-0.5, 10.0), 0.0);").tolist() == [-8.0, 0.5**10, 0.0]
    assert shader_value("return vec3(pow(2.0, 3.0), pow(4.0, 0.5), pow(0.0, 2.0));").tolist() == [
        8.0,
        2.0,
        0.0,
    ]


def test_pow_by_a_constant_1_2_or_4_is_multiplication_as_gpu_compilers_make_it():
    """A literal exponent, an int literal, or a const variable holding one (even through a negation) gives
    x, x x, (x x)(x x) for any base, as Mesa does; an exponent of 3, or a parameter equal to 2, does not,
    and the code specialized to the parameter's value computes the same (the parameter is not a constant
    to the shader's semantics)."""
    helpers = "const float TWO = 2.0;\nconst float MINUS_FOUR = -4.0;"
    body = "const float FOUR = -MINUS_FOUR;\nreturn vec3(pow(-3.0, 2) + pow(-3.0, 1.0), pow(-2.0, FOUR), pow(-3.0, TWO));"
    assert shader_value(body, helpers=helpers).tolist() == [6.0, 16.0, 9.0]
    got = shader_value(
        "float b = L.z - 3.0;\nreturn vec3(pow(b, 3.0), pow(b, e), 0.0);", params="float e 0 4 2"
    )
    assert np.isnan(got[0]) and np.isnan(got[1])
    shader = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(pow(L.z - 3.0, e)); }"
    brdf = parse_brdf_text(brdf_text(shader, "float e 0 4 2"), "test.brdf")
    normal = np.array([[0.0, 0.0, 1.0]])
    assert np.isnan(compile_brdf(brdf, [2.0]).evaluate(normal, normal)).all()
