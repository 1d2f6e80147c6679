"""Directions in the local shading frame (z = normal) and the unit-disk projection.

The seed's sampler works on the unit disk: a direction ``v`` maps to ``(v.x, v.y)``. Disk area is the
projected solid angle, ``dx dy = cos(theta) d(omega)``, so ``pdf_solid_angle = pdf_disk * cos(theta)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


def spherical_to_dir(theta: np.ndarray | float, phi: np.ndarray | float = 0.0) -> np.ndarray:
    """Unit vectors from polar angle ``theta`` and azimuth ``phi`` (radians); shape ``(..., 3)``."""
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    s = np.sin(theta)
    return np.stack(np.broadcast_arrays(s * np.cos(phi), s * np.sin(phi), np.cos(theta)), axis=-1)


def dir_to_spherical(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(theta, phi)`` of unit vectors ``w (..., 3)``; ``phi`` in ``[0, 2 pi)``."""
    w = np.asarray(w, dtype=np.float64)
    theta = np.arccos(np.clip(w[..., 2], -1.0, 1.0))
    phi = np.mod(np.arctan2(w[..., 1], w[..., 0]), 2.0 * np.pi)
    return theta, phi


def degrees_to_dir(theta_deg: float, phi_deg: float = 0.0) -> np.ndarray:
    """A unit vector ``(3,)`` from angles in degrees; theta = 90 gives an exactly grazing direction."""
    t = math.radians(theta_deg)
    p = math.radians(phi_deg)
    z = 0.0 if theta_deg == 90.0 else math.cos(t)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), z])


def reflect(w: np.ndarray) -> np.ndarray:
    """Mirror direction of ``w (..., 3)`` about the normal z."""
    w = np.asarray(w, dtype=np.float64)
    return w * np.array([-1.0, -1.0, 1.0])


@njit(inline="always", nogil=True, cache=True)
def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(inline="always", nogil=True, cache=True)
def normalize(a):
    n = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    if n == 0.0:
        return (0.0, 0.0, 1.0)
    return (a[0] / n, a[1] / n, a[2] / n)


@njit(inline="always", nogil=True, cache=True)
def half_vector(wi, wo):
    """Normalized ``wi + wo``; the normal when the two are opposite (a measure-zero case)."""
    return normalize((wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]))


@njit(inline="always", nogil=True, cache=True)
def mirror(w):
    """Mirror direction about the normal z: ``2 (w.n) n - w``."""
    return (-w[0], -w[1], w[2])


@njit(inline="always", nogil=True, cache=True)
def to_frame(v, t, b, n):
    """Express world vector ``v`` in the frame with axes ``t, b, n``."""
    return (dot(v, t), dot(v, b), dot(v, n))


@njit(inline="always", nogil=True, cache=True)
def from_frame(v, t, b, n):
    """Map local vector ``v`` in frame ``t, b, n`` back to world coordinates."""
    return (
        v[0] * t[0] + v[1] * b[0] + v[2] * n[0],
        v[0] * t[1] + v[1] * b[1] + v[2] * n[1],
        v[0] * t[2] + v[1] * b[2] + v[2] * n[2],
    )


@njit(inline="always", nogil=True, cache=True)
def basis(n):
    """An orthonormal ``(t, b)`` completing unit vector ``n`` (Duff et al. 2017, branchless)."""
    sign = 1.0 if n[2] >= 0.0 else -1.0
    a = -1.0 / (sign + n[2])
    bb = n[0] * n[1] * a
    t = (1.0 + sign * n[0] * n[0] * a, sign * bb, -sign * n[0])
    b = (bb, sign + n[1] * n[1] * a, -n[1])
    return t, b
