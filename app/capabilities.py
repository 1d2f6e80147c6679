"""What the app can use from the library, found at run time: measured BRDFs, the albedo quadrature, the
adaptive sampler, the renderer. Parts of the project land at different times; a panel whose part is
missing says so (:class:`Unavailable`) instead of faking it. One place for the adapters keeps the views
free of import guessing. (The adaptive sampler is always in the build: its adapter only picks the mode.)"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from core.errors import BrdfStudioError, ParameterError
from core.model import BRDF

if TYPE_CHECKING:
    from core.sampling.adaptive import AdaptiveSampler

MEASURED_MODEL = "merl"
"""The ``model`` name of a measured material in the document."""


class Unavailable(BrdfStudioError):
    """A feature whose library part is not in this build yet."""


def _module(name: str) -> Any | None:
    try:
        return importlib.import_module(name)
    except ImportError:
        return None


# ---- measured BRDFs ---------------------------------------------------------------------------------
def load_measured(path: str | Path) -> BRDF:
    """A BRDF from a MERL ``.binary`` file (``FileFormatError`` with the reason when the file is bad)."""
    merl = _module("core.merl")
    if merl is None or not hasattr(merl, "measured_brdf"):
        raise Unavailable("measured BRDFs (MERL files) are not available yet in this build")
    return merl.measured_brdf(str(path))


# ---- analysis -----------------------------------------------------------------------------------------
ALBEDO_RTOL = 1e-3
"""Relative accuracy asked of the albedo quadrature in the UI (the library's default is stricter and slower)."""


def albedo_available() -> bool:
    mod = _module("core.analysis")
    return mod is not None and hasattr(mod, "albedo_table")


def directional_albedo(brdf: BRDF, thetas_deg: Sequence[float], phi_deg: float = 0.0) -> np.ndarray:
    """Directional albedo ``(n, 3)`` at the given polar angles (degrees), from ``core.analysis``."""
    mod = _module("core.analysis")
    if mod is None or not hasattr(mod, "albedo_table"):
        raise Unavailable("the albedo quadrature (core.analysis) is not available yet in this build")
    results = mod.albedo_table(brdf, [float(t) for t in thetas_deg], phi_deg=phi_deg, rtol=ALBEDO_RTOL)
    return np.array([r.value for r in results], dtype=np.float64).reshape(len(results), 3)


# ---- the adaptive sampler (always in the build) -----------------------------------------------------
ADAPTIVE_SAMPLERS = {"exact": "adaptive", "warp": "adaptive_warp"}
"""The registered sampler of each mode of the adaptive sampler."""


def adaptive_sampler(brdf: BRDF, mode: str = "exact", n_max: float = 2.0) -> AdaptiveSampler:
    """The adaptive sampler of ``brdf`` in ``mode`` (``"exact"`` or ``"warp"``). Both modes read one table per
    material and ``n_max`` (made on first use, kept in memory and on disk); what a view shows of it is in
    :mod:`core.sampling.adaptive.inspect`."""
    from core.sampling import make_sampler

    if mode not in ADAPTIVE_SAMPLERS:
        raise ParameterError(f"the adaptive sampler's mode must be 'exact' or 'warp', got {mode!r}")
    return make_sampler(ADAPTIVE_SAMPLERS[mode], brdf, n_max=n_max)


def adaptive_table_info(brdf: BRDF) -> dict[str, Any]:
    """Memory and build time of the adaptive sampler's table for ``brdf`` (makes it)."""
    sampler = adaptive_sampler(brdf)
    sampler.preload()
    return sampler.info()


# ---- the renderer ---------------------------------------------------------------------------------------
def renderer_available() -> bool:
    mod = _module("renderer")
    return mod is not None and _module("renderer.render") is not None
