"""Helpers of the core.glsl tests: fixture paths, a .brdf file around a bare shader, the direction grid."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.glsl import CompiledBrdf, compile_brdf, parse_brdf_text
from tests.conftest import all_pairs, direction_grid

FIXTURES = Path(__file__).parent / "fixtures"
GOOD_FIXTURES = sorted(FIXTURES.glob("*.brdf"))
BAD_FIXTURES = sorted((FIXTURES / "bad").glob("*.brdf"))


SHADER_LINE = 3


def brdf_text(shader: str, params: str = "") -> str:
    """A .brdf file holding ``shader`` and the parameter lines ``params``; the shader section comes first so
    that its first line is line ``SHADER_LINE`` of the file whatever the parameters."""
    return (
        f"analytic\n::begin shader\n{shader}\n::end shader\n::begin parameters\n{params}\n::end parameters\n"
    )


def compile_shader(shader: str, params: str = "") -> CompiledBrdf:
    return compile_brdf(parse_brdf_text(brdf_text(shader, params), "test.brdf"))


def shader_value(
    body: str, *, helpers: str = "", params: str = "", values: np.ndarray | None = None
) -> np.ndarray:
    """The vec3 a BRDF whose body is ``body`` returns for L = V = (0, 0, 1)."""
    shader = f"{helpers}\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{{\n{body}\n}}\n"
    compiled = compile_shader(shader, params)
    normal = np.array([[0.0, 0.0, 1.0]])
    return compiled.evaluate(normal, normal, values)[0]


def grid_pairs() -> tuple[np.ndarray, np.ndarray]:
    """Every ordered pair of the shared direction grid (normal incidence to 90 degrees, 89.9 included):
    ``(wi, wo)`` each ``(n, 3)``."""
    wo, wi = all_pairs(direction_grid())
    return wi, wo
