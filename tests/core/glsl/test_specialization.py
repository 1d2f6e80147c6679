"""A shader compiled with its parameters as constants computes what the general code computes, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ParameterError
from core.glsl import compile_brdf, read_brdf_file
from tests.core.glsl._shaders import GOOD_FIXTURES, grid_pairs


def _random_settings(brdf, rng: np.random.Generator, count: int) -> list[np.ndarray]:
    """The defaults, then ``count`` settings drawn within each parameter's range (bools 0 or 1)."""
    settings = [brdf.default_parameters()]
    for _ in range(count):
        values: list[float] = []
        for param in brdf.params:
            if param.kind == "bool":
                values.append(float(rng.integers(0, 2)))
            elif param.kind == "color":
                values.extend(rng.uniform(0.0, 1.0, 3))
            else:
                values.append(rng.uniform(param.lo, param.hi))
        settings.append(np.array(values))
    return settings


@pytest.mark.parametrize("path", GOOD_FIXTURES, ids=lambda p: p.stem)
def test_a_specialization_gives_the_general_codes_values(path):
    """Every fixture at its defaults and at 3 random settings, on the direction grid (normal incidence
    to 90 degrees): the same float64 values, NaN where the general code gives NaN. LLVM folds
    the parameters' expressions with IEEE arithmetic and the C library the general code calls."""
    brdf = read_brdf_file(path)
    general = compile_brdf(brdf)
    L, V = grid_pairs()
    for values in _random_settings(brdf, np.random.default_rng(7), 3):
        special = compile_brdf(brdf, values)
        expected = general.evaluate(L, V, values)
        np.testing.assert_array_equal(special.evaluate(L, V, values), expected)
        # the constants are the specialization's: the vector it is handed is not read
        np.testing.assert_array_equal(special.evaluate(L, V, np.full_like(values, np.nan)), expected)


def test_a_specialization_needs_the_files_number_of_values():
    brdf = read_brdf_file(GOOD_FIXTURES[0])
    n = len(brdf.default_parameters())
    with pytest.raises(ParameterError, match=f"expected {n} parameter values, got {n + 1}"):
        compile_brdf(brdf, np.zeros(n + 1))
