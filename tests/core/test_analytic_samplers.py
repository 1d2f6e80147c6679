"""Every model's analytic sampler (``Model.sample`` / ``Model.pdf``), checked against its own declaration.

For each model that has one, at its default parameters and at the defaults with every colour set to a
distinct RGB value (so a mixture whose default weight is 0, e.g. Lewis' ``kd = 0``, is exercised too):

- the density returned by ``sample`` equals ``pdf`` at the returned direction (1e-9 relative), is finite
  and non-negative, and the directions are unit vectors; over outgoing directions up to and at 90 degrees;
- ``pdf`` integrates to 1 over the sphere (Gauss-Legendre x trapezoid quadrature);
- the Monte Carlo estimate of the directional albedo, the mean of ``f cos(theta_i) / pdf`` over 2e5
  samples (fixed seed), matches the albedo by dense quadrature within 5 standard errors plus twice the
  quadrature's own error estimate (the difference between two resolutions). Under the central limit theorem
  one comparison fails by chance with probability 5.7e-7; with a few hundred comparisons (models x settings x
  3 directions x 3 channels) the suite fails by chance with probability below 1e-3.

The two quadrature checks (the costly ones) run at the defaults for outgoing directions at 0, 45 and 80
degrees, and for the RGB setting at 45 degrees (its colours change only the mixture weights, which the 45
degree direction exercises); the RGB setting at 0 and 80 degrees runs with ``-m slow``.
"""

from __future__ import annotations

import numpy as np
import pytest

from core.brdf import all_models
from tests.core.models._checks import (
    assert_albedo_estimate_matches,
    assert_pdf_integrates_to_one,
    assert_sample_matches_pdf,
)

MODELS = [m for m in all_models() if m.sample is not None]
IDS = [m.name for m in MODELS]
DISTINCT_RGB = (0.55, 0.3, 0.12)


def _settings(model):
    """Defaults, and defaults with every colour parameter set to a distinct RGB (clipped to its bounds)."""
    coloured = {}
    for p in model.params:
        if p.kind == "color":
            coloured[p.name] = tuple(float(np.clip(c, p.lo, p.hi)) for c in DISTINCT_RGB)
    out = [("defaults", model.bind())]
    if coloured:
        out.append(("rgb", model.bind(coloured)))
    return out


def _cases():
    for m in MODELS:
        for label, brdf in _settings(m):
            yield pytest.param(brdf, id=f"{m.name}-{label}")


CASES = list(_cases())
ALL_THETAS = (0.0, 45.0, 80.0)
FAST_THETAS_RGB = (45.0,)


def _quadrature_cases(slow: bool):
    """``(brdf, thetas)``: every setting in the fast run (RGB at one direction), the rest in the slow run."""
    for case in CASES:
        (brdf,) = case.values
        is_rgb = case.id.endswith("-rgb")
        if slow:
            thetas = tuple(t for t in ALL_THETAS if t not in FAST_THETAS_RGB) if is_rgb else ()
        else:
            thetas = FAST_THETAS_RGB if is_rgb else ALL_THETAS
        if thetas:
            yield pytest.param(brdf, thetas, id=case.id)


FAST_QUADRATURE_CASES = list(_quadrature_cases(slow=False))
SLOW_QUADRATURE_CASES = list(_quadrature_cases(slow=True))


@pytest.mark.parametrize("brdf", CASES)
def test_sample_returns_its_pdf_and_unit_vectors(brdf):
    assert_sample_matches_pdf(brdf)


@pytest.mark.parametrize(("brdf", "thetas"), FAST_QUADRATURE_CASES)
def test_pdf_integrates_to_one_over_the_sphere(brdf, thetas):
    assert_pdf_integrates_to_one(brdf, thetas)


@pytest.mark.parametrize(("brdf", "thetas"), FAST_QUADRATURE_CASES)
def test_monte_carlo_albedo_matches_quadrature(brdf, thetas):
    assert_albedo_estimate_matches(brdf, thetas)


@pytest.mark.slow
@pytest.mark.parametrize(("brdf", "thetas"), SLOW_QUADRATURE_CASES)
def test_pdf_integrates_to_one_over_the_sphere_all_directions(brdf, thetas):
    assert_pdf_integrates_to_one(brdf, thetas)


@pytest.mark.slow
@pytest.mark.parametrize(("brdf", "thetas"), SLOW_QUADRATURE_CASES)
def test_monte_carlo_albedo_matches_quadrature_all_directions(brdf, thetas):
    assert_albedo_estimate_matches(brdf, thetas)
