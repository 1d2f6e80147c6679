"""Distant illumination in the local frame, for studying estimators of reflected radiance.

``L_r(wo) = integral of f(wi, wo) L(wi) cos(theta_i) d(omega_i)`` over the upper hemisphere. Each light
gives ``radiance(wi) (n,)`` (scalar, white light), and can be sampled with an exact density so that
light sampling and resampling (RIS) have a proposal of their own.
"""

from __future__ import annotations

import math

import numpy as np

from core.sampling.distributions import build_cdf, find_intervals

TWO_PI = 2.0 * math.pi


class Furnace:
    """Constant unit radiance from every direction: ``L_r`` is the directional albedo."""

    name = "furnace"

    def radiance(self, wi: np.ndarray) -> np.ndarray:
        return np.ones(len(wi))


class CapLight:
    """A small bright disk light: constant ``radiance`` inside the cone of ``half_angle`` about ``axis``."""

    name = "small_light"

    def __init__(self, axis: np.ndarray, half_angle: float, radiance: float):
        self.axis = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
        self.cos_max = math.cos(half_angle)
        self.level = float(radiance)

    def radiance(self, wi: np.ndarray) -> np.ndarray:
        return np.where(wi @ self.axis >= self.cos_max, self.level, 0.0)

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Uniform directions in the cone and their density per solid angle."""
        u = rng.random((n, 2))
        cos_t = 1.0 - u[:, 0] * (1.0 - self.cos_max)
        sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
        phi = TWO_PI * u[:, 1]
        local = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=-1)
        t = np.cross(self.axis, [1.0, 0.0, 0.0] if abs(self.axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        t /= np.linalg.norm(t)
        b = np.cross(self.axis, t)
        wi = local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * self.axis
        return wi, np.full(n, 1.0 / (TWO_PI * (1.0 - self.cos_max)))


class LatLongEnvironment:
    """An HDR environment map in latitude-longitude layout, ``image (h, w)`` of radiance; row 0 is the
    zenith (z = +1), columns run over ``phi`` in ``[0, 2 pi)``. Piecewise constant per pixel."""

    name = "environment"

    def __init__(self, image: np.ndarray):
        self.image = np.asarray(image, dtype=np.float64)
        h, w = self.image.shape
        theta_edges = np.linspace(0.0, math.pi, h + 1)
        self.pixel_solid = (np.cos(theta_edges[:-1]) - np.cos(theta_edges[1:])) * (TWO_PI / w)
        self.cdf = build_cdf(self.image * self.pixel_solid[:, None])
        self.theta_edges = theta_edges

    @staticmethod
    def procedural_sky(
        width: int = 128, height: int = 64, sun_theta: float = 0.6, sun_phi: float = 3.5
    ) -> np.ndarray:
        """A bright small sun, a blue-ish sky gradient and a dim ground: strong dynamic range."""
        theta = (np.arange(height) + 0.5) / height * math.pi
        phi = (np.arange(width) + 0.5) / width * TWO_PI
        t, p = np.meshgrid(theta, phi, indexing="ij")
        w = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
        sun = np.array(
            [
                math.sin(sun_theta) * math.cos(sun_phi),
                math.sin(sun_theta) * math.sin(sun_phi),
                math.cos(sun_theta),
            ]
        )
        cos_sun = w @ sun
        sky = np.where(w[..., 2] > 0, 0.4 + 0.6 * w[..., 2], 0.05)
        return sky + 2000.0 * (cos_sun > math.cos(0.06)) + 5.0 * np.exp((cos_sun - 1.0) * 30.0)

    def pixel(self, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The row and column of the pixel each direction of ``wi`` (n, 3) falls in, as two (n,) int arrays."""
        h, w = self.image.shape
        theta = np.arccos(np.clip(wi[:, 2], -1.0, 1.0))
        phi = np.mod(np.arctan2(wi[:, 1], wi[:, 0]), TWO_PI)
        r = np.minimum((theta / math.pi * h).astype(int), h - 1)
        c = np.minimum((phi / TWO_PI * w).astype(int), w - 1)
        return r, c

    def radiance(self, wi: np.ndarray) -> np.ndarray:
        r, c = self.pixel(wi)
        return self.image[r, c]

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Pixels by radiance times solid angle, uniform in solid angle inside the pixel; exact pdf."""
        h, w = self.image.shape
        u = rng.random((n, 3))
        k = np.empty(n, dtype=np.int64)
        find_intervals(self.cdf, u[:, 0], k)
        r, c = np.divmod(k, w)
        c0, c1 = np.cos(self.theta_edges[r]), np.cos(self.theta_edges[r + 1])
        cos_t = c0 + u[:, 1] * (c1 - c0)
        phi = (c + u[:, 2]) * TWO_PI / w
        sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
        wi = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=-1)
        return wi, self.pdf(wi)

    def pdf(self, wi: np.ndarray) -> np.ndarray:
        r, c = self.pixel(wi)
        k = r * self.image.shape[1] + c
        return (self.cdf[k + 1] - self.cdf[k]) / self.pixel_solid[r]
