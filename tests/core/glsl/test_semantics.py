"""GLSL's meaning, shader by shader: conversions, vectors, evaluation order, control flow, scopes, overloads,
uniforms; and the checker's errors, at the right line of the .brdf file."""

from __future__ import annotations

import ctypes
import math
import threading

import numpy as np
import pytest

from core.errors import ParameterError
from core.glsl import ShaderError
from tests.core.glsl._shaders import SHADER_LINE, compile_shader, shader_value

# a global counter and a function that counts its calls: what ran can be read from the result
COUNTER = """
int calls = 0;
bool hit() { calls++; return true; }
float tally(float x) { calls++; return x; }
"""


def value(body: str, **kwargs) -> list[float]:
    return shader_value(body, **kwargs).tolist()


# ---- numbers


def test_int_and_float_arithmetic():
    assert value("return vec3(1/2, 1/2.0, 3*0.5);") == [0.0, 0.5, 1.5]
    assert value("float x = 1; int i = 7; return vec3(x + i, i / 2, -7 / 2);") == [8.0, 3.0, -3.0]
    assert value("int i = 5; i += 2; i *= 3; i -= 1; i /= 4; return vec3(i, 2 - 5, -(3));") == [
        5.0,
        -3.0,
        -3.0,
    ]


def test_int_division_by_zero_is_defined():
    assert value("int zero = 0; int big = -2147483647 - 1; return vec3(5 / zero, big / -1, 0);") == [
        0.0,
        -2147483648.0,
        0.0,
    ]


def test_scalar_constructors_convert():
    assert value("return vec3(int(-2.7), int(2.7), int(0.0 / 0.0));") == [-2.0, 2.0, 0.0]
    assert value("return vec3(float(true), float(bool(0.5)), float(bool(0)));") == [1.0, 1.0, 0.0]
    assert value("return vec3(int(1e30), int(-1e30), float(int(true)));") == [
        2147483647.0,
        -2147483648.0,
        1.0,
    ]


def test_float_literals():
    assert value("return vec3(.5, 1., 1.5e-3) + vec3(2e2, 0x10, 010);") == [200.5, 17.0, 8.0015]


def test_raw_values_pass_through():
    """No clamping or sanitizing: negative, infinite and NaN values come out as the shader computes them."""
    got = shader_value("float zero = 0.0; return vec3(-1.0, 1.0 / zero, zero / zero);")
    assert got[0] == -1.0 and got[1] == math.inf and math.isnan(got[2])


# ---- vectors


def test_swizzles_read_and_write():
    assert value("vec4 v = vec4(1, 2, 3, 4); return v.wzy;") == [4.0, 3.0, 2.0]
    assert value("vec4 v = vec4(1, 2, 3, 4); return vec3(v.rg, v.q);") == [1.0, 2.0, 4.0]
    assert value("vec4 v = vec4(1, 2, 3, 4); v.zx = vec2(9, 8); return v.xyz + vec3(0, 0, v.w);") == [
        8.0,
        2.0,
        13.0,
    ]
    assert value("vec3 v = vec3(1, 2, 3); v.yz += 10.0; return v.zyx.xyz;") == [13.0, 12.0, 1.0]
    assert value("vec3 v = vec3(1, 2, 3); return vec3(v.zyx.xy, v.x);") == [3.0, 2.0, 1.0]


def test_indexing_constant_and_computed():
    assert value(
        "vec3 v = vec3(1, 2, 3); int i = 2; v[i] = 7.0; v[0] += 1.0; return vec3(v[i], v[0], v[1]);"
    ) == [
        7.0,
        2.0,
        2.0,
    ]
    got = shader_value("vec3 v = vec3(1, 2, 3); int j = 7; v[j] = 5.0; return vec3(v[j], v[1], v[2]);")
    assert math.isnan(got[0]) and got[1:].tolist() == [2.0, 3.0]  # out of range: reads NaN, writes nothing


def test_vector_arithmetic_and_scalars():
    assert value("return vec3(1, 2, 3) * vec3(2) + 1;") == [3.0, 5.0, 7.0]
    assert value("return 2.0 / vec3(1, 2, 4) - vec3(1);") == [1.0, 0.0, -0.5]
    assert value("return -vec3(1, 2, 3) * 2;") == [-2.0, -4.0, -6.0]
    assert value("vec3 a = vec3(1); a *= 2; a += vec3(1, 2, 3); a /= 2; a++; return a;") == [2.5, 3.0, 3.5]
    assert value("vec3 a = vec3(1); vec3 b = a++; vec3 c = ++a; return vec3(b.x, c.x, a.x);") == [
        1.0,
        3.0,
        3.0,
    ]


def test_vector_equality():
    assert value(
        "return vec3(vec3(1, 2, 3) == vec3(1, 2, 3), vec2(1, 2) != vec2(1, 2), vec2(1, 2) != vec2(1, 3));"
    ) == [
        1.0,
        0.0,
        1.0,
    ]


def test_vector_constructors():
    assert value("return vec3(vec2(1, 2), 3);") == [1.0, 2.0, 3.0]
    assert value("return vec3(vec4(1, 2, 3, 4));") == [1.0, 2.0, 3.0]
    assert value("return vec3(vec2(vec3(5, 6, 7)), 0);") == [5.0, 6.0, 0.0]
    assert value("return vec3(true, 0, 2) + vec4(1).xyz;") == [2.0, 1.0, 3.0]
    assert value("return vec3(1, vec2(2, 3));") == [1.0, 2.0, 3.0]


# ---- what gets evaluated


def test_logical_operators_short_circuit():
    body = """
    bool a = false && hit();
    bool b = true || hit();
    bool c = true && hit();
    bool d = false || hit();
    return vec3(calls, float(a) + 2.0 * float(b), float(c ^^ d) + 2.0 * float(!c));
    """
    assert value(body, helpers=COUNTER) == [2.0, 2.0, 0.0]


def test_conditional_evaluates_the_taken_branch_only():
    body = """
    float zero = 0.0;
    float a = zero > 1.0 ? 1.0 / zero : 2.0;
    float b = zero == 0.0 ? 3.0 : zero / zero;
    float c = true ? 1.0 : tally(5.0);
    float d = false ? tally(5.0) : tally(7.0);
    return vec3(a + b, c + d, calls);
    """
    assert value(body, helpers=COUNTER) == [5.0, 8.0, 1.0]


def test_globals_start_again_each_evaluation():
    compiled = compile_shader(
        COUNTER + "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { hit(); hit(); return vec3(calls); }"
    )
    rows = np.tile([[0.0, 0.0, 1.0]], (5, 1))
    assert np.all(compiled.evaluate(rows, rows) == 2.0)


# ---- statements


def test_loops_break_and_continue():
    body = """
    float total = 0.0;
    for (int i = 0; i < 10; i++) {
        if (i == 2) continue;
        if (i == 5) break;
        total += float(i);              // 0 + 1 + 3 + 4
    }
    int n = 0;
    while (n < 100) n += 7;
    int m = 10;
    do { m--; } while (m > 100);
    float nested = 0.0;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            if (b > a) break;
            nested += 1.0;              // 1 + 2 + 3
        }
    return vec3(total, float(n + m), nested);
    """
    assert value(body) == [8.0, 114.0, 6.0]


def test_loop_without_condition_and_comma_expressions():
    body = """
    int i, j;
    float steps = 0.0;
    for (i = 0, j = 10; ; i++, j--) {
        if (i >= j) break;
        steps += 1.0;
    }
    return vec3(steps, i, j);
    """
    assert value(body) == [5.0, 5.0, 5.0]


def test_return_from_nested_blocks():
    helpers = """
    float first_index_above(vec3 v, float limit)
    {
        for (int i = 0; i < 3; i++) {
            if (v[i] > limit) {
                { return float(i); }
            }
        }
        return -1.0;
    }
    void nothing() { return; }
    """
    body = """
    nothing();
    vec3 v = vec3(0.1, 0.7, 0.9);
    return vec3(first_index_above(v, 0.5), first_index_above(v, 0.8), first_index_above(v, 2.0));
    """
    assert value(body, helpers=helpers) == [1.0, 2.0, -1.0]


def test_scopes_and_shadowing():
    body = """
    float x = 1.0;
    { float x = 2.0; x += 1.0; }
    int i = 5;
    for (int i = 0; i < 3; i++) {}
    float y = 2.0;
    { float y = y + 1.0; x += y; }        // the new y is initialized from the outer one
    if (true) float z = 9.0;
    return vec3(x, i, y);
    """
    assert value(body) == [4.0, 5.0, 2.0]


def test_a_local_named_like_a_function():
    helpers = "float G(float v) { return 2.0 * v; }"
    assert value("float G = G(1.5) + G(0.5); G *= 2.0; return vec3(G);", helpers=helpers) == [8.0, 8.0, 8.0]


def test_user_functions_take_precedence_over_builtins():
    helpers = """
    float max(float a, float b) { return a + b; }
    vec3 reflect(vec3 I, vec3 N) { return 2.0 * dot(I, N) * N - I; }
    """
    body = "return vec3(max(1.0, 2.0), max(1, 2), reflect(vec3(1, 0, 1), vec3(0, 0, 1)).x);"
    assert value(body, helpers=helpers) == [3.0, 3.0, -1.0]


def test_builtins_before_a_redefinition_are_glsls():
    helpers = """
    float before() { return max(1.0, 2.0); }
    float max(float a, float b) { return a + b; }
    """
    assert value("return vec3(before(), max(1.0, 2.0), 0);", helpers=helpers) == [2.0, 3.0, 0.0]


def test_overloads_by_argument_types():
    helpers = """
    float f(float x) { return 1.0; }
    float f(vec3 x) { return 3.0; }
    float f(int x) { return 4.0; }
    float g(float x, float y) { return x - y; }
    """
    assert value("return vec3(f(1.0), f(vec3(0)), f(2)) + vec3(0, 0, g(1, 3));", helpers=helpers) == [
        1.0,
        3.0,
        2.0,
    ]


def test_prototype_then_definition():
    helpers = "float later(float x);\nfloat use_it() { return later(2.0); }"
    shader = f"{helpers}\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) {{ return vec3(use_it()); }}\nfloat later(float x) {{ return x * 10.0; }}"
    compiled = compile_shader(shader)
    normal = np.array([[0.0, 0.0, 1.0]])
    assert compiled.evaluate(normal, normal).tolist() == [[20.0, 20.0, 20.0]]


def test_glsl_min_max_clamp_with_nan():
    """GLSL defines min(x, y) = y < x ? y : x and max(x, y) = x < y ? y : x: a NaN in y is dropped, in x kept."""
    got = shader_value(
        "float nan = 0.0 / 0.0; return vec3(min(1.0, nan), max(nan, 1.0), clamp(nan, 0.0, 1.0));"
    )
    assert got[0] == 1.0 and math.isnan(got[1]) and math.isnan(got[2])


# ---- uniforms and what the compiled object reports


def test_uniforms_in_declaration_order():
    params = "float a 0 10 1\ncolor c .1 .2 .3\nbool flag 1\nfloat b 0 10 2"
    compiled = compile_shader(
        "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return flag ? c * a + vec3(b) : vec3(-1); }",
        params,
    )
    normal = np.array([[0.0, 0.0, 1.0]])
    assert compiled.source.default_parameters().tolist() == [1.0, 0.1, 0.2, 0.3, 1.0, 2.0]
    np.testing.assert_allclose(compiled.evaluate(normal, normal)[0], [2.1, 2.2, 2.3], rtol=1e-15)
    p = np.array([2.0, 1.0, 2.0, 3.0, 0.5, 0.0])  # any nonzero bool is true
    assert compiled.evaluate(normal, normal, p)[0].tolist() == [2.0, 4.0, 6.0]
    p[4] = 0.0
    assert compiled.evaluate(normal, normal, p)[0].tolist() == [-1.0, -1.0, -1.0]
    assert compiled.reads_uniforms == {"a", "b", "c", "flag"}
    with pytest.raises(ParameterError, match="expected 6 parameter values"):
        compiled.evaluate(normal, normal, np.zeros(5))
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        compiled.evaluate(normal[:, :2], normal[:, :2])


def test_reads_uniforms_only_from_reachable_code():
    params = "float used 0 1 .5\nfloat unused 0 1 .5"
    shader = """
    float never_called() { return unused; }
    float helper() { return used; }
    vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(helper()); }
    """
    assert compile_shader(shader, params).reads_uniforms == {"used"}


@pytest.mark.parametrize(
    ("body", "uses"),
    [
        ("return N;", False),
        ("X = vec3(0); Y = vec3(1); return N;", False),
        ("return vec3(dot(L, X));", True),
        ("return vec3(project(V, Y));", True),
        ("vec3 T = true ? X : N; return T;", True),
        ("X.x += 1.0; return N;", True),
    ],
)
def test_uses_tangents(body, uses):
    helpers = "float project(vec3 v, vec3 X) { return dot(v, X); }"
    shader = f"{helpers}\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) {{ {body} }}"
    assert compile_shader(shader).uses_tangents is uses


def test_frame_and_directions():
    """N, X, Y are the local frame's axes; L and V arrive as given."""
    compiled = compile_shader(
        "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return 100.0 * N + 10.0 * X + Y + L * V; }"
    )
    got = compiled.evaluate(np.array([[0.1, 0.2, 0.3]]), np.array([[2.0, 3.0, 4.0]]))[0]
    np.testing.assert_allclose(got, [10.2, 1.6, 101.2], rtol=1e-15)


def test_the_address_is_a_reentrant_c_function():
    """The C entry point, called through its address from several threads at once, gives each its value."""
    compiled = compile_shader(
        "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { float s = 0.0; for (int i = 0; i < 50; i++) s += L.x; return vec3(s, V.y, k); }",
        "float k 0 10 3",
    )
    signature = ctypes.CFUNCTYPE(
        None, *[ctypes.c_double] * 6, ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p
    )
    function = signature(compiled.address)
    params = np.array([3.0])
    errors = []

    def worker(seed: int) -> None:
        out = np.empty(3)
        for i in range(2000):
            x = seed + i * 1e-3
            function(x, 0.0, 1.0, 0.0, -x, 1.0, params.ctypes.data, 1, out.ctypes.data)
            if not (abs(out[0] - 50 * x) <= 1e-9 * abs(50 * x) and out[1] == -x and out[2] == 3.0):
                errors.append((seed, i, out.copy()))

    threads = [threading.Thread(target=worker, args=(seed,)) for seed in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []


# ---- errors


def error_of(body: str, helpers: str = "", params: str = "") -> ShaderError:
    shader = f"{helpers}\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{{\n{body}\n}}\n"
    with pytest.raises(ShaderError) as caught:
        compile_shader(shader, params)
    return caught.value


HELPERS = """void nothing() {}
float ambiguous(int a, float b) { return 1.0; }
float ambiguous(float a, int b) { return 2.0; }"""
BODY_LINE = SHADER_LINE + 3 + 2  # below the three helper lines, BRDF's header and its brace


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("float G = 1.0; return vec3(G(1.0));", f"'G' is a variable here (line {BODY_LINE}), not a function"),
        ("float f = nothing(); return vec3(f);", "initializing 'f': the expression has no value (void)"),
        ("return vec3(1.0 + nothing());", "a void function call has no value to use here"),
        ("break; return N;", "'break' outside a loop"),
        ("return vec3(5 % 2);", "operator '%' is reserved in GLSL 1.20"),
        ("return vec3(5 & 2);", "operator '&' is reserved in GLSL 1.20"),
        ("float f = 1.0; f *= vec3(1); return N;", "'*=' would turn the float on its left into a vec3"),
        ("int i = 1; i += 0.5; return N;", "'+=' would turn the int on its left into a float"),
        ("vec3 v = N; return vec3(v[1.0]);", "an index must be an int, not float"),
        ("vec3 v = N; return vec3(v[3]);", "index 3 is outside the 3 components of a vec3"),
        ("vec3 v = N; v.xx = vec2(1); return v;", "cannot assign to '.xx': it names a component twice"),
        ("vec3 v = N; return vec3(v.xg, 1);", "'.xg' is not a swizzle"),
        ("float f = 1.0; return vec3(f.x);", "a float has no components"),
        (
            "float a = 1.0; float a = 2.0; return N;",
            f"'a' is already declared in this scope (line {BODY_LINE})",
        ),
        ("const float c; return N;", "const 'c' needs an initializer"),
        ("const float c = k; return N;", "the initializer of const 'c' is not a constant expression"),
        ("uniform float u; return N;", "uniform declarations are not supported"),
        ("discard; return N;", "'discard' has no meaning in a BRDF shader"),
        ("if (L < V) return N; return N;", "operator '<' compares scalar numbers, not vec3 and vec3"),
        ("if (1) return N; return N;", "the condition of 'if' must be a bool, not int"),
        ("while (k) {} return N;", "the condition of 'while' must be a bool, not float"),
        ("return vec3(true && 1.0);", "operator '&&' needs bools, not float"),
        ("return vec3(!1.0);", "operator '!' needs a bool, not float"),
        ("return vec3(-true);", "operator '-' needs a number or a vector, not bool"),
        ("return vec3(L + vec2(1));", "operator '+' cannot combine vec3 and vec2"),
        ("return true ? N : 1.0;", "the two branches of '?:': vec3 and float do not match"),
        ("return vec3(1, 2);", "vec3() needs 3 components, the arguments give 2"),
        ("return vec3(1, 2, 3, 4);", "too many arguments to vec3(): argument 4 is not used"),
        ("return vec3(float(1, 2));", "float() takes one argument, not 2"),
        ("return vec3(ambiguous(1, 1));", "the call ambiguous(int, int) is ambiguous"),
        ("return vec3(k);", "unknown identifier 'k'"),
        ("return vec3(dot);", "'dot' is a function: call it with arguments"),
        ("(L + V) = N; return N;", "this expression cannot be assigned to"),
        ("return;", "'BRDF' must return a vec3"),
        ("return 1.0;", "returning from 'BRDF': cannot convert float to vec3"),
        ("return vec3(2147483648);", "integer 2147483648 does not fit in 32 bits"),
        ("float gl_x = 1.0; return N;", "names starting with 'gl_' belong to GLSL"),
        ("float a__b = 1.0; return N;", "GLSL keeps names containing '__' for itself"),
    ],
)
def test_errors_name_the_problem_and_its_line(body, message):
    params = "" if "unknown identifier 'k'" in message else "float k 0 1 .5"
    error = error_of(body, helpers=HELPERS, params=params)
    assert message in error.message
    assert error.line == BODY_LINE


@pytest.mark.parametrize(
    ("shader", "line", "message"),  # line: counted from the shader's first
    [
        ("float f(out float x) { return 1.0; }", 0, "'out' parameters are not supported"),
        (
            "float f(float x);\nfloat g() { return f(1.0); }",
            1,
            "function 'float f(float)' is declared but never defined",
        ),
        (
            "float f() { return 1.0; }\nint f() { return 1; }",
            1,
            "'f()' was declared returning float (line 3)",
        ),
        (
            "float f() { return 1.0; }\nfloat f() { return 2.0; }",
            1,
            "'float f()' is already defined (line 3)",
        ),
        ("float f() { return 1.0; }\nfloat x = f();", 1, "the initializer of global 'x' calls a function"),
        ("float x = 1.0;\nfloat x() { return 1.0; }", 1, "'x' is already declared as a variable"),
        ("float k = 1.0;", 0, "'k' is already declared as a parameter of the file"),
        ("void v;", 0, "a variable cannot be void"),
        ("float f(float a, float a) { return a; }", 0, "two parameters are named 'a'"),
        (
            "float mix(float a) { return a; }\nfloat g() { return mix(1.0, 2.0, 0.5); }",
            1,
            "'mix' takes 1 argument, not 3",
        ),
    ],
)
def test_declaration_errors(shader, line, message):
    brdf = "\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return N; }"
    with pytest.raises(ShaderError) as caught:
        compile_shader(shader + brdf, "float k 0 1 .5")
    assert message in caught.value.message
    assert caught.value.line == SHADER_LINE + line
