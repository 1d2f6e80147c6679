"""The GLSL types a shader may use: float, int, bool, vec2, vec3, vec4 (and void for functions)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Base = Literal["float", "int", "bool", "void"]


@dataclass(frozen=True)
class GlslType:
    """A scalar (``size`` 1), a float vector (``size`` 2-4) or void (``size`` 0). Code generation keeps one
    scalar per component (a vec3 is three doubles)."""

    name: str
    base: Base
    size: int

    @property
    def is_scalar(self) -> bool:
        return self.size == 1

    @property
    def is_vector(self) -> bool:
        return self.size > 1

    @property
    def is_numeric(self) -> bool:
        return self.base in ("float", "int")

    def __str__(self) -> str:
        return self.name


VOID = GlslType("void", "void", 0)
FLOAT = GlslType("float", "float", 1)
INT = GlslType("int", "int", 1)
BOOL = GlslType("bool", "bool", 1)
VEC2 = GlslType("vec2", "float", 2)
VEC3 = GlslType("vec3", "float", 3)
VEC4 = GlslType("vec4", "float", 4)

TYPES_BY_NAME: dict[str, GlslType] = {t.name: t for t in (VOID, FLOAT, INT, BOOL, VEC2, VEC3, VEC4)}
FLOAT_TYPES: tuple[GlslType, ...] = (FLOAT, VEC2, VEC3, VEC4)  # GLSL's "genType"


def float_type(size: int) -> GlslType:
    """float for ``size`` 1, else the float vector of that size."""
    return FLOAT_TYPES[size - 1]


def implicitly_converts(source: GlslType, target: GlslType) -> bool:
    """GLSL 1.20's implicit conversions: only int to float (there are no integer vectors here)."""
    return source == target or (source == INT and target == FLOAT)
