"""The one sampling interface every strategy implements, and the registry of strategies by name.

``sample(wo, n, seed) -> (wi (n, 3), pdf (n,))``
    ``n`` directions for one outgoing direction ``wo (3,)``, with their density per unit solid angle.
``sample_each(wo (n, 3), seed) -> (wi (n, 3), pdf (n,))``
    one direction for each row of ``wo`` (what a wavefront renderer needs).
``pdf(wo, wi) -> (n,)``
    the density per unit solid angle of the samples the strategy makes, at any unit vector ``wi``.
``eval(wo, wi) -> (n, 3)``
    the BRDF being sampled.

All in the local frame (z = normal), reproducible for a given seed. A strategy may return directions
below the horizon (a lobe that spills over); they carry no energy, and ``pdf`` accounts for them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from core.errors import ParameterError, UnknownNameError
from core.kernels import pdf_batch, sample_batch
from core.model import BRDF
from core.models.lobes import cosine_hemisphere, cosine_hemisphere_pdf, uniform_hemisphere

INV_TWO_PI = 0.15915494309189535


def _pairs(wo: np.ndarray, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    wo = np.atleast_2d(np.asarray(wo, dtype=np.float64))
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float64))
    wo, wi = np.broadcast_arrays(wo, wi)
    return np.ascontiguousarray(wo), np.ascontiguousarray(wi)


def check_direction(wo: np.ndarray) -> np.ndarray:
    wo = np.asarray(wo, dtype=np.float64)
    if wo.shape[-1] != 3 or not np.all(np.isfinite(wo)):
        raise ParameterError("a direction must be three finite numbers")
    norm = np.linalg.norm(wo, axis=-1)
    if np.any(np.abs(norm - 1.0) > 1e-6):
        raise ParameterError("a direction must be a unit vector")
    return wo


class Sampler:
    """Base class: subclasses provide ``_sample_rows(wo (n,3), u (n,3))`` and ``_pdf_rows(wo, wi)``, or
    override :meth:`sample_each` and :meth:`pdf` themselves."""

    name = "base"

    def __init__(self, brdf: BRDF):
        self.brdf = brdf

    def sample(self, wo: np.ndarray, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        if int(n) <= 0:
            raise ParameterError(f"the number of samples must be positive, got {n}")
        wo = check_direction(wo).reshape(1, 3)
        return self.sample_each(np.repeat(wo, int(n), axis=0), seed)

    def sample_each(self, wo: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        u = np.random.default_rng(seed).random((wo.shape[0], 3))
        return self._sample_rows(wo, u)

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        wo, wi = _pairs(wo, wi)
        return self._pdf_rows(wo, wi)

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        return self.brdf.eval(wo, wi)

    def info(self) -> dict[str, Any]:
        """Precomputation facts (memory in bytes, build seconds, ...) for reports."""
        return {"sampler": self.name, "memory_bytes": 0, "build_seconds": 0.0}

    def preload(self) -> int:
        """Load precomputed tables a disk cache holds (a render's preparation calls it, so that its timed
        passes do not); returns how many. Samplers without such tables have nothing to load."""
        return 0

    def _sample_rows(self, wo: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        raise NotImplementedError


@njit(nogil=True, cache=True)
def sample_uniform(wo, p, u1, u2, u3):
    x, y, z = uniform_hemisphere(u1, u2)
    return x, y, z, INV_TWO_PI


@njit(nogil=True, cache=True)
def pdf_uniform(wo, wi, p):
    return INV_TWO_PI if wi[2] > 0.0 else 0.0


@njit(nogil=True, cache=True)
def sample_cosine(wo, p, u1, u2, u3):
    x, y, z = cosine_hemisphere(u1, u2)
    return x, y, z, cosine_hemisphere_pdf(z)


@njit(nogil=True, cache=True)
def pdf_cosine(wo, wi, p):
    return cosine_hemisphere_pdf(wi[2])


class _KernelSampler(Sampler):
    """A sampler given by a pair of kernels with the model-kernel signatures."""

    sample_kernel: Any = None
    pdf_kernel: Any = None

    def _kernels(self) -> tuple[Any, Any]:
        return self.sample_kernel, self.pdf_kernel

    def _sample_rows(self, wo: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s, _ = self._kernels()
        return sample_batch(s, wo, self.brdf.params, u)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        _, p = self._kernels()
        return pdf_batch(p, wo, wi, self.brdf.params)


class UniformSampler(_KernelSampler):
    """Uniform over the upper hemisphere: ``pdf = 1 / (2 pi)``."""

    name = "uniform"
    sample_kernel = sample_uniform
    pdf_kernel = pdf_uniform


class CosineSampler(_KernelSampler):
    """Cosine-weighted upper hemisphere: ``pdf = cos(theta_i) / pi``."""

    name = "cosine"
    sample_kernel = sample_cosine
    pdf_kernel = pdf_cosine


class AnalyticSampler(_KernelSampler):
    """The model's own importance sampler (lobe mixtures for diffuse + specular models)."""

    name = "analytic"

    def __init__(self, brdf: BRDF):
        if brdf.model.sample is None or brdf.model.pdf is None:
            raise UnknownNameError(
                f"model '{brdf.model.name}' has no analytic sampler; use 'adaptive', 'cosine' or 'uniform'"
            )
        super().__init__(brdf)

    def _kernels(self) -> tuple[Any, Any]:
        return self.brdf.model.sample, self.brdf.model.pdf


SamplerFactory = Callable[..., Sampler]
_SAMPLERS: dict[str, SamplerFactory] = {}


def register_sampler(name: str, factory: SamplerFactory) -> None:
    _SAMPLERS[name] = factory


register_sampler("uniform", lambda brdf, **_: UniformSampler(brdf))
register_sampler("cosine", lambda brdf, **_: CosineSampler(brdf))
register_sampler("analytic", lambda brdf, **_: AnalyticSampler(brdf))


def sampler_names() -> list[str]:
    _load_samplers()
    return list(_SAMPLERS)


def make_sampler(name: str, brdf: BRDF, **options: Any) -> Sampler:
    """A sampler by name (``uniform``, ``cosine``, ``analytic``, ``adaptive``, ...) for ``brdf``."""
    _load_samplers()
    try:
        factory = _SAMPLERS[name]
    except KeyError:
        raise UnknownNameError(f"unknown sampler '{name}'; known samplers: {', '.join(_SAMPLERS)}") from None
    return factory(brdf, **options)


def applicable_samplers(brdf: BRDF) -> list[str]:
    names = sampler_names()
    if brdf.model.sample is None:
        names = [n for n in names if n != "analytic"]
    return names


def _load_samplers() -> None:
    """Import the modules that register further strategies (kept lazy: they are heavier)."""
    from core.samplers import load_all

    load_all()
