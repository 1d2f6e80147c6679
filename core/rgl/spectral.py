"""Spectral RGL ``.bsdf`` files in an RGB renderer: the stored spectra become linear sRGB once, on load.

The RGL database's measurements are spectral (``wavelengths`` of about 360-1000 nm, ``spectra`` in place of
``rgb``). Mitsuba 3's ``measured`` plugin refuses them in its RGB variants (and an RGB file in its spectral
ones); what Mitsuba 3 does with any *reflectance* spectrum in an RGB variant (``spectrum_list_to_srgb`` with its
D65 option, used for spectra given in a scene) is what we do with every stored value:

* the spectrum is the linear interpolant of its samples, 0 outside the stored range;
* ``XYZ = integral S(l) cmf(l) D65(l) dl / integral y(l) D65(l) dl`` over the CIE 1931 2-degree observer's
  range, 360-830 nm (trapezoids at 5 nm): the value is a reflectance seen under D65, the white point of sRGB,
  so a flat spectrum ``S = c`` has ``Y = c`` and the chromaticity of D65; light beyond 830 nm (the database's
  near-infrared samples) has no colour and is left out;
* linear sRGB is the IEC 61966-2-1 matrix times ``XYZ``, then divided channel by channel by the image of the
  tabulated D65 white. The matrix is rounded to four digits and the white it was made for is (0.3127, 0.3290),
  so without that step a flat spectrum would come out ``c (0.99992, 1.00009, 0.99997)`` rather than grey; with
  it, a flat spectrum is exactly ``(c, c, c)`` (a correction below 1e-4; Mitsuba 3 leaves it out);
* negative channels (colours outside the sRGB gamut) are kept in the table: the kernels clamp the value they
  return at 0, as they do for an RGB file's.

The tabulated data are :mod:`core.rgl.cie_tables`: the CIE 1931 2-degree colour-matching functions and the CIE
D65 relative spectral power at 5 nm from 360 to 830 nm (the interval CIE 015 gives for colorimetric sums, and
Mitsuba 3's) and the sRGB matrix, written by ``python -m core.rgl.spectral`` from the ``colour-science``
package (its ``MSDS_CMFS``, ``SDS_ILLUMINANTS`` and ``RGB_COLOURSPACE_sRGB``, transcribed from the CIE's and
the IEC's tables; a test checks that the module is what the script writes). colour-science is not imported at
run time: importing it takes 2-20 s (it loads its plotting), once per process that would read a spectral file.
"""

from __future__ import annotations

import sys
from functools import cache
from pathlib import Path

import numpy as np

CIE_MIN_NM = 360.0
CIE_MAX_NM = 830.0
STEP_NM = 5.0


@cache
def observer() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The CIE 1931 2-degree observer under D65: wavelengths ``(n,)`` nm, the colour-matching functions times
    D65 and the trapezoid weights, normalized so that a flat unit spectrum has ``Y = 1`` (``(n, 3)``), and the
    XYZ -> linear sRGB matrix ``(3, 3)`` with the white correction folded in."""
    from core.rgl import cie_tables  # here, so that the script below can write it when it is missing

    rows = np.array(cie_tables.ROWS, dtype=np.float64)
    grid = cie_tables.FIRST_NM + cie_tables.STEP_NM * np.arange(rows.shape[0])
    xyz_bar, power = rows[:, :3], rows[:, 3]
    step = np.full(grid.shape, cie_tables.STEP_NM)
    step[0] *= 0.5
    step[-1] *= 0.5
    weighted = xyz_bar * (power * step)[:, None]
    weighted /= weighted[:, 1].sum()
    to_rgb = np.array(cie_tables.XYZ_TO_SRGB, dtype=np.float64)
    white = to_rgb @ weighted.sum(axis=0)
    return grid, weighted, to_rgb / white[:, None]


def rgb_weights(wavelengths: np.ndarray) -> np.ndarray:
    """The linear map from a spectrum sampled at ``wavelengths (w,)`` (nm, increasing) to linear sRGB:
    ``(w, 3)``, so that ``rgb = spectrum @ rgb_weights(wavelengths)``."""
    wl = np.asarray(wavelengths, dtype=np.float64)
    grid, weighted, to_rgb = observer()
    # Sample j's share of the interpolant at every grid wavelength: the hat function of node j.
    hats = np.empty((wl.size, grid.size))
    for j in range(wl.size):
        unit = np.zeros(wl.size)
        unit[j] = 1.0
        hats[j] = np.interp(grid, wl, unit, left=0.0, right=0.0)
    return (hats @ weighted) @ to_rgb.T


def covers_visible(wavelengths: np.ndarray) -> bool:
    """Whether samples at ``wavelengths`` (nm, increasing) overlap the observer's range at all."""
    wl = np.asarray(wavelengths, dtype=np.float64)
    return bool(wl.size >= 2 and wl[0] < CIE_MAX_NM and wl[-1] > CIE_MIN_NM)


def spectra_to_rgb(spectra: np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
    """Stored spectra ``(P, T, w, h, n)`` (the ``spectra`` field) as linear sRGB ``(P, T, 3, h, n)``, float32
    like an RGB file's ``rgb`` field (computed in float64)."""
    k = rgb_weights(wavelengths)
    rgb = np.einsum("ptwhn,wc->ptchn", np.asarray(spectra, dtype=np.float64), k, optimize=True)
    return rgb.astype(np.float32)


# --------------------------------------------------------------------------------------------- the table


def table_source() -> str:
    """The text of :mod:`core.rgl.cie_tables`, from colour-science (imported here only)."""
    from colour.colorimetry import MSDS_CMFS, SDS_ILLUMINANTS
    from colour.models import RGB_COLOURSPACE_sRGB

    cmfs = MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = SDS_ILLUMINANTS["D65"]
    first, step, last = int(CIE_MIN_NM), int(STEP_NM), int(CIE_MAX_NM)
    d65_last = int(d65.wavelengths[-1])
    lines = [
        '"""CIE tables for :mod:`core.rgl.spectral`. Written by ``python -m core.rgl.spectral`` from colour-science;',
        "do not edit.",
        "",
        "ROWS: wavelength FIRST_NM + i * STEP_NM -> (x_bar, y_bar, z_bar, D65): the CIE 1931 2-degree standard",
        "observer (CIE 015:2018) and the CIE standard illuminant D65's relative spectral power (ISO 11664-2 /",
        f"CIE S 014-2), as colour-science holds them; D65 past {d65_last} nm, where colour-science's table ends, is",
        f"held at its {d65_last} nm value (y_bar is below 2e-5 of its peak there).",
        "XYZ_TO_SRGB: the XYZ -> linear sRGB matrix of IEC 61966-2-1.",
        '"""',
        "",
        f"FIRST_NM = {float(first)!r}",
        f"STEP_NM = {float(step)!r}",
        "",
        "XYZ_TO_SRGB = (",
    ]
    for row in np.asarray(RGB_COLOURSPACE_sRGB.matrix_XYZ_to_RGB, dtype=np.float64):
        lines.append("    (" + ", ".join(repr(float(v)) for v in row) + "),")
    lines += [")", "", "ROWS = ("]
    d65_wl = np.asarray(d65.wavelengths, dtype=np.float64)
    d65_values = np.asarray(d65.values, dtype=np.float64)
    cmf_wl = np.asarray(cmfs.wavelengths, dtype=np.float64)
    for wl in range(first, last + 1, step):
        # The stored values at the node (indexing the distribution interpolates, which adds rounding noise).
        x, y, z = (float(v) for v in np.asarray(cmfs.values)[int(np.flatnonzero(cmf_wl == wl)[0])])
        at = np.flatnonzero(d65_wl == wl)
        power = float(d65_values[int(at[0])]) if at.size else float(d65_values[-1])
        lines.append(f"    ({x!r}, {y!r}, {z!r}, {power!r}),  # {wl} nm")
    lines += [")", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    target = Path(__file__).with_name("cie_tables.py")
    target.write_text(table_source())
    print(f"wrote {target}", file=sys.stderr)
