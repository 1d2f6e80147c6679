"""The basic strategies: ``uniform`` and ``cosine`` over the upper hemisphere, and ``analytic``, the model's own
importance sampler (lobe mixtures for diffuse + specular models, reached through :mod:`core.dispatch`).

The uniform and cosine loops know no model: they compile once for every material. ``f`` is evaluated by the
base class for the directions drawn.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from core.brdf import BRDF
from core.errors import UnknownNameError
from core.jit import kernel
from core.kernels import DirectionSamples, pdf_batch, sample_batch
from core.models.lobes import cosine_hemisphere, cosine_hemisphere_pdf, uniform_hemisphere
from core.sampling.base import Sampler, register_sampler

INV_TWO_PI = 0.15915494309189535


@njit(inline="always", nogil=True, cache=True)
def _store(wi_out, pdf_out, i, x, y, z, pdf):
    """Row ``i`` of a draw: the direction ``(x, y, z)`` and its density."""
    wi_out[i, 0] = x
    wi_out[i, 1] = y
    wi_out[i, 2] = z
    pdf_out[i] = pdf


@kernel
def sample_uniform_rows(u, wi_out, pdf_out):
    """``wi_out (n, 3)``, ``pdf_out (n,)``: directions uniform over the upper hemisphere from ``u (n, 3)``."""
    for i in range(u.shape[0]):
        x, y, z = uniform_hemisphere(u[i, 0], u[i, 1])
        _store(wi_out, pdf_out, i, x, y, z, INV_TWO_PI)


@kernel
def pdf_uniform_rows(wi, out):
    """``out (n,)``: the uniform hemisphere density at every row of ``wi (n, 3)`` (0 below the horizon; the
    horizon itself, where ``u = 0`` puts a draw, is included)."""
    for i in range(wi.shape[0]):
        out[i] = INV_TWO_PI if wi[i, 2] >= 0.0 else 0.0


@kernel
def sample_cosine_rows(u, wi_out, pdf_out):
    """``wi_out (n, 3)``, ``pdf_out (n,)``: cosine-weighted directions over the upper hemisphere."""
    for i in range(u.shape[0]):
        x, y, z = cosine_hemisphere(u[i, 0], u[i, 1])
        _store(wi_out, pdf_out, i, x, y, z, cosine_hemisphere_pdf(z))


@kernel
def pdf_cosine_rows(wi, out):
    """``out (n,)``: the cosine-weighted density ``cos(theta_i) / pi`` (0 below the horizon)."""
    for i in range(wi.shape[0]):
        out[i] = cosine_hemisphere_pdf(wi[i, 2])


class _WarpSampler(Sampler):
    """A warp of the hemisphere that knows no model: its kernels ``draw_rows(u, wi, pdf)`` and
    ``pdf_rows(wi, out)`` (module functions, compiled once for every material)."""

    draw_rows: Callable[[np.ndarray, np.ndarray, np.ndarray], None]
    density_rows: Callable[[np.ndarray, np.ndarray], None]

    def _directions_into(self, wo: np.ndarray, u: np.ndarray, wi: np.ndarray, pdf: np.ndarray) -> None:
        type(self).draw_rows(np.ascontiguousarray(u), wi, pdf)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        out = np.empty(wi.shape[0])
        type(self).density_rows(wi, out)
        return out


class UniformSampler(_WarpSampler):
    """Uniform over the upper hemisphere: ``pdf = 1 / (2 pi)``."""

    name = "uniform"
    draw_rows = sample_uniform_rows
    density_rows = pdf_uniform_rows


class CosineSampler(_WarpSampler):
    """Cosine-weighted upper hemisphere: ``pdf = cos(theta_i) / pi``."""

    name = "cosine"
    draw_rows = sample_cosine_rows
    density_rows = pdf_cosine_rows


class AnalyticSampler(Sampler):
    """The model's own importance sampler."""

    name = "analytic"

    def __init__(self, brdf: BRDF):
        if brdf.model.sample is None or brdf.model.pdf is None:
            raise UnknownNameError(
                f"model '{brdf.model.name}' has no analytic sampler; use 'adaptive_exact', 'adaptive_warp', 'cosine' or 'uniform'"
            )
        super().__init__(brdf)

    def _sample_directions(self, wo: np.ndarray, u: np.ndarray) -> DirectionSamples:
        return sample_batch(self.brdf.model.id, wo, self.brdf.params, u)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        return pdf_batch(self.brdf.model.id, wo, wi, self.brdf.params)


register_sampler("uniform", UniformSampler)  # no options: make_sampler refuses any
register_sampler("cosine", CosineSampler)
register_sampler("analytic", AnalyticSampler)
