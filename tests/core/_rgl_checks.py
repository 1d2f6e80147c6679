"""Checks shared by tests/core/test_rgl.py, test_rgl_warp.py and test_rgl_spectral.py: the reader's one clear
error per broken file, and the chi-square check of the RGL luminance warp (``rgl_warp``, a ``.bsdf``
material's ``analytic`` sampler).

Every draw is made (a half vector facing away from ``wo`` reflects it below the horizon, with its density), so
the density integrates to 1 over the sphere: the share of draws not made (pdf 0) is checked against the
quadrature's ``1 - integral``, then chi-square (core.chi2, Sidak-corrected 1 % over ``n_tests``) of the draws
against the density over the upper hemisphere.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.chi2 import chi2_test, integrate_pdf
from core.errors import FileFormatError
from core.rgl.material import read_bsdf
from core.sampling.base import SampleBatch, Sampler

QUADRATURE_TOL = 3e-4
"""How far the quadrature of the whole density may be off: bilinear VNDF tables fall off linearly in ``u``
at the pole where the true density falls off as ``u^3`` (the ``u -> m`` Jacobian), so the density of ``wi``
has an integrable ``1 / theta`` peak at the mirror direction that the self-refining rule over-integrates
(Ward at 75 degrees: 1.000159 at 64^2, 128^2 and 256^2 cells alike; a 4e6-sample Monte Carlo estimate gives
1.0001 +- 0.0014)."""


def assert_warp_chi2(
    sampler: Sampler, wo: np.ndarray, n_tests: int, seed: int, n: int = 1_000_000
) -> SampleBatch:
    """Draw ``n`` directions (and 5 % more for the ones not made) for ``wo`` and check them; returns the
    draws."""

    def pdf(wi: np.ndarray) -> np.ndarray:
        return sampler.pdf(np.broadcast_to(wo, wi.shape), wi)

    integral = integrate_pdf(pdf, cell_tol=1e-9)
    drawn = sampler.sample(wo, n + n // 20, seed=seed)
    ok = drawn.pdf > 0.0
    lost = 1.0 - ok.mean()
    assert lost < 1e-3
    assert abs(lost - (1.0 - integral)) < QUADRATURE_TOL, (lost, integral)
    accepted = drawn.wi[ok][:n]
    assert len(accepted) == n
    result = chi2_test(
        lambda k, seed: accepted[:k], lambda wi: pdf(wi) / integral, n_samples=n, n_tests=n_tests
    )
    assert result.passed, result.reason
    return drawn


def assert_clear_errors(variants: dict[str, tuple[Path, str]]) -> None:
    """Each broken file (name -> path, a phrase its error must hold) gives one :class:`FileFormatError`
    naming the file."""
    for name, (path, phrase) in variants.items():
        with pytest.raises(FileFormatError) as exc:
            read_bsdf(path)
        assert phrase in str(exc.value), (name, str(exc.value))
        assert str(path) in str(exc.value), name
