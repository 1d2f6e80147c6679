"""Shared fixtures: a seeded generator and the dense direction sets the physics tests use."""

from __future__ import annotations

import numpy as np
import pytest

from core.geometry import spherical_to_dir

# Polar angles (degrees) that include normal incidence, grazing angles and exactly 90 degrees.
THETAS_DEG = np.array([0.0, 0.5, 5.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.9, 90.0])
PHIS_DEG = np.array([0.0, 37.0, 90.0, 135.0, 180.0, 222.0, 270.0, 333.0])


def direction_grid() -> np.ndarray:
    """Upper-hemisphere unit vectors ``(n, 3)`` over ``THETAS_DEG x PHIS_DEG`` (exact zeros at 90 degrees)."""
    t, p = np.meshgrid(np.radians(THETAS_DEG), np.radians(PHIS_DEG), indexing="ij")
    w = spherical_to_dir(t.ravel(), p.ravel())
    w[THETAS_DEG.repeat(len(PHIS_DEG)) == 90.0, 2] = 0.0
    return w


def all_pairs(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every ordered pair of rows of ``w``: ``(wo, wi)`` each ``(n*n, 3)``."""
    n = len(w)
    return np.repeat(w, n, axis=0), np.tile(w, (n, 1))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20080627)  # the seed's defence date
