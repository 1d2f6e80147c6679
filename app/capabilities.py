"""What the app can use from the library, found at run time: measured BRDFs, the albedo quadrature, the
adaptive quadtree, the renderer. Parts of the project land at different times; a panel whose part is
missing says so (:class:`Unavailable`) instead of faking it. One place for the adapters keeps the views
free of import guessing."""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from core.errors import BrdfStudioError
from core.model import BRDF

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


# ---- the adaptive sampler -------------------------------------------------------------------------
def quadtree_available() -> bool:
    mod = _module("core.quadtree")
    needed = ("theta_edges", "BuildOptions", "normalizer_values", "direction_to_disk", "PROJECTIONS")
    return mod is not None and all(hasattr(mod, n) for n in needed) and "adaptive" in _sampler_names()


def _sampler_names() -> list[str]:
    from core.sampling import sampler_names

    return sampler_names()


def quadtree_bin(brdf: BRDF, theta_deg: float, phi_deg: float, n_max: float) -> dict[str, Any]:
    """The adaptive sampler's tree for the incident-angle bin holding ``(theta_deg, phi_deg)``.

    Returns a dict: ``leaves (k, 5)`` rows ``M, x0, y0, x1, y1`` (the bound and the disk-clipped box, in the
    tree's disk coordinates), ``projection`` (how disk points map to directions, see
    ``core.quadtree.disk_to_direction``), ``total_mass`` V, ``integral`` I(wo) (the tree's normalizer at this
    direction), ``nbytes``, ``build_seconds``, ``bin_deg`` (theta range), ``acceptance``. Isotropic trees are
    built for phi = 0 (rotated at sampling time); anisotropic ones per phi bin (mirror-symmetric models: bins
    of the first quadrant, returned mirrored to the direction's quadrant).
    """
    q = _module("core.quadtree")
    if q is None or not quadtree_available():
        raise Unavailable("the adaptive quadtree (core/quadtree.py) is not available yet in this build")
    return _sampler_tree(q, brdf, theta_deg, phi_deg, n_max)


def _sampler_tree(q: Any, brdf: BRDF, theta_deg: float, phi_deg: float, n_max: float) -> dict[str, Any]:
    """The tree the adaptive sampler itself uses for this direction (built on demand, cached by it)."""
    from core.sampling import make_sampler

    sampler = make_sampler("adaptive", brdf, n_max=n_max)
    table = sampler.table
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    wo = np.array([[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)]])
    try:
        b, tree = table.tree_at(wo[0])
        if tree is None:
            raise Unavailable("at this grazing angle the adaptive sampler falls back to the cosine density")
        bins, theta, phi = table.locate(wo)
        integral = float(table.normalizer(bins, theta, phi)[0])
        rng = table.bin_range(b)
        projection = getattr(tree, "projection", 0)
        acceptance = float(sampler.acceptance(wo[0])[0])
    except (TypeError, AttributeError, ValueError, IndexError, KeyError) as exc:
        raise Unavailable(
            f"the adaptive sampler's tree could not be read ({type(exc).__name__}: {exc})"
        ) from None
    if isinstance(projection, int | np.integer):
        projection = q.PROJECTIONS[int(projection)]
    # The table may store a tree in scaled units (its normalizer carries the scale): express the bounds and
    # the mass in the units of f, so that V = I / acceptance.
    true_mass = integral / acceptance if acceptance > 0 else tree.total_mass
    unit = true_mass / tree.total_mass if tree.total_mass > 0 else 1.0
    leaves = np.array(tree.leaf_rows(), dtype=np.float64)[:, :5]
    leaves[:, 0] *= unit
    # A mirror-symmetric anisotropic table keeps trees for the first quadrant of phi_o: show the tree mirrored
    # to the direction's quadrant, as sampling uses it.
    for axis, sign in enumerate(table.mirror_signs(wo)[0]):
        if sign < 0:
            lo, hi = leaves[:, 1 + axis].copy(), leaves[:, 3 + axis].copy()
            leaves[:, 1 + axis], leaves[:, 3 + axis] = -hi, -lo
    return {
        "leaves": leaves,
        "projection": str(projection),
        "total_mass": true_mass,
        "integral": integral,
        "nbytes": tree.nbytes,
        "build_seconds": tree.build_seconds,
        "bin_deg": (float(np.degrees(rng[0])), float(np.degrees(rng[1]))),
        "acceptance": acceptance,
    }


def to_disk(wi: np.ndarray, projection: str) -> np.ndarray:
    """Disk points ``(n, 2)`` of directions in the tree's projection."""
    q = _module("core.quadtree")
    if projection == "orthographic" or q is None:
        return np.asarray(wi)[:, :2].copy()
    return q.direction_to_disk(np.asarray(wi), projection)


def from_disk(x: np.ndarray, y: np.ndarray, projection: str) -> np.ndarray:
    """Directions ``(n, 3)`` of disk points in the tree's projection."""
    q = _module("core.quadtree")
    if projection == "orthographic" or q is None:
        z = np.sqrt(np.maximum(0.0, 1.0 - x * x - y * y))
        return np.stack([x, y, z], axis=1)
    wi, _ = q.disk_to_direction(x, y, projection)
    return wi


# ---- the renderer ---------------------------------------------------------------------------------------
def renderer_available() -> bool:
    mod = _module("renderer")
    return mod is not None and _module("renderer.render") is not None


def adaptive_table_info(brdf: BRDF) -> dict[str, Any]:
    """Memory and build time of the adaptive sampler's tables for ``brdf`` (builds them)."""
    from core.sampling import make_sampler, sampler_names

    if "adaptive" not in sampler_names():
        raise Unavailable("the adaptive sampler is not available yet in this build")
    sampler = make_sampler("adaptive", brdf)
    sampler.sample(np.array([0.0, 0.0, 1.0]), 1, 0)
    return sampler.info()
