"""GLSL's reserved words: a file parameter or a shader identifier may not take any of them."""

from __future__ import annotations

# GLSL 1.20 keywords, the words it reserves for future use, and the keywords later versions added that a
# shader written for a newer driver may contain.
GLSL_KEYWORDS: frozenset[str] = frozenset(
    """
    attribute const uniform varying centroid invariant break continue do for while if else in out inout
    float int void bool true false discard return struct
    vec2 vec3 vec4 ivec2 ivec3 ivec4 bvec2 bvec3 bvec4 uvec2 uvec3 uvec4 uint
    mat2 mat3 mat4 mat2x2 mat2x3 mat2x4 mat3x2 mat3x3 mat3x4 mat4x2 mat4x3 mat4x4
    dmat2 dmat3 dmat4 dvec2 dvec3 dvec4 double
    sampler1D sampler2D sampler3D samplerCube sampler1DShadow sampler2DShadow sampler2DRect sampler3DRect
    sampler2DRectShadow
    asm class union enum typedef template this packed goto switch case default inline noinline volatile
    public static extern external interface long short half fixed unsigned lowp mediump highp precision
    input output hvec2 hvec3 hvec4 fvec2 fvec3 fvec4 sizeof cast namespace using
    flat smooth noperspective layout patch sample subroutine buffer shared coherent restrict readonly
    writeonly precise
    """.split()
)


def reserved_name_problem(name: str) -> str | None:
    """Why ``name`` cannot name a variable, function or parameter in GLSL, or None if it can."""
    if name in GLSL_KEYWORDS:
        return f"'{name}' is a GLSL keyword"
    if name.startswith("gl_"):
        return f"'{name}' is reserved: names starting with 'gl_' belong to GLSL"
    if "__" in name:
        return f"'{name}' is reserved: GLSL keeps names containing '__' for itself"
    return None
