"""BRDF Explorer's analytic ``.brdf`` files: the parameter list and the GLSL shader, with their line numbers.

The format (github wdas/brdf, ``src/brdfs/``)::

    analytic
    # comment
    ::begin parameters
    float NAME MIN MAX DEFAULT
    color NAME R G B
    bool NAME DEFAULT
    ::end parameters
    ::begin shader
    ... GLSL defining vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) ...
    ::end shader

The sections are read line by line here; the shader is only cut out (see :mod:`core.glsl.parser` for its
grammar). Every parameter becomes a uniform of the shader: ``float`` a float, ``color`` a vec3 and ``bool``
a bool.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from core.errors import FileFormatError
from core.glsl.errors import ShaderError
from core.glsl.keywords import reserved_name_problem

ParamKind = Literal["float", "color", "bool"]

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_FIELD_COUNTS: dict[str, int] = {"float": 5, "color": 5, "bool": 3}
_FIELD_LAYOUTS: dict[str, str] = {
    "float": "float NAME MIN MAX DEFAULT",
    "color": "color NAME R G B",
    "bool": "bool NAME DEFAULT",
}
_SECTIONS = ("parameters", "shader")


@dataclass(frozen=True)
class ShaderParam:
    """One parameter of a ``.brdf`` file, seen by the shader as a uniform of the same name.

    ``lo``/``hi`` bound a float; a color's components and a bool lie in [0, 1]. ``default`` is a float
    (a bool's is 0.0 or 1.0) or, for a color, an (r, g, b) tuple.
    """

    name: str
    kind: ParamKind
    lo: float
    hi: float
    default: float | tuple[float, float, float]

    @property
    def slot_count(self) -> int:
        """How many doubles of the compiled kernel's parameter vector this parameter takes."""
        return 3 if self.kind == "color" else 1


@dataclass(frozen=True)
class BrdfFile:
    """A parsed ``.brdf`` file. ``shader_line`` is the 1-based line of the file holding the shader's first line,
    so shader line ``k`` is file line ``shader_line + k - 1``."""

    params: tuple[ShaderParam, ...]
    shader: str
    shader_line: int
    path: str

    def default_parameters(self) -> np.ndarray:
        """The parameter vector ``(k,) float64`` of the defaults, in the layout the compiled kernel reads."""
        values: list[float] = []
        for param in self.params:
            values.extend(param.default if isinstance(param.default, tuple) else (param.default,))
        return np.array(values, dtype=np.float64)


def read_brdf_file(path: str | Path) -> BrdfFile:
    """Read and parse a ``.brdf`` file (see the module docstring for the format).

    Raises
    ------
    FileFormatError
        The file cannot be read.
    ShaderError
        The header or the parameter section is malformed, or the shader block is missing.
    """
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError as error:
        raise FileFormatError(f"{path}: cannot read the file: {error.strerror or error}") from error
    return parse_brdf_text(text, str(path))


def parse_brdf_text(text: str, filename: str = "<text>") -> BrdfFile:
    """Parse the text of a ``.brdf`` file; ``filename`` names it in error messages. The GLSL is not checked
    here (:func:`core.glsl.compile_brdf` does that)."""
    lines = text.splitlines()
    header_seen = False
    section: str | None = None
    section_start = 0
    seen_sections: dict[str, int] = {}
    params: list[ShaderParam] = []
    param_lines: dict[str, int] = {}
    shader_lines: list[str] = []
    shader_line = 0

    def fail(line: int, message: str, column: int = 1) -> ShaderError:
        return ShaderError(filename, line, column, message)

    for number, raw in enumerate(lines, start=1):
        stripped = raw.strip()
        if section == "shader":
            if stripped.startswith("::end"):
                _check_end(stripped, "shader", number, fail)
                section = None
            else:
                shader_lines.append(raw)
            continue
        if not stripped or stripped.startswith("#"):
            continue
        if not header_seen:
            if stripped != "analytic":
                raise fail(
                    number, f"expected the header 'analytic' (an analytic BRDF file), found '{stripped}'"
                )
            header_seen = True
            continue
        if stripped.startswith("::begin"):
            if section is not None:
                raise fail(number, f"'{stripped}' inside the {section} section (missing '::end {section}')")
            name = stripped[len("::begin") :].strip()
            if name not in _SECTIONS:
                raise fail(number, f"unknown section '{name}': expected 'parameters' or 'shader'")
            if name in seen_sections:
                raise fail(
                    number, f"a second {name} section (the first begins on line {seen_sections[name]})"
                )
            seen_sections[name] = number
            section, section_start = name, number
            if name == "shader":
                shader_line = number + 1
            continue
        if stripped.startswith("::end"):
            if section is None:
                raise fail(number, f"'{stripped}' without a matching '::begin'")
            _check_end(stripped, section, number, fail)
            section = None
            continue
        if section == "parameters":
            param = _parse_param_line(raw, number, fail)
            if param.name in param_lines:
                raise fail(
                    number,
                    f"parameter '{param.name}' is declared twice (first on line {param_lines[param.name]})",
                    _column_of_field(raw, 1),
                )
            param_lines[param.name] = number
            params.append(param)
            continue
        raise fail(number, f"unexpected text outside the parameters and shader sections: '{stripped}'")

    last_line = max(len(lines), 1)
    if not header_seen:
        raise fail(1, "empty file: expected the header 'analytic'")
    if section is not None:
        raise fail(last_line, f"the {section} section begun on line {section_start} has no '::end {section}'")
    if "shader" not in seen_sections:
        raise fail(last_line, "no shader: expected a '::begin shader' ... '::end shader' section")
    return BrdfFile(
        params=tuple(params), shader="\n".join(shader_lines), shader_line=shader_line, path=filename
    )


def _check_end(stripped: str, section: str, number: int, fail) -> None:
    name = stripped[len("::end") :].strip()
    if name != section:
        raise fail(number, f"'{stripped}' closes the {section} section: expected '::end {section}'")


def _column_of_field(raw: str, index: int) -> int:
    """1-based column where the whitespace-separated field ``index`` of ``raw`` starts."""
    fields = list(re.finditer(r"\S+", raw))
    return fields[index].start() + 1 if index < len(fields) else len(raw) + 1


def _parse_param_line(raw: str, number: int, fail) -> ShaderParam:
    content = raw.split("#", 1)[0]
    fields = content.split()
    kind = fields[0]
    if kind not in _FIELD_COUNTS:
        raise fail(number, f"unknown parameter type '{kind}': expected float, color or bool")
    if len(fields) != _FIELD_COUNTS[kind]:
        raise fail(
            number,
            f"a {kind} parameter needs {_FIELD_COUNTS[kind]} fields ('{_FIELD_LAYOUTS[kind]}'), found {len(fields)}",
        )
    name = fields[1]
    if not _IDENTIFIER.match(name):
        raise fail(number, f"parameter name '{name}' is not a GLSL identifier", _column_of_field(raw, 1))
    problem = reserved_name_problem(name)
    if problem is not None:
        raise fail(number, f"parameter name {problem}", _column_of_field(raw, 1))

    numbers: list[float] = []
    for index in range(2, len(fields)):
        try:
            value = float(fields[index])
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise fail(number, f"'{fields[index]}' is not a finite number", _column_of_field(raw, index))
        numbers.append(value)

    if kind == "float":
        lo, hi, default = numbers
        if lo > hi:
            raise fail(
                number,
                f"parameter '{name}': MIN {fields[2]} is greater than MAX {fields[3]}",
                _column_of_field(raw, 2),
            )
        if not lo <= default <= hi:
            raise fail(
                number,
                f"parameter '{name}': default {fields[4]} is outside [{fields[2]}, {fields[3]}]",
                _column_of_field(raw, 4),
            )
        return ShaderParam(name, "float", lo, hi, default)
    if kind == "color":
        for index, value in enumerate(numbers, start=2):
            if not 0.0 <= value <= 1.0:
                raise fail(
                    number,
                    f"color '{name}': component {fields[index]} is outside [0, 1]",
                    _column_of_field(raw, index),
                )
        return ShaderParam(name, "color", 0.0, 1.0, (numbers[0], numbers[1], numbers[2]))
    (default,) = numbers
    if default not in (0.0, 1.0):
        raise fail(
            number, f"bool '{name}': default must be 0 or 1, found {fields[2]}", _column_of_field(raw, 2)
        )
    return ShaderParam(name, "bool", 0.0, 1.0, default)
