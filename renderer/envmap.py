"""Light from infinity: a constant environment and an HDR lat-long map with importance sampling.

Lat-long convention (see :mod:`core.scene`): ``theta`` from +y (row 0 looks up), ``phi = atan2(z, x)``
increasing with the column, minus the map's rotation about +y. The map is piecewise constant per pixel
(nearest lookup), and sampling picks a pixel with probability proportional to ``luminance * sin(theta)`` at the
pixel centre, then a uniform point in ``(u, v)`` inside it. The density per unit solid angle is then exactly
``p_pixel * W * H / (2 pi^2 sin(theta))`` at the sampled point, and :meth:`EnvironmentMap.pdf` returns it for
any direction, so MIS weights use the true density.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.brdf import LUMINANCE
from core.fastmath import acos_estimate, atan2_estimate, sincos_small
from core.sampling.distributions import fill_guide, remainder, uniform_sphere, walk_upper_bound

INV_FOUR_PI = 1.0 / (4.0 * math.pi)


class ConstantEnvironment:
    """Radiance ``L`` from every direction; light sampling is uniform over the sphere."""

    def __init__(self, radiance: tuple[float, float, float]):
        self.radiance = np.asarray(radiance, dtype=np.float64)

    @property
    def power_weight(self) -> float:
        return float(self.radiance @ LUMINANCE)

    def eval(self, d: np.ndarray) -> np.ndarray:
        return np.broadcast_to(self.radiance, (len(d), 3)).copy()

    def lookup(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.eval(d), self.pdf(d)

    def pdf(self, d: np.ndarray) -> np.ndarray:
        return np.full(len(d), INV_FOUR_PI)

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``u (n, 2)`` uniforms -> directions ``(n, 3)``, radiance ``(n, 3)``, pdf per solid angle ``(n,)``."""
        z = 1.0 - 2.0 * u[:, 0]
        r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
        phi = 2.0 * np.pi * u[:, 1]
        d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
        return d, self.eval(d), self.pdf(d)


class EnvironmentMap:
    """An equirectangular HDR image ``(h, w, 3)`` (linear RGB), scaled and rotated about +y."""

    def __init__(self, image: np.ndarray, scale: float = 1.0, rotate_deg: float = 0.0):
        img = np.asarray(image, dtype=np.float64)[..., :3] * float(scale)
        if img.ndim != 3 or img.shape[0] < 1 or img.shape[1] < 1:
            raise ValueError("an environment map is an (h, w, 3) image")
        self.image = np.maximum(img, 0.0)
        self.h, self.w = self.image.shape[:2]
        self.rotation = math.radians(rotate_deg) % (2.0 * math.pi)  # in [0, 2 pi): env_eval_one relies on it
        theta_c = (np.arange(self.h) + 0.5) / self.h * np.pi
        weight = (self.image @ LUMINANCE) * np.sin(theta_c)[:, None]
        total = float(weight.sum())
        if total <= 0.0:  # a black map: nothing to sample; pdf 0 everywhere and BRDF sampling alone
            self._pixel_pmf = np.zeros((self.h, self.w))
            self._row_cdf = np.linspace(0.0, 1.0, self.h + 1)[1:]
            self._col_cdf = np.tile(np.linspace(0.0, 1.0, self.w + 1)[1:], (self.h, 1))
            self._col_cdf_flat = (self._col_cdf + np.arange(self.h)[:, None]).ravel()
        else:
            self._pixel_pmf = weight / total
            rows = self._pixel_pmf.sum(axis=1)
            self._row_cdf = np.cumsum(rows)
            self._row_cdf /= self._row_cdf[-1]
            cond = np.where(
                rows[:, None] > 0, self._pixel_pmf / np.where(rows > 0, rows, 1.0)[:, None], 1.0 / self.w
            )
            self._col_cdf = np.cumsum(cond, axis=1)
            self._col_cdf /= self._col_cdf[:, -1:]
        # each row's CDF shifted by its row index: one searchsorted finds the column for every sample
        self._col_cdf_flat = (self._col_cdf + np.arange(self.h)[:, None]).ravel()
        self._guide = guide_table(self._row_cdf, self._col_cdf_flat, self.h, self.w)
        self._edges = pixel_edges(self.h, self.w, self.rotation)
        self._total = total
        # mean radiance over the sphere (solid-angle weighted), for choosing between light types
        solid = np.sin(theta_c)[:, None] * (2 * np.pi / self.w) * (np.pi / self.h)
        self.mean_radiance = (self.image * solid[..., None]).sum(axis=(0, 1)) / (4 * np.pi)

    @property
    def power_weight(self) -> float:
        return float(self.mean_radiance @ LUMINANCE)

    def lookup(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Radiance ``(n, 3)`` and pdf per solid angle ``(n,)`` of world directions ``d (n, 3)``."""
        return _env_lookup(
            np.ascontiguousarray(d, dtype=np.float64), self._pixel_pmf, self.image, self.rotation, self._edges
        )

    def eval(self, d: np.ndarray) -> np.ndarray:
        return self.lookup(d)[0]

    def pdf(self, d: np.ndarray) -> np.ndarray:
        return self.lookup(d)[1]

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``u (n, 2)`` uniforms -> directions ``(n, 3)``, radiance ``(n, 3)``, pdf per solid angle ``(n,)``
        (further columns are ignored: the point inside the pixel comes from the first two, see
        :func:`env_sample_one`)."""
        return _env_sample(
            np.ascontiguousarray(u, dtype=np.float64),
            self._row_cdf,
            self._col_cdf_flat,
            self._guide,
            self._pixel_pmf,
            self.image,
            self.rotation,
            self._edges,
        )


INV_2PI2 = 1.0 / (2.0 * math.pi * math.pi)
TWO_PI = 2.0 * math.pi
ENV_NONE, ENV_CONSTANT, ENV_MAP = 0, 1, 2
"""Kinds of sky for the compiled wavefront (:func:`env_eval_one`, :func:`env_sample_one`,
:func:`renderer.stages.records.sky_record`)."""


def guide_table(row_cdf: np.ndarray, col_cdf_flat: np.ndarray, h: int, w: int) -> np.ndarray:
    """Where the searches of the sky's CDFs start (int32, ``h + h * w`` entries): entry ``j < h`` is the
    row whose CDF first exceeds ``j / h``; entry ``h + r * w + j`` the position in ``col_cdf_flat`` of row
    ``r``'s first column whose CDF exceeds ``j / w``. A uniform ``u`` then starts at entry ``int(u * h)``
    (or ``int(u * w)``) and :func:`~core.sampling.distributions.walk_upper_bound` walks on average about one
    element from there (:func:`~core.sampling.distributions.fill_guide` builds each part)."""
    guide = np.empty(h + h * w, dtype=np.int32)
    fill_guide(row_cdf, 0, h, 0.0, h, guide[:h])
    for r in range(h):
        fill_guide(col_cdf_flat, r * w, w, float(r), w, guide[h + r * w : h + (r + 1) * w])
    return guide


def pixel_edges(h: int, w: int, rotation: float) -> np.ndarray:
    """The map's pixel edges for :func:`env_eval_one` and :func:`env_sample_one`: ``cos(k pi / h)`` for the
    ``h + 1`` row edges (``theta = k pi / h``), then the cosines and the sines of the ``w`` column edges'
    azimuths (``phi = rotation + 2 pi j / w``), then ``sin(k pi / h)`` for the row edges."""
    beta = rotation + TWO_PI * np.arange(w) / w
    theta = np.arange(h + 1) * math.pi / h
    return np.concatenate([np.cos(theta), np.cos(beta), np.sin(beta), np.sin(theta)])


SMALL_ANGLE_ROWS, SMALL_ANGLE_COLUMNS = 32, 64
"""Maps with at least this many rows and columns (pixels at most pi / 32 ~ 0.098 rad on a side) place a sample
inside its pixel by angle addition from the pixel's edges (:func:`core.fastmath.sincos_small`); smaller maps call ``sin``
and ``cos``."""


# env_eval_one and env_sample_one run once per ray in the wavefront's loops: each has a single return (an
# inlined function with several returns makes numba keep a reference count on every array argument per call,
# atomic increments that the two threads contend for) and no Python-semantics float modulo (a library call).


@njit(inline="always", nogil=True, cache=True)
def env_eval_one(kind, dx, dy, dz, radiance, pmf, image, rotation, edges):
    """Radiance ``(r, g, b)`` from world direction ``d`` and the sky's light-sampling pdf per solid angle.
    ``rotation`` in ``[0, 2 pi)`` (:func:`renderer.stages.records.sky_record`), ``edges`` from
    :func:`pixel_edges`.

    The pixel is the one of ``theta = acos(d_y)`` and ``phi = atan2(d_z, d_x) - rotation`` without either
    function: a polynomial guess of each, then a walk to the row whose edges' cosines bracket ``d_y`` and
    to the column whose edge directions bracket ``(d_x, d_z)`` (the sign of a cross product). The walk is
    exact from any guess, so the pixel is the one the angles give (but within rounding of an edge); the two
    library calls cost 60 % of the lookup (38 of 61 ns)."""
    r, g, b, pdf = 0.0, 0.0, 0.0, 0.0
    if kind == ENV_CONSTANT:
        r, g, b, pdf = radiance[0], radiance[1], radiance[2], INV_FOUR_PI
    elif kind == ENV_MAP:
        h, w = pmf.shape
        cos_t = min(1.0, max(-1.0, dy))
        # the row: the number of edges k in 1 .. h - 1 with cos_t <= cos(k pi / h)
        row = max(0, min(int(acos_estimate(cos_t) / math.pi * h), h - 1))
        while row > 0 and cos_t > edges[row]:
            row -= 1
        while row < h - 1 and cos_t <= edges[row + 1]:
            row += 1
        if dx == 0.0 and dz == 0.0:  # a pole: the azimuth atan2 gives (0 or pi, by the zeros' signs)
            phi = math.atan2(dz, dx) - rotation
        else:
            phi = atan2_estimate(dz, dx) - rotation  # in [-3 pi, pi]
        if phi < 0.0:
            phi += TWO_PI
        if phi < 0.0:
            phi += TWO_PI
        col = max(0, min(int(phi / TWO_PI * w), w - 1))
        if dx != 0.0 or dz != 0.0:
            # the column j with d at or past edge j and before edge j + 1 (cyclic; one step or two)
            cx, cz = h + 1, h + 1 + w
            for _ in range(w):
                if edges[cx + col] * dz - edges[cz + col] * dx < 0.0:
                    col = col - 1 if col > 0 else w - 1
                    continue
                nxt = col + 1 if col < w - 1 else 0
                if w > 1 and edges[cx + nxt] * dz - edges[cz + nxt] * dx >= 0.0:
                    col = nxt
                    continue
                break
        # sin(theta) from the other two components: near a pole 1 - d_y^2 keeps only the few bits d_y has
        # left (4e-9 relative off at 0.02 degrees from it), d_x^2 + d_z^2 all of them
        sin_t = math.sqrt(dx * dx + dz * dz)
        if sin_t > 1e-12:
            pdf = pmf[row, col] * (w * h) * INV_2PI2 / sin_t
        r, g, b = image[row, col, 0], image[row, col, 1], image[row, col, 2]
    return r, g, b, pdf


@njit(inline="always", nogil=True, cache=True)
def env_sample_one(kind, u0, u1, radiance, row_cdf, col_cdf_flat, guide, pmf, image, rotation, edges):
    """A direction from the sky's light sampling: ``(dx, dy, dz, r, g, b, pdf)`` (pdf per solid angle); the
    CDF searches start from the ``guide`` table's entries (:func:`guide_table`). The point inside the chosen
    pixel comes from the same two uniforms: ``u2``, ``u3`` are where ``u0`` and ``u1`` fell inside the row's
    and the column's CDF intervals, rescaled to ``[0, 1]`` (uniform and independent of the pixel's choice, as
    pbrt's piecewise-constant distributions do it), so a stratified pair stays stratified inside the pixels
    and no further random number is drawn. The point ``theta = (row + u2) pi / h``, ``phi = rotation + (col +
    u3) 2 pi / w`` is placed by angle addition from the pixel's edges
    (``edges``, :func:`pixel_edges`) and the sine and cosine of the small offsets, on maps of at least
    ``SMALL_ANGLE_ROWS x SMALL_ANGLE_COLUMNS`` pixels (four ``sin``/``cos`` calls cost ~35 of a sample's ~75
    ns; the directions differ from theirs in the last bits)."""
    dx, dy, dz, r, g, b, pdf = 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0
    if kind == ENV_CONSTANT:
        dx, dy, dz = uniform_sphere(u0, u1)
        r, g, b, pdf = radiance[0], radiance[1], radiance[2], INV_FOUR_PI
    elif kind == ENV_MAP:
        h, w = pmf.shape
        row = min(walk_upper_bound(row_cdf, 0, h, u0, guide[min(int(u0 * h), h - 1)]), h - 1)
        # row r's column CDF is stored shifted by r: search that row's segment only
        start = guide[h + row * w + min(int(u1 * w), w - 1)]
        col = min(walk_upper_bound(col_cdf_flat, row * w, w, row + u1, start) - row * w, w - 1)
        lo = row_cdf[row - 1] if row > 0 else 0.0
        u2 = remainder(u0, lo, row_cdf[row])
        lo = col_cdf_flat[row * w + col - 1] if col > 0 else float(row)
        u3 = remainder(row + u1, lo, col_cdf_flat[row * w + col])
        if h >= SMALL_ANGLE_ROWS and w >= SMALL_ANGLE_COLUMNS:
            se, ce = sincos_small(u2 / h * math.pi)
            sp, cp = sincos_small(u3 / w * TWO_PI)
            ct, st = edges[row], edges[h + 1 + 2 * w + row]  # the row's upper edge
            cb, sb = edges[h + 1 + col], edges[h + 1 + w + col]  # the column's first edge
            s = st * ce + ct * se
            cos_t = ct * ce - st * se
            cos_p = cb * cp - sb * sp
            sin_p = sb * cp + cb * sp
        else:
            theta = (row + u2) / h * math.pi
            phi = (col + u3) / w * TWO_PI + rotation
            s = math.sin(theta)
            cos_t, cos_p, sin_p = math.cos(theta), math.cos(phi), math.sin(phi)
        if s > 1e-12:
            pdf = pmf[row, col] * (w * h) * INV_2PI2 / s
        dx, dy, dz = s * cos_p, cos_t, s * sin_p
        r, g, b = image[row, col, 0], image[row, col, 1], image[row, col, 2]
    return dx, dy, dz, r, g, b, pdf


@njit(nogil=True, cache=True)
def _env_lookup(d, pmf, image, rotation, edges):
    n = d.shape[0]
    le = np.empty((n, 3))
    pdf = np.empty(n)
    none = np.zeros(3)
    for i in range(n):
        le[i, 0], le[i, 1], le[i, 2], pdf[i] = env_eval_one(ENV_MAP, d[i, 0], d[i, 1], d[i, 2], none, pmf,
                                                            image, rotation, edges)  # fmt: skip
    return le, pdf


@njit(nogil=True, cache=True)
def _env_sample(u, row_cdf, col_cdf_flat, guide, pmf, image, rotation, edges):
    n = u.shape[0]
    d = np.empty((n, 3))
    le = np.empty((n, 3))
    pdf = np.empty(n)
    none = np.zeros(3)
    for i in range(n):
        d[i, 0], d[i, 1], d[i, 2], le[i, 0], le[i, 1], le[i, 2], pdf[i] = env_sample_one(
            ENV_MAP, u[i, 0], u[i, 1], none, row_cdf, col_cdf_flat, guide, pmf, image, rotation, edges
        )
    return d, le, pdf


def load_environment(env, scene):  # type: ignore[no-untyped-def]
    """The renderer's environment for a scene's ``environment`` entry (``None`` for a black sky)."""
    from core.scene import ConstantEnvironment as ConstantSpec
    from core.scene import MapEnvironment as MapSpec
    from renderer.image_io import read_exr

    if env is None:
        return None
    if isinstance(env, ConstantSpec):
        return ConstantEnvironment(env.radiance) if max(env.radiance) > 0 else None
    if isinstance(env, MapSpec):
        from core.errors import BrdfStudioError

        try:
            img = read_exr(scene.resolve(env.path))
        except BrdfStudioError as exc:
            raise scene.error("environment.path", str(exc)) from None
        return EnvironmentMap(img, env.scale, env.rotate_deg)
    raise TypeError(f"unknown environment {env!r}")
