"""What every stage shares: the block size of their scratch rows, the roles of a vertex's random numbers, MIS
weights, the radiance rows' accumulation and the tangent frame of a normal."""

from __future__ import annotations

import math

from numba import njit

NO_MATERIAL = -1

BLOCK = 64
"""Vertices whose random numbers a stage hashes ahead of their loop (:func:`renderer.stages.bsdf.bsdf_stage`),
and whose frames :func:`renderer.stages.surface.surface_stage` keeps for their light samples: the rows of the
wavefront's scratch arrays (:class:`renderer.stages.records.Scratch`)."""

# roles of a path vertex's random numbers (the key of a vertex is key(path key, bounce))
U_RR = 4
U_LOBE = 5
# pairs of low-discrepancy dimensions: the pixel, the light point at bounce k and the BRDF sample at bounce k
# get their own scrambles
PAIR_PIXEL = 0
PAIR_LIGHT = 1
PAIR_BSDF = 1 << 16
SOBOL_DEPTH = 2
"""Vertices below this bounce draw their light points and their BRDF samples' two warp dimensions from Sobol
pairs; deeper ones from independent uniforms (stratification pays where a pixel's variance comes from: the
first bounces). Every strategy gets the same BRDF points, those with tables too (``Sampler.sample_into``'s
``points``): a renderer built to compare BRDF samplers must not place one strategy's samples better than
another's; how much of the stratification a strategy's warp keeps is its own (a rejection trial keeps it
only when accepted at once)."""


@njit(inline="always", nogil=True, cache=True)
def mis_weight(a, b, power):
    """Weight of a strategy of density ``a`` against one of density ``b`` (power or balance heuristic)."""
    if power:
        s = a * a + b * b
        return a * a / s if s > 0.0 else 0.0
    s = a + b
    return a / s if s > 0.0 else 0.0


@njit(inline="always", nogil=True, cache=True)
def rescale(u, lo, hi):
    """Where ``u`` lies in ``[lo, hi)``, as a number of ``[0, 1)``: uniform there when ``u`` is uniform and
    fell in that interval, and as stratified as ``u`` was (one number makes a discrete choice, then a
    continuous one)."""
    if not hi > lo:
        return 0.5
    return min(max((u - lo) / (hi - lo), 0.0), 0.9999999999999999)


@njit(inline="always", nogil=True, cache=True)
def add_radiance(radiance, p, r, g, b):
    """``radiance[p] += (r, g, b)`` for a finite value; returns 1 for a value that was not finite."""
    if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
        return 1
    radiance[p, 0] += r
    radiance[p, 1] += g
    radiance[p, 2] += b
    return 0


@njit(inline="always", nogil=True, cache=True)
def tangents(sx, sy, sz):
    """Tangent and bitangent of the unit normal ``s`` (Duff et al. 2017): a function of ``s`` alone, so a
    stage that needs the frame recomputes it from the stored normal (the same values bit for bit) instead of
    reading six more numbers a vertex."""
    sign = 1.0 if sz >= 0.0 else -1.0
    q = -1.0 / (sign + sz)
    c = sx * sy * q
    return 1.0 + sign * sx * sx * q, sign * c, -sign * sx, c, sign + sy * sy * q, -sy
