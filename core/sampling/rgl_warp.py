"""``rgl_warp``: the sampler of Dupuy & Jakob 2018 — a luminance warp over the visible-normal
parameterization — as a baseline for any BRDF, the field's standard for measured data.

For an RGL ``.bsdf`` material it uses the file's own tables (exactly what Mitsuba 3 and pbrt-v4 sample). For
any other BRDF it first builds them as the RGL acquisition would, with ``f`` in place of the measurement
(:func:`core.rgl.export.tabulate`: NDF from retro-reflection, VNDF per conditioning direction, luminance of
``f cos / pdf_vndf`` on the sample square). Draws and densities are :func:`core.rgl.lookup.sample_rgl` and
:func:`core.rgl.lookup.pdf_rgl` over those tables: the density is exact (it is the composition of two
continuous marginal warps of bilinear interpolants and the reflection's Jacobian), whatever the tables'
resolution; only how closely it follows ``f cos`` depends on it. ``f`` comes from the BRDF itself, not from
the tables. A draw whose half vector faces away from ``wo`` (the VNDF interpolant's spill over the visibility
boundary) reflects ``wo`` below the horizon, with its density: the density integrates to 1 over the sphere.

Options ``n_theta`` (conditioning polar angles), ``vndf`` and ``samples`` (grid sides) set the tables of an
analytic BRDF; a ``.bsdf`` material ignores them.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from core.brdf import BRDF
from core.jit import kernel
from core.kernels import DirectionSamples
from core.rgl.lookup import pdf_rgl, sample_rgl
from core.sampling.base import Sampler, SamplerOption, register_sampler


@kernel
def _sample_rows(wo, p, u, wi, pdf):
    for i in range(wo.shape[0]):
        w = (wo[i, 0], wo[i, 1], wo[i, 2])
        x, y, z, q = sample_rgl(w, p, u[i, 0], u[i, 1], u[i, 2])
        wi[i, 0] = x
        wi[i, 1] = y
        wi[i, 2] = z
        # The density by pdf's own arithmetic (from wi, as MIS will recompute it): equal to q up to the
        # rounding of the round trip m -> wi -> m, but then equal to pdf(wo, wi) to the last bit.
        pdf[i] = pdf_rgl(w, (x, y, z), p) if q > 0.0 else 0.0


@kernel
def _pdf_rows(wo, wi, p, out):
    for i in range(wo.shape[0]):
        out[i] = pdf_rgl((wo[i, 0], wo[i, 1], wo[i, 2]), (wi[i, 0], wi[i, 1], wi[i, 2]), p)


class RGLWarpSampler(Sampler):
    """The luminance warp over the VNDF parameterization (see the module docstring)."""

    name = "rgl_warp"

    def __init__(self, brdf: BRDF, n_theta: int = 16, vndf: int = 64, samples: int = 32):
        super().__init__(brdf)
        from core.rgl.export import ExportOptions, tabulate
        from core.rgl.material import RGLBRDF, kernel_vector

        t0 = time.perf_counter()
        if isinstance(brdf, RGLBRDF):
            self.tables = brdf.params
        else:
            options = ExportOptions(n_theta_i=n_theta, vndf=(vndf, vndf), samples=(samples, samples))
            self.tables = kernel_vector(tabulate(brdf, options))
        self.build_seconds = time.perf_counter() - t0

    def _sample_directions(self, wo: np.ndarray, u: np.ndarray) -> DirectionSamples:
        wi = np.empty_like(wo)
        pdf = np.empty(wo.shape[0])
        _sample_rows(wo, self.tables, u, wi, pdf)
        return DirectionSamples(wi, pdf)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        out = np.empty(wo.shape[0])
        _pdf_rows(wo, wi, self.tables, out)
        return out

    def info(self) -> dict[str, Any]:
        return {
            "sampler": self.name,
            "memory_bytes": int(self.tables.nbytes),
            "build_seconds": self.build_seconds,
        }


register_sampler(
    "rgl_warp",
    lambda brdf, **o: RGLWarpSampler(brdf, **o),
    (
        SamplerOption(
            "n_theta", "int", 2, 90, doc="conditioning polar angles of the tables (analytic BRDFs)"
        ),
        SamplerOption("vndf", "int", 4, 512, doc="side of the VNDF grid (analytic BRDFs)"),
        SamplerOption("samples", "int", 4, 256, doc="side of the sample square's grid (analytic BRDFs)"),
    ),
)
