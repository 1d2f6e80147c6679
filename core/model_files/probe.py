"""What a model file computes, measured at load: its symmetries, and the directions where its values are not
a BRDF's (NaN, infinite or negative).

A shader declares no traits, so they are measured: a trait is kept when it holds to :data:`RTOL` on random
direction pairs at the defaults and at random parameter settings within the bounds (booleans flipped too), as
the adaptive sampler measures isotropy per material (:func:`core.sampling.adaptive.table.symmetry_of`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from core.brdf import Param, Traits
from core.model_files.call import eval_raw_rows

RTOL = 1e-8
"""Relative agreement for a symmetry to count as held (shaders compute in double precision)."""

PROBE_THETAS = (0.0, 10.0, 30.0, 50.0, 70.0, 85.0, 89.0, 89.9)
PROBE_PHIS = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)


def probe_directions() -> np.ndarray:
    """Upper-hemisphere directions ``(n, 3)``: :data:`PROBE_THETAS` x :data:`PROBE_PHIS` (normal once)."""
    rows = []
    for t in PROBE_THETAS:
        for ph in PROBE_PHIS if t > 0.0 else (0.0,):
            st, ct = math.sin(math.radians(t)), math.cos(math.radians(t))
            rows.append((st * math.cos(math.radians(ph)), st * math.sin(math.radians(ph)), ct))
    return np.array(rows)


def raw_values(row: np.ndarray, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """The file's own values ``(n, 3)`` for a kernel parameter row (header included)."""
    out = np.empty((len(wi), 3))
    eval_raw_rows(np.ascontiguousarray(wi), np.ascontiguousarray(wo), row, out)
    return out


def _angles(w: np.ndarray) -> str:
    theta = math.degrees(math.acos(max(-1.0, min(1.0, float(w[2])))))
    phi = math.degrees(math.atan2(float(w[1]), float(w[0]))) % 360.0
    return f"(theta {theta:g}, phi {phi:g})"


def bad_values(row: np.ndarray, label: str) -> list[str]:
    """One line for each kind of value that is not a BRDF's (NaN, infinite, negative) over every pair of
    :func:`probe_directions`, with the first pair where it occurs; empty when every value is fine."""
    d = probe_directions()
    n = len(d)
    wi, wo = np.repeat(d, n, axis=0), np.tile(d, (n, 1))
    f = raw_values(row, wi, wo)
    with np.errstate(invalid="ignore"):
        kinds = (("NaN", np.isnan(f)), ("infinite", np.isinf(f)), ("negative", f < 0.0))
    out = []
    for what, mask in kinds:
        bad = mask.any(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            out.append(
                f"{label} returns {what} values for {int(bad.sum())} of {len(bad)} direction pairs "
                f"(first at L {_angles(wi[i])}, V {_angles(wo[i])}); they are taken as 0"
            )
    return out


def _random_settings(params: tuple[Param, ...], rng: np.random.Generator, count: int) -> list[dict]:
    settings: list[dict] = [{}]
    for _ in range(count):
        values: dict = {}
        for p in params:
            if p.kind == "bool":
                values[p.name] = float(rng.integers(0, 2))
                continue
            draws = rng.uniform(p.lo, p.hi, 3)
            values[p.name] = tuple(float(v) for v in draws) if p.kind == "color" else float(draws[0])
        settings.append(values)
    return settings


def _upper(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    v[:, 2] = np.abs(v[:, 2]) + 1e-3
    return v / np.linalg.norm(v, axis=1)[:, None]


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.where(np.isfinite(a) & (a >= 0.0), a, 0.0)
    b = np.where(np.isfinite(b) & (b >= 0.0), b, 0.0)
    scale = max(float(np.max(np.abs(a))), 1e-300)
    return bool(np.all(np.abs(a - b) <= RTOL * np.maximum(np.abs(a), 1e-6 * scale)))


def measured_traits(
    params: tuple[Param, ...], row_of: Callable[[dict], np.ndarray], pairs: int = 256, settings: int = 6
) -> Traits:
    """The traits that hold at the defaults and at ``settings`` random parameter settings; ``row_of`` gives
    the kernel row (header included) of a setting."""
    rng = np.random.default_rng(20080627)
    wi, wo = _upper(rng, pairs), _upper(rng, pairs)
    angle = rng.uniform(0.0, 2.0 * math.pi, pairs)
    c, s = np.cos(angle), np.sin(angle)

    def turn(w: np.ndarray) -> np.ndarray:
        return np.stack([c * w[:, 0] - s * w[:, 1], s * w[:, 0] + c * w[:, 1], w[:, 2]], axis=1)

    mirror_x, mirror_y = np.array([-1.0, 1.0, 1.0]), np.array([1.0, -1.0, 1.0])
    held = {Traits.ISOTROPIC: True, Traits.RECIPROCAL: True, Traits.MIRROR_SYMMETRIC: True}
    for values in _random_settings(params, rng, settings):
        row = row_of(values)
        f = raw_values(row, wi, wo)
        held[Traits.ISOTROPIC] &= _same(f, raw_values(row, turn(wi), turn(wo)))
        held[Traits.RECIPROCAL] &= _same(f, raw_values(row, wo, wi))
        held[Traits.MIRROR_SYMMETRIC] &= _same(f, raw_values(row, wi * mirror_x, wo * mirror_x)) and _same(
            f, raw_values(row, wi * mirror_y, wo * mirror_y)
        )
    traits = Traits.NONE
    for trait, ok in held.items():
        if ok:
            traits |= trait
    return traits
