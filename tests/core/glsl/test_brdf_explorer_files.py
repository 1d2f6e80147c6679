"""BRDF Explorer's own analytic files (github wdas/brdf, src/brdfs), when a copy is on this machine: every one
compiles (showAngles and showVectors too: refusing them is another layer's business) and gives finite values
somewhere. The files are not ours and are not in the repository: set BRDF_EXPLORER_DIR to their folder."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from core.glsl import compile_brdf, read_brdf_file
from tests.core.glsl._shaders import FIXTURES, grid_pairs

FOLDER = Path(os.environ.get("BRDF_EXPLORER_DIR", "/tmp/wdas/src/brdfs"))
FILES = sorted(FOLDER.glob("*.brdf")) if FOLDER.is_dir() else []
needs_files = pytest.mark.skipif(
    not FILES, reason=f"no BRDF Explorer .brdf files in {FOLDER} (set BRDF_EXPLORER_DIR)"
)

ANISOTROPIC = {"ashikhman_shirley", "dAniso", "disney", "showAngles", "showVectors", "ward"}


@needs_files
@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_compiles_and_evaluates(path):
    brdf = compile_brdf(read_brdf_file(path))
    wi, wo = grid_pairs()
    values = brdf.evaluate(wi[::7], wo[::7])
    assert values.shape == (len(wi[::7]), 3) and values.dtype == np.float64
    assert np.isfinite(values).any()
    assert brdf.uses_tangents is (path.stem in ANISOTROPIC)
    assert brdf.reads_uniforms <= {p.name for p in brdf.source.params}


@needs_files
def test_principled_fixture_is_disneys_brdf_with_a_linear_base_color():
    """Our principled.brdf against BRDF Explorer's disney.brdf, whose baseColor is gamma 2.2 encoded."""
    ours = compile_brdf(read_brdf_file(FIXTURES / "principled.brdf"))
    disney = compile_brdf(read_brdf_file(FOLDER / "disney.brdf"))
    rng = np.random.default_rng(7)
    wi, wo = grid_pairs()
    for _ in range(4):
        params = rng.uniform(0.0, 1.0, 13)
        encoded = params.copy()
        encoded[:3] = params[:3] ** (1 / 2.2)
        np.testing.assert_allclose(
            ours.evaluate(wi, wo, params), disney.evaluate(wi, wo, encoded), rtol=1e-9, equal_nan=True
        )
