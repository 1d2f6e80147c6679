"""Reading .brdf files: the parameter section, the shader's place in the file, and the file-level errors
(the bad fixtures cover the common ones; the rest are here)."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import FileFormatError
from core.glsl import BrdfFile, ShaderError, ShaderParam, parse_brdf_text, read_brdf_file

SAMPLE = """\

# a comment before the header
analytic

# variables go here...
::begin parameters
float roughness 0.01 1 .5   # a trailing comment
color tint .1 .2 .3
\tbool   flip 1
::end parameters

::begin shader
// GLSL
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return tint * roughness; }
::end shader
"""


def test_sample_parameters_and_shader():
    brdf = parse_brdf_text(SAMPLE, "sample.brdf")
    assert isinstance(brdf, BrdfFile)
    assert brdf.path == "sample.brdf"
    assert brdf.params == (
        ShaderParam("roughness", "float", 0.01, 1.0, 0.5),
        ShaderParam("tint", "color", 0.0, 1.0, (0.1, 0.2, 0.3)),
        ShaderParam("flip", "bool", 0.0, 1.0, 1.0),
    )
    assert [p.slot_count for p in brdf.params] == [1, 3, 1]
    assert brdf.default_parameters().tolist() == [0.5, 0.1, 0.2, 0.3, 1.0]
    lines = SAMPLE.splitlines()
    assert brdf.shader_line == lines.index("// GLSL") + 1
    assert brdf.shader.splitlines() == lines[brdf.shader_line - 1 : lines.index("::end shader")]


def test_windows_line_endings(tmp_path):
    path = tmp_path / "crlf.brdf"
    path.write_bytes(SAMPLE.replace("\n", "\r\n").encode())
    brdf = read_brdf_file(path)
    assert brdf.path == str(path)
    assert brdf.params == parse_brdf_text(SAMPLE).params
    assert brdf.shader == parse_brdf_text(SAMPLE).shader


def test_an_unreadable_file_is_a_file_format_error(tmp_path):
    with pytest.raises(FileFormatError, match="cannot read") as caught:
        read_brdf_file(tmp_path / "missing.brdf")
    assert not isinstance(caught.value, ShaderError)


def test_no_parameters_section_is_fine():
    brdf = parse_brdf_text("analytic\n::begin shader\nvoid f() {}\n::end shader\n")
    assert brdf.params == () and brdf.shader == "void f() {}" and brdf.shader_line == 3
    assert brdf.default_parameters().shape == (0,)


SHADER = "::begin shader\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return N; }\n::end shader\n"


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ("", 1, "empty file: expected the header 'analytic'"),
        ("analytic\nstray words\n" + SHADER, 2, "unexpected text outside the parameters and shader sections"),
        ("analytic\n::begin colors\n", 2, "unknown section 'colors'"),
        ("analytic\n" + SHADER + SHADER, 5, "a second shader section (the first begins on line 2)"),
        ("analytic\n::begin parameters\n::end shader\n", 3, "'::end shader' closes the parameters section"),
        ("analytic\n::end parameters\n", 2, "'::end parameters' without a matching '::begin'"),
        ("analytic\n::begin parameters\n::begin shader\n", 3, "inside the parameters section"),
        (
            "analytic\n::begin parameters\nbool b 2\n::end parameters\n" + SHADER,
            3,
            "bool 'b': default must be 0 or 1",
        ),
        (
            "analytic\n::begin parameters\ncolor c 1 1.5 1\n::end parameters\n" + SHADER,
            3,
            "component 1.5 is outside [0, 1]",
        ),
        (
            "analytic\n::begin parameters\nfloat 2x 0 1 0\n::end parameters\n" + SHADER,
            3,
            "'2x' is not a GLSL identifier",
        ),
        (
            "analytic\n::begin parameters\nfloat x 0 nan 0\n::end parameters\n" + SHADER,
            3,
            "'nan' is not a finite number",
        ),
        (
            "analytic\n::begin parameters\nfloat gl_x 0 1 0\n::end parameters\n" + SHADER,
            3,
            "names starting with 'gl_'",
        ),
        ("analytic\n::begin parameters\nbool if 0\n::end parameters\n" + SHADER, 3, "'if' is a GLSL keyword"),
    ],
)
def test_file_errors(text, line, message):
    with pytest.raises(ShaderError) as caught:
        parse_brdf_text(text, "bad.brdf")
    assert caught.value.line == line
    assert message in caught.value.message
    assert str(caught.value).startswith(f"bad.brdf:{line}:")


def test_error_column_points_at_the_field():
    with pytest.raises(ShaderError) as caught:
        parse_brdf_text("analytic\n::begin parameters\nfloat k 0 1 7\n::end parameters\n" + SHADER, "x.brdf")
    assert (caught.value.line, caught.value.column) == (3, 13)
    assert np.isclose(caught.value.column, len("float k 0 1 ") + 1)
