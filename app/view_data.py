"""The arrays the BRDF views draw, as plain numpy functions (no Qt, testable on their own); the sampler
view's snapshot is :mod:`app.sampling_data`.

All directions are in the local shading frame (z = normal). ``wo`` is the direction the user sets
(the API's outgoing direction, the seed's ``u``); the views show the BRDF over ``wi``. By reciprocity this
is also the reflected lobe for light arriving from ``wo`` when the model is reciprocal.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from core.brdf import BRDF, luminance

if TYPE_CHECKING:
    from collections.abc import Callable


def hemisphere_grid(n_theta: int = 40, n_phi: int = 80) -> np.ndarray:
    """Unit directions ``(n_theta, n_phi + 1, 3)`` over the upper hemisphere; the last phi column repeats
    the first so that a structured grid closes. Theta runs from 0 to just below 90 degrees."""
    theta = np.linspace(0.0, 0.5 * math.pi * (1.0 - 1e-4), n_theta)
    phi = np.linspace(0.0, 2.0 * math.pi, n_phi + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    s = np.sin(t)
    return np.stack([s * np.cos(p), s * np.sin(p), np.cos(t)], axis=-1)


def grid_quads(n_theta: int, n_cols: int) -> np.ndarray:
    """The faces of a ``(n_theta, n_cols)`` grid of points (C order, point ``i * n_cols + j``) as a VTK cell
    array: ``(n_theta - 1) * (n_cols - 1)`` quads, each ``[4, a, b, c, d]``, wound so that the normal points
    outwards for :func:`hemisphere_grid` (theta down the rows, phi along the columns)."""
    i, j = np.meshgrid(np.arange(n_theta - 1), np.arange(n_cols - 1), indexing="ij")
    a = (i * n_cols + j).ravel()
    quads = np.stack([np.full_like(a, 4), a, a + n_cols, a + n_cols + 1, a + 1], axis=1)
    return quads.ravel()


def grid_normals(points: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Unit outward normals ``(n_theta, n_phi + 1, 3)`` of the surface through ``points`` (same shape), a
    deformed :func:`hemisphere_grid` whose last column repeats the first.

    Central differences along theta and (periodically) along phi; the theta = 0 row, where the phi tangent
    vanishes, takes the mean of the next row's normals; where the surface degenerates (the lobe is 0 around a
    point) the normal falls back to the grid direction.
    """
    p = points[:, :-1]  # drop the closing column: phi is periodic
    d_theta = np.gradient(p, axis=0)
    d_phi = 0.5 * (np.roll(p, -1, axis=1) - np.roll(p, 1, axis=1))
    n = np.cross(d_theta, d_phi)
    n = np.concatenate([n, n[:, :1]], axis=1)
    n[0] = np.sum(n[1, :-1], axis=0) if n.shape[0] > 1 else n[0]
    length = np.linalg.norm(n, axis=-1)
    # relative threshold: tangents scale with the lobe's size
    tiny = length <= 1e-12 * max(float(np.max(length, initial=0.0)), 1e-300)
    n = np.where(tiny[..., None], directions, n / np.where(tiny, 1.0, length)[..., None])
    return n


def lobe(brdf: BRDF, wo: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lobe ``f(wo, wi) cos(theta_i)`` (luminance) over ``directions (..., 3)``.

    Returns ``(points (..., 3), value (...))``: each direction scaled by its value, and the value.
    """
    flat = directions.reshape(-1, 3)
    value = luminance(brdf.eval(np.asarray(wo, dtype=np.float64), flat)) * np.maximum(flat[:, 2], 0.0)
    value = np.where(np.isfinite(value), np.maximum(value, 0.0), 0.0)
    points = flat * value[:, None]
    return points.reshape(directions.shape), value.reshape(directions.shape[:-1])


def incidence_plane(brdf: BRDF, wo: np.ndarray, n: int = 181) -> tuple[np.ndarray, np.ndarray]:
    """The slice of ``f cos(theta_i)`` in the plane of ``wo`` and the normal.

    Returns ``(theta (n,), rgb (n, 3))`` with signed polar angles in radians from -pi/2 to pi/2: positive on
    the mirror side of ``wo`` (forward scattering), negative towards ``wo`` (back scattering).
    """
    wo = np.asarray(wo, dtype=np.float64)
    phi_o = math.atan2(wo[1], wo[0]) if abs(wo[0]) + abs(wo[1]) > 1e-12 else 0.0
    theta = np.linspace(-0.5 * math.pi, 0.5 * math.pi, n)
    phi = np.where(theta >= 0.0, phi_o + math.pi, phi_o)
    s = np.sin(np.abs(theta))
    wi = np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], axis=-1)
    wi[np.abs(np.abs(theta) - 0.5 * math.pi) < 1e-12, 2] = 0.0
    rgb = brdf.eval(wo, wi) * np.maximum(wi[:, 2], 0.0)[:, None]
    return theta, np.where(np.isfinite(rgb), np.maximum(rgb, 0.0), 0.0)


def _tangent_frames(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent and bitangent ``(m, 3)`` for normals ``n (m, 3)``: the tangent follows world x projected
    onto the surface (so anisotropy lines up across the sphere)."""
    ex = np.array([1.0, 0.0, 0.0])
    t = ex - n * (n @ ex)[:, None]
    norm = np.linalg.norm(t, axis=1)
    bad = norm < 1e-6
    t[bad] = np.array([0.0, 1.0, 0.0]) - n[bad] * n[bad, 1:2]
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-12)[:, None]
    b = np.cross(n, t)
    return t, b


def lit_sphere(brdf: BRDF, light: np.ndarray, size: int = 128, ambient: float = 0.02) -> np.ndarray:
    """Radiance ``(size, size, 3)`` of a sphere seen from +z (orthographic), lit by a unit-irradiance
    directional light from ``light`` (world direction towards the light) plus a little ambient term.
    Pixels off the sphere are 0; image row 0 is the top."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)
    r2 = x * x + y * y
    inside = r2 < 1.0
    n = np.stack([x[inside], y[inside], np.sqrt(1.0 - r2[inside])], axis=-1)
    t, b = _tangent_frames(n)
    view = np.array([0.0, 0.0, 1.0])
    light = np.asarray(light, dtype=np.float64)
    light = light / np.linalg.norm(light)
    wo = np.stack([t @ view, b @ view, n @ view], axis=-1)
    wi = np.stack([t @ light, b @ light, n @ light], axis=-1)
    f = brdf.eval(wo, wi)
    cos_i = np.maximum(wi[:, 2], 0.0)[:, None]
    albedo_hint = brdf.eval(wo, wo) * np.maximum(wo[:, 2], 0.0)[:, None]
    rad = f * cos_i + ambient * np.minimum(albedo_hint, 1.0)
    img = np.zeros((size, size, 3))
    img[inside] = np.where(np.isfinite(rad), np.maximum(rad, 0.0), 0.0)
    return img


def to_srgb8(linear: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """Linear RGB to 8-bit sRGB (clipped), for display."""
    x = np.clip(np.asarray(linear, dtype=np.float64) * exposure, 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.ascontiguousarray(np.round(s * 255.0).astype(np.uint8))


def light_from_disk(x: float, y: float) -> tuple[float, float, float]:
    """A light direction from a point on the preview's unit disk (front hemisphere; outside the disk the
    point is pulled onto the rim)."""
    r = math.hypot(x, y)
    if r > 1.0:
        x, y = x / r, y / r
        r = 1.0
    return (x, y, math.sqrt(max(0.0, 1.0 - r * r)))


def direction_from_disk(x: float, y: float) -> tuple[float, float]:
    """``(theta_deg, phi_deg)`` of the hemisphere direction whose disk projection is ``(x, y)``."""
    r = min(math.hypot(x, y), 1.0)
    theta = math.degrees(math.asin(r))
    phi = math.degrees(math.atan2(y, x)) % 360.0
    return theta, phi


def albedo_line(
    thetas_deg: np.ndarray, rgb: np.ndarray, quote: tuple[float, ...] = (0.0, 30.0, 60.0, 80.0)
) -> str:
    """One line of text: the luminance albedo at the ``quote`` angles (taken from a computed curve)."""
    rho = luminance(rgb)
    cells = []
    for t in quote:
        k = int(np.argmin(np.abs(np.asarray(thetas_deg) - t)))
        cells.append(f"{thetas_deg[k]:g}&deg;: {rho[k]:.3f}")
    warn = " <b style='color:#c62828'>(&gt; 1!)</b>" if np.any(rho > 1.0 + 1e-3) else ""
    return f"Albedo (luminance) {', '.join(cells)}{warn}"


ALBEDO_RTOL = 1e-3
"""Relative accuracy asked of the albedo quadrature in the UI (the library's default is stricter and slower)."""


def directional_albedo(brdf: BRDF, thetas_deg: list[float], phi_deg: float = 0.0,
                       stop: Callable[[], bool] | None = None) -> np.ndarray | None:  # fmt: skip
    """Directional albedo ``(n, 3)`` at the polar angles ``thetas_deg`` (degrees), by ``core.analysis``;
    None when ``stop()`` said so between two angles (a newer request is waiting)."""
    from core.analysis import albedo

    values = np.empty((len(thetas_deg), 3))
    for i, t in enumerate(thetas_deg):
        if stop is not None and stop():
            return None
        values[i] = albedo(brdf, float(t), phi_deg=phi_deg, rtol=ALBEDO_RTOL).value
    return values
