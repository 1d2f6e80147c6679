"""BRDF Explorer's analytic ``.brdf`` files compiled to native kernels.

The steps, one module each: :mod:`~core.glsl.brdf_file` reads the file's parameters and cuts out its GLSL;
:mod:`~core.glsl.parser` parses the GLSL with the lark grammar ``glsl.lark`` into a :mod:`~core.glsl.syntax`
tree; :mod:`~core.glsl.checker` types it and binds its names against the built-ins of
:mod:`~core.glsl.builtin_functions`, giving a :mod:`~core.glsl.program`; :mod:`~core.glsl.codegen` lowers that
to LLVM IR; :mod:`~core.glsl.compiler` optimizes and JIT-compiles it to a C function pointer.

>>> brdf = compile_brdf(read_brdf_file("principled.brdf"))      # doctest: +SKIP
>>> brdf.evaluate(wi, wo)                                       # doctest: +SKIP
"""

from core.glsl.brdf_file import BrdfFile, ShaderParam, parse_brdf_text, read_brdf_file
from core.glsl.compiler import CompiledBrdf, compile_brdf
from core.glsl.errors import ShaderError

__all__ = [
    "BrdfFile",
    "CompiledBrdf",
    "ShaderError",
    "ShaderParam",
    "compile_brdf",
    "parse_brdf_text",
    "read_brdf_file",
]
