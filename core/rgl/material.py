"""An RGL ``.bsdf`` file as a material: reading with validation, writing, and the model declarations.

Fields of an RGB ``.bsdf`` file (a tensor file, :mod:`core.rgl.tensor_file`), as the RGL database, Mitsuba 3's
``measured`` plugin and pbrt-v4's ``MeasuredBxDF`` use them; ``P = len(phi_i)``, ``T = len(theta_i)``:

============== ========= ===================== =====================================================
field          type      shape                 meaning
============== ========= ===================== =====================================================
description    uint8     (n,)                  UTF-8 text
jacobian       uint8     (1,)                  1: ``rgb`` holds ``f cos theta_i * 4 sigma / D``
theta_i        float32   (T,)                  polar angles of the conditioning direction (radians)
phi_i          float32   (P,)                  its azimuths; ``P <= 2``: isotropic
ndf            float32   (h, w)                ``D`` over ``(u(phi_m), u(theta_m))``
sigma          float32   (h, w)                projected area ``sigma(wo)`` over ``(u(phi), u(theta))``
vndf           float32   (P, T, h, w)          the visible-normal warp's density (any scale)
luminance      float32   (P, T, n, n)          the luminance warp's density over the sample square
rgb            float32   (P, T, 3, n, n)       stored values over the sample square
============== ========= ===================== =====================================================

A spectral file — the RGL database's own measurements — holds ``wavelengths`` (float32, ``(W,)``, nm) and
``spectra`` (float32, ``(P, T, W, n, n)``) in place of ``rgb``: the renderer is RGB, so the spectra become
linear sRGB on load (:mod:`core.rgl.spectral`: CIE 1931 under D65), and the table keeps the wavelengths it
came from; everything else (the warps, hence sampling) is the same. Every problem — a missing field, a wrong type or shape, shapes that disagree, non-finite or
negative values, a warp slice with no mass — is one :class:`~core.errors.FileFormatError` naming the file and
the field.

A ``.bsdf`` material is a :class:`core.brdf.BRDF` like a MERL one: :func:`rgl_brdf` gives an
:class:`RGLBRDF` whose model is :data:`RGL` (isotropic), :data:`RGL_ANISOTROPIC` (files folded into a quadrant
of ``phi``, mirror-symmetric) or :data:`RGL_GENERAL`, all three evaluated by
:func:`core.rgl.lookup.eval_rgl` and sampled by the file's own luminance warp (``sample_rgl``/``pdf_rgl``,
the model's ``analytic`` sampler). :func:`write_bsdf` writes a table, or exports any BRDF
(:func:`core.rgl.export.tabulate`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.brdf import BRDF, Model, Traits
from core.errors import FileFormatError
from core.measured import FileBRDF
from core.rgl import lookup, spectral
from core.rgl.tensor_file import read_tensor_file, write_tensor_file

SUFFIX = ".bsdf"
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass(frozen=True)
class RGLTable:
    """The fields of an RGB ``.bsdf`` file (see the module docstring), as stored (float32); a spectral file's
    ``rgb`` is its spectra converted, and ``wavelengths`` (nm) says so (``None`` for an RGB file)."""

    description: str
    jacobian: bool
    theta_i: np.ndarray
    phi_i: np.ndarray
    ndf: np.ndarray
    sigma: np.ndarray
    vndf: np.ndarray
    luminance: np.ndarray
    rgb: np.ndarray
    wavelengths: np.ndarray | None = None

    @property
    def isotropic(self) -> bool:
        return self.phi_i.shape[0] <= 2

    @property
    def reduction(self) -> int:
        """How many copies of the stored ``phi_i`` range make the circle (1 for isotropic files)."""
        if self.isotropic:
            return 1
        span = float(self.phi_i[-1]) - float(self.phi_i[0])
        return max(1, round(2.0 * math.pi / span))

    def fields(self) -> dict[str, np.ndarray | str]:
        """The tensor-file fields of an RGB file, in the order the RGL database writes them (a table read
        from a spectral file is written with its converted ``rgb``)."""
        return {
            "description": self.description,
            "jacobian": np.array([1 if self.jacobian else 0], dtype=np.uint8),
            "theta_i": self.theta_i.astype(np.float32),
            "phi_i": self.phi_i.astype(np.float32),
            "ndf": self.ndf.astype(np.float32),
            "sigma": self.sigma.astype(np.float32),
            "vndf": self.vndf.astype(np.float32),
            "luminance": self.luminance.astype(np.float32),
            "rgb": self.rgb.astype(np.float32),
        }

    def resolution(self) -> str:
        p, t, _, h, w = self.rgb.shape
        if self.wavelengths is not None:
            return f"{p} x {t} x {h} x {w} x 3 (from {self.wavelengths.shape[0]} wavelengths)"
        return f"{p} x {t} x {h} x {w} x 3"


# --------------------------------------------------------------------------------------------- reading


def _spectral(table: dict[str, np.ndarray], where: str) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """A spectral file's fields with ``rgb`` made from its spectra, and its wavelengths; an RGB file's as
    they are (and ``None``)."""
    if "rgb" in table or ("spectra" not in table and "wavelengths" not in table):
        return table, None
    for name in ("wavelengths", "spectra"):
        if name not in table:
            raise FileFormatError(
                f"{where} is a spectral .bsdf file without field '{name}' (a spectral file holds 'wavelengths' "
                "and 'spectra')"
            )
    wl, spectra = table["wavelengths"], table["spectra"]
    for name, arr, ndim in (("wavelengths", wl, 1), ("spectra", spectra, 5)):
        if arr.dtype != np.float32 or arr.ndim != ndim:
            raise FileFormatError(
                f"{where}: field '{name}' is {arr.dtype} of rank {arr.ndim}, expected float32 of rank {ndim}"
            )
    if wl.shape[0] < 2 or not np.all(np.isfinite(wl)) or wl[0] <= 0.0 or np.any(np.diff(wl) <= 0.0):
        raise FileFormatError(
            f"{where}: field 'wavelengths' must hold at least 2 increasing positive wavelengths (nm)"
        )
    if not spectral.covers_visible(wl):
        raise FileFormatError(
            f"{where}: field 'wavelengths' spans {wl[0]:g} to {wl[-1]:g} nm, outside the visible range "
            f"({spectral.CIE_MIN_NM:g} to {spectral.CIE_MAX_NM:g} nm): no colour can be made of it"
        )
    if spectra.shape[2] != wl.shape[0]:
        raise FileFormatError(
            f"{where}: field 'spectra' has shape {spectra.shape}; its third size must be len(wavelengths) = "
            f"{wl.shape[0]}"
        )
    if not np.all(np.isfinite(spectra)):
        raise FileFormatError(f"{where}: field 'spectra' holds NaN or Inf values")
    return {**table, "rgb": spectral.spectra_to_rgb(spectra, wl)}, wl


def _check(table: dict[str, np.ndarray], where: str) -> RGLTable:
    table, wavelengths = _spectral(table, where)
    values = "rgb" if wavelengths is None else "spectra"
    required = {
        "description": (np.uint8, 1),
        "jacobian": (np.uint8, 1),
        "theta_i": (np.float32, 1),
        "phi_i": (np.float32, 1),
        "ndf": (np.float32, 2),
        "sigma": (np.float32, 2),
        "vndf": (np.float32, 4),
        "luminance": (np.float32, 4),
        "rgb": (np.float32, 5),
    }
    for name, (dtype, ndim) in required.items():
        if name not in table:
            raise FileFormatError(
                f"{where} has no field '{name}' (an RGB .bsdf file holds {', '.join(required)}; a spectral "
                "one 'wavelengths' and 'spectra' in place of 'rgb')"
            )
        arr = table[name]
        if arr.dtype != np.dtype(dtype) or arr.ndim != ndim:
            raise FileFormatError(
                f"{where}: field '{name}' is {arr.dtype} of rank {arr.ndim}, expected {np.dtype(dtype)} of rank {ndim}"
            )
    theta, phi = table["theta_i"], table["phi_i"]
    n_phi, n_theta = phi.shape[0], theta.shape[0]
    if n_theta < 1 or n_phi < 1:
        raise FileFormatError(f"{where}: 'theta_i' and 'phi_i' need at least one value each")
    for name, arr in (("theta_i", theta), ("phi_i", phi)):
        if not np.all(np.isfinite(arr)) or np.any(np.diff(arr) <= 0.0):
            raise FileFormatError(f"{where}: field '{name}' must hold increasing finite angles")
    if theta[0] < 0.0 or theta[-1] > 0.5 * math.pi + 1e-4:
        raise FileFormatError(
            f"{where}: 'theta_i' must lie in [0, pi/2] radians, got {theta[0]:g} to {theta[-1]:g}"
        )
    vndf, lum, rgb = table["vndf"], table["luminance"], table["rgb"]
    if table["jacobian"].shape != (1,):
        raise FileFormatError(
            f"{where}: field 'jacobian' must hold one value, got shape {table['jacobian'].shape}"
        )
    for name, arr in (("vndf", vndf), ("luminance", lum), (values, rgb)):
        if arr.shape[:2] != (n_phi, n_theta):
            raise FileFormatError(
                f"{where}: field '{name}' has shape {arr.shape}; its first two sizes must be "
                f"len(phi_i) x len(theta_i) = {n_phi} x {n_theta}"
            )
    if rgb.shape[2] != 3:
        raise FileFormatError(f"{where}: field 'rgb' has {rgb.shape[2]} channels, expected 3")
    if lum.shape[2:] != rgb.shape[3:]:
        raise FileFormatError(
            f"{where}: 'luminance' ({lum.shape[2]} x {lum.shape[3]}) and '{values}' ({rgb.shape[3]} x "
            f"{rgb.shape[4]}) must share the sample grid"
        )
    for name in ("ndf", "sigma", "vndf", "luminance", "rgb"):
        arr = table[name]
        if min(arr.shape[-2:]) < 2:
            name = values if name == "rgb" else name
            raise FileFormatError(f"{where}: field '{name}' needs at least 2 x 2 nodes, got {arr.shape[-2:]}")
        if not np.all(np.isfinite(arr)):
            raise FileFormatError(f"{where}: field '{name}' holds NaN or Inf values")
    for name in ("ndf", "sigma", "vndf", "luminance"):
        if np.any(table[name] < 0.0):
            raise FileFormatError(f"{where}: field '{name}' holds negative values (it is a density)")
    if not np.all(table["sigma"] > 0.0):
        raise FileFormatError(f"{where}: field 'sigma' (projected area) must be positive everywhere")
    for name in ("vndf", "luminance"):
        mass = table[name].reshape(n_phi * n_theta, -1).sum(axis=1)
        if np.any(mass <= 0.0):
            raise FileFormatError(f"{where}: field '{name}' has a slice with no mass (all zeros)")
    try:
        description = bytes(table["description"]).decode("utf-8")
    except UnicodeDecodeError:
        raise FileFormatError(f"{where}: field 'description' is not UTF-8 text") from None
    out = RGLTable(
        description=description,
        jacobian=bool(table["jacobian"][0]),
        theta_i=theta,
        phi_i=phi,
        ndf=table["ndf"],
        sigma=table["sigma"],
        vndf=vndf,
        luminance=lum,
        rgb=rgb,
        wavelengths=wavelengths,
    )
    if not out.isotropic and out.reduction not in (1, 2, 4):
        raise FileFormatError(
            f"{where}: 'phi_i' spans {float(phi[-1] - phi[0]):.4f} rad; an anisotropic file covers the circle, "
            "half or a quarter of it"
        )
    return out


def read_bsdf(path: str | os.PathLike[str]) -> RGLTable:
    """Read a ``.bsdf`` file, RGB or spectral (converted to RGB); raises :class:`FileFormatError` naming what
    is wrong."""
    where = f"RGL .bsdf file '{Path(path)}'"
    return _check(read_tensor_file(path, "RGL .bsdf file"), where)


def write_bsdf(path: str | os.PathLike[str], source: BRDF | RGLTable) -> RGLTable:
    """Write a ``.bsdf`` file atomically: a table as it is, or any BRDF exported by
    :func:`core.rgl.export.tabulate` (default resolution). Returns the table written."""
    if isinstance(source, BRDF):
        from core.rgl.export import tabulate

        table = tabulate(source)
    else:
        table = source
    write_tensor_file(path, table.fields())
    return table


# --------------------------------------------------------------------------------------------- kernel vector


def warp_tables(density: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normalized data, marginal and conditional CDFs of warp slices ``density (s, h, w)`` (see
    :mod:`core.rgl.marginal`); a slice with no mass becomes uniform."""
    d = np.asarray(density, dtype=np.float64)
    s, h, w = d.shape
    empty = d.reshape(s, -1).sum(axis=1) <= 0.0
    if empty.any():
        d = d.copy()
        d[empty] = 1.0
    cond = np.cumsum(0.5 / (w - 1) * (d[:, :, :-1] + d[:, :, 1:]), axis=2)
    rows = cond[:, :, -1]
    marg = np.cumsum(0.5 / (h - 1) * (rows[:, :-1] + rows[:, 1:]), axis=1)
    norm = 1.0 / marg[:, -1]
    return d * norm[:, None, None], marg * norm[:, None], cond * norm[:, None, None]


def kernel_vector(table: RGLTable) -> np.ndarray:
    """The kernel parameter vector of :mod:`core.rgl.lookup` (header, tables, the warps' CDFs)."""
    n_phi, n_theta = table.phi_i.shape[0], table.theta_i.shape[0]
    slices = n_phi * n_theta
    vndf_h, vndf_w = table.vndf.shape[2:]
    n_h, n_w = table.rgb.shape[3:]
    vndf = warp_tables(table.vndf.reshape(slices, vndf_h, vndf_w))
    lum = warp_tables(table.luminance.reshape(slices, n_h, n_w))
    parts = {
        lookup.H_OFF_PHI: table.phi_i,
        lookup.H_OFF_THETA: table.theta_i,
        lookup.H_OFF_NDF: table.ndf,
        lookup.H_OFF_SIGMA: table.sigma,
        lookup.H_OFF_VNDF: vndf[0],
        lookup.H_OFF_VNDF_MARG: vndf[1],
        lookup.H_OFF_VNDF_COND: vndf[2],
        lookup.H_OFF_LUM: lum[0],
        lookup.H_OFF_LUM_MARG: lum[1],
        lookup.H_OFF_LUM_COND: lum[2],
        lookup.H_OFF_RGB: table.rgb,
    }
    header = np.zeros(lookup.HEADER)
    header[lookup.H_MAGIC] = lookup.MAGIC
    header[lookup.H_N_PHI] = n_phi
    header[lookup.H_N_THETA] = n_theta
    header[lookup.H_REDUCTION] = table.reduction
    header[lookup.H_ISOTROPIC] = 1.0 if table.isotropic else 0.0
    header[lookup.H_JACOBIAN] = 1.0 if table.jacobian else 0.0
    header[lookup.H_NDF_H], header[lookup.H_NDF_W] = table.ndf.shape
    header[lookup.H_SIGMA_H], header[lookup.H_SIGMA_W] = table.sigma.shape
    header[lookup.H_VNDF_H], header[lookup.H_VNDF_W] = vndf_h, vndf_w
    header[lookup.H_SAMPLE_H], header[lookup.H_SAMPLE_W] = n_h, n_w
    chunks = [header]
    pos = lookup.HEADER
    for slot, arr in parts.items():
        header[slot] = pos
        flat = np.asarray(arr, dtype=np.float64).reshape(-1)
        chunks.append(flat)
        pos += flat.size
    return np.ascontiguousarray(np.concatenate(chunks))


# --------------------------------------------------------------------------------------------- models

_CITATION = (
    "J. Dupuy, W. Jakob, An Adaptive Parameterization for Efficient Material Acquisition and Rendering, "
    "ACM Trans. Graph. 37(6), 2018."
)
_NOTES = (
    "Not in the model registry: a measured BRDF is made from a file with core.rgl.material.rgl_brdf(path). "
    "Its analytic sampler is the file's luminance warp over the visible-normal parameterization."
)


def _declare(name: str, label: str, traits: Traits, notes: str = "") -> Model:
    """One of the three declarations below: they differ only in name, label, traits and notes."""
    return Model(
        name=name,
        label=label,
        citation=_CITATION,
        params=(),
        traits=traits,
        eval=lookup.eval_rgl,
        sample=lookup.sample_rgl,
        pdf=lookup.pdf_rgl,
        doc=__doc__ or "",
        notes=_NOTES + notes,
        measured=True,
    )


RGL = _declare("rgl", "Measured (RGL .bsdf)", Traits.ISOTROPIC)
"""Isotropic ``.bsdf`` files (``phi_o`` is not a parameter: tables over ``phi_m - phi_o``)."""

RGL_ANISOTROPIC = _declare(
    "rgl_anisotropic",
    "Measured (RGL .bsdf, anisotropic)",
    Traits.MIRROR_SYMMETRIC,
    " The file covers a quadrant of phi_o; the reader mirrors the rest into it.",
)
"""Anisotropic files over a quadrant of ``phi_o`` (reduction 4): mirror-symmetric by construction."""

RGL_GENERAL = _declare("rgl_general", "Measured (RGL .bsdf, anisotropic, no symmetry)", Traits.NONE)
"""Anisotropic files over the whole circle of ``phi_o`` or half of it."""


def model_of(table: RGLTable) -> Model:
    if table.isotropic:
        return RGL
    return RGL_ANISOTROPIC if table.reduction == 4 else RGL_GENERAL


class RGLBRDF(FileBRDF):
    """A BRDF backed by an RGL table; ``path`` says where it came from (``None`` for an in-memory table)."""

    def __init__(self, table: RGLTable, path: str | None = None):
        super().__init__(model_of(table), kernel_vector(table), table, path)


def rgl_brdf(path: str | os.PathLike[str]) -> RGLBRDF:
    """A :class:`BRDF` from a ``.bsdf`` file, RGB or spectral (errors as :func:`read_bsdf`)."""
    return RGLBRDF(read_bsdf(path), str(path))
