"""Energy conservation: every model declaring ENERGY_CONSERVING has directional albedo <= 1 (plus the
quadrature's stated error, see core.analysis) at theta in {0, 30, 60, 80, 89} degrees, for its defaults and
three parameter settings drawn inside the bounds (log-uniform where declared; fixed seed)."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from core.analysis import albedo
from core.brdf import Model, all_models

CONSERVING = [m for m in all_models() if m.energy_conserving]
THETAS_DEG = (0.0, 30.0, 60.0, 80.0, 89.0)


def _draw(model: Model, rng: np.random.Generator) -> dict:
    values: dict = {}
    for p in model.params:
        if p.kind == "bool":
            values[p.name] = float(rng.integers(0, 2))
            continue
        if p.log and p.lo > 0:
            one = lambda: float(np.exp(rng.uniform(np.log(p.lo), np.log(p.hi))))  # noqa: B023
        else:
            one = lambda: float(rng.uniform(p.lo, p.hi))  # noqa: B023
        values[p.name] = (one(), one(), one()) if p.kind == "color" else one()
    return values


@pytest.mark.parametrize("model", CONSERVING, ids=[m.name for m in CONSERVING])
def test_albedo_at_most_one(model):
    rng = np.random.default_rng(zlib.crc32(model.name.encode()))  # fixed, but different per model
    settings = [model.defaults(), *(_draw(model, rng) for _ in range(3))]
    for values in settings:
        brdf = model.bind(values)
        for theta in THETAS_DEG:
            r = albedo(brdf, theta)
            value, error = np.array(r.value), np.array(r.error)
            assert np.all(np.isfinite(value)) and np.all(value >= -error)
            assert np.all(value <= 1.0 + error), (
                f"{model.name} {values} theta={theta}: albedo {value} ± {error}"
            )
