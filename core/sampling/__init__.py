"""Importance sampling of BRDFs: one interface (:mod:`core.sampling.base`), one module or subpackage per
family of strategies.

==================  ==========================================================================================
``base``            :class:`Sampler`, :class:`SampleBatch` and the registry of strategies by name
``basic``           ``uniform``, ``cosine`` and ``analytic`` (the model's own sampler)
``tabulated``       ``uniform_cdf`` and ``compress_cdf`` (Matusik et al. 2003, Lawrence et al. 2005)
``factored``        ``factored`` (Lawrence, Rusinkiewicz & Ramamoorthi 2004)
``rgl_warp``        ``rgl_warp`` (Dupuy & Jakob 2018: luminance warp over the VNDF parameterization)
``ris``             resampled importance sampling of BRDF x light on top of any strategy
``distributions``   the toolkit the strategies share: piecewise-constant 1-D/2-D distributions, warps
==================  ==========================================================================================

Strategy modules register themselves when imported; :func:`make_sampler` imports them all on first use.
"""

from core.sampling.base import (
    SampleBatch,
    Sampler,
    applicable_samplers,
    check_direction,
    make_sampler,
    register_sampler,
    sampler_names,
)

__all__ = [
    "SampleBatch",
    "Sampler",
    "applicable_samplers",
    "check_direction",
    "make_sampler",
    "register_sampler",
    "sampler_names",
]
