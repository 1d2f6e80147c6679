"""The arrays the BRDF views draw, as plain numpy functions (no Qt, testable on their own).

All directions are in the local shading frame (z = normal). ``wo`` is the direction the user sets
(the API's outgoing direction, the seed's ``u``); the views show the BRDF over ``wi``. By reciprocity this
is also the reflected lobe for light arriving from ``wo`` when the model is reciprocal.
"""

from __future__ import annotations

import math

import numpy as np

from core.model import BRDF, luminance


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


def adaptive_line(brdf: BRDF) -> str:
    """One line of text: the adaptive sampler's table memory and build time for ``brdf`` (builds it)."""
    from app.capabilities import Unavailable, adaptive_table_info

    try:
        info = adaptive_table_info(brdf)
    except Unavailable as exc:
        return f"Adaptive table: {exc}"
    return (
        f"Adaptive table: {info.get('memory_bytes', 0) / 1024:.1f} KiB, "
        f"built in {info.get('build_seconds', 0.0) * 1000:.0f} ms"
    )


def rotate_z(w: np.ndarray, phi: float) -> np.ndarray:
    """Rotate directions ``w (..., 3)`` by ``phi`` radians about the normal."""
    c, s = math.cos(phi), math.sin(phi)
    out = np.array(w, dtype=np.float64, copy=True)
    out[..., 0] = c * w[..., 0] - s * w[..., 1]
    out[..., 1] = s * w[..., 0] + c * w[..., 1]
    return out


def leaf_raster(leaves: np.ndarray, size: int) -> np.ndarray:
    """An image ``(size, size)`` over the square [-1, 1]^2 (row 0 at y = -1) holding each pixel's leaf bound
    ``M`` (0 outside every leaf); ``leaves (k, 5)`` rows ``M, x0, y0, x1, y1``. A leaf covers the pixels
    between its rounded edges, at least one; where leaves smaller than a pixel share one, the later wins."""
    img = np.zeros((size, size))
    leaves = np.asarray(leaves, dtype=np.float64).reshape(-1, 5)
    leaves = leaves[(leaves[:, 3] > leaves[:, 1]) & (leaves[:, 4] > leaves[:, 2])]
    if not len(leaves):
        return img
    px = np.rint((leaves[:, 1:] + 1.0) * 0.5 * size).astype(np.int64)  # x0, y0, x1, y1 (round half to even)
    x0, y0 = px[:, 0], px[:, 1]
    w = np.maximum(px[:, 2], x0 + 1) - x0
    h = np.maximum(px[:, 3], y0 + 1) - y0
    n = w * h
    leaf = np.repeat(np.arange(len(leaves)), n)  # one entry per covered pixel, leaf by leaf
    local = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    rows = np.clip(y0[leaf] + local // w[leaf], 0, size - 1)
    cols = np.clip(x0[leaf] + local % w[leaf], 0, size - 1)
    img[rows, cols] = leaves[leaf, 0]
    return img


def sampling_snapshot(
    brdf: BRDF,
    theta_deg: float,
    phi_deg: float,
    n_max: float = 2.0,
    ratio_sampler: str = "adaptive",
    n_samples: int = 2000,
    seed: int = 1,
    grid: int = 96,
) -> dict:
    """What the sampler view draws, computed off the GUI thread.

    Everything is in the *display frame*: the local frame rotated about the normal so that ``wo`` has
    phi = 0 when the BRDF is isotropic (the adaptive trees are built so and rotated at sampling time), the
    local frame itself otherwise. Keys: ``tree`` (see :func:`app.capabilities.quadtree_bin`, or ``None``),
    ``tree_error``, ``samples (n, 2)`` disk points of adaptive samples (or ``None``), ``samples_error``,
    ``ratio (grid, grid)`` = ``pdf / (f cos / I)`` of ``ratio_sampler`` on the disk (NaN where both are 0),
    ``ratio_error``, ``weight_rel_std`` of ``f cos / pdf`` over the ratio sampler's samples,
    ``acceptance`` (expected per-trial acceptance ``I / V``), ``wo_disk`` (2,).
    """
    from app.capabilities import Unavailable, from_disk, quadtree_bin, to_disk
    from core.errors import BrdfStudioError
    from core.sampling import make_sampler, sampler_names

    iso = brdf.model.isotropic
    frame_phi = math.radians(phi_deg) if iso else 0.0
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    wo_true = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
    wo_disp = rotate_z(wo_true, -frame_phi)
    out: dict = {"wo_disk": wo_disp[:2], "theta_deg": theta_deg, "phi_deg": phi_deg, "n_max": n_max}
    out["frame_rotated"] = iso

    try:
        tree = quadtree_bin(brdf, theta_deg, phi_deg, n_max)
        out["tree"], out["tree_error"] = tree, ""
        v = tree["total_mass"]
        out["acceptance"] = tree.get("acceptance", tree["integral"] / v if v > 0 else float("nan"))
    except BrdfStudioError as exc:
        out["tree"], out["tree_error"], out["acceptance"] = None, str(exc), float("nan")
    projection = out["tree"]["projection"] if out["tree"] else "orthographic"
    out["projection"] = projection

    out["samples"], out["samples_error"], out["sampler_info"] = None, "", {}
    adaptive_draw = None  # (sampler, batch): reused by the ratio map when it shows the adaptive sampler
    if "adaptive" in sampler_names():
        try:
            s = make_sampler("adaptive", brdf, n_max=n_max)
            batch = s.sample(wo_true, n_samples, seed)
            adaptive_draw = (s, batch)
            wi = batch.wi
            up = wi[:, 2] > 0.0
            out["samples"] = to_disk(rotate_z(wi[up], -frame_phi), projection)
            out["sampler_info"] = s.info()
        except BrdfStudioError as exc:
            out["samples_error"] = str(exc)
    else:
        out["samples_error"] = str(Unavailable("adaptive samples: the adaptive sampler is not available yet"))

    # ratio map of the chosen strategy against the ideal density f cos / I
    c = (np.arange(grid) + 0.5) / grid * 2.0 - 1.0
    x, y = np.meshgrid(c, c)  # row 0 at y = -1
    inside = x * x + y * y < 1.0
    wi_disp = from_disk(x[inside], y[inside], projection)
    wi_true = rotate_z(wi_disp, frame_phi)
    f = luminance(brdf.eval(wo_true, wi_true))
    # without a tree, I = int f cos dw = int f dx dy on the orthographic disk (midpoint rule)
    integral = out["tree"]["integral"] if out["tree"] else float(np.sum(f) * (2.0 / grid) ** 2)
    target = f * wi_true[:, 2] / integral if integral > 0 else np.zeros_like(f)
    out["ratio"], out["ratio_error"], out["weight_rel_std"] = None, "", float("nan")
    out["ratio_sampler"] = ratio_sampler
    if ratio_sampler in sampler_names():
        try:
            if ratio_sampler == "adaptive" and adaptive_draw is not None:
                s, drawn = adaptive_draw  # the same draw as the samples shown (same seed and count)
            else:
                s = make_sampler(
                    ratio_sampler, brdf, **({"n_max": n_max} if ratio_sampler == "adaptive" else {})
                )
                drawn = s.sample(wo_true, n_samples, seed)
            pdf = s.pdf(np.broadcast_to(wo_true, wi_true.shape), wi_true)
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.where((pdf > 0) | (target > 0), pdf / target, np.nan)
            img = np.full(x.shape, np.nan)
            img[inside] = r
            out["ratio"] = img
            fw = luminance(drawn.f) * np.maximum(drawn.wi[:, 2], 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                w = np.where(drawn.pdf > 0, fw / drawn.pdf, 0.0)
            mean = float(np.mean(w))
            out["weight_rel_std"] = float(np.std(w) / mean) if mean > 0 else float("nan")
        except BrdfStudioError as exc:
            out["ratio_error"] = str(exc)
    else:
        out["ratio_error"] = f"sampler '{ratio_sampler}' is not available yet"
    return out
