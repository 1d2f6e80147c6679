"""Whether our float64 value of a BRDF Explorer shader agrees with Mesa's float32 one (:mod:`app.shader_oracle`).

Per value (a pair of directions, one channel), pairs with L or V below the horizon left out (the host returns
0 there)::

    |ours - mesa| <= RELATIVE_TOLERANCE · max(|ours|, |mesa|) + rounding bound + ABSOLUTE_FLOOR

- ``ours`` is evaluated at the float32-rounded directions and parameters Mesa sees, so the rounding of the
  inputs is no part of the difference.
- The rounding bound (:func:`float32_propagation_bound`) is how far the value moves when one quantity a shader
  computes is off by ``u = ULPS · 2^-24``: each direction component and parameter scaled by ``1 ± u``, each
  cosine a BRDF is built from (L, V and the half vector H against N, X, Y; L against H) moved by ``± u``
  (first order), and each direction turned by ``sqrt(2u)``, which moves a cosine at its extremum by ``u``
  (second order: half the symmetric difference). It is large where float32 cannot do better: ``pow`` of a
  large exponent, a narrow lobe at its peak, a difference of nearly equal terms of the directions.
- ``ABSOLUTE_FLOOR``, ``u`` itself: a value a shader forms as a difference of terms of order one
  (``1 - exp(-x)``, ``1 - cos``) keeps only their absolute precision; it also covers llvmpipe's flush of
  subnormal intermediates to zero.

NaN agrees with NaN. A NaN on one side only agrees when it comes from rounding: that side is finite at one of
the direction moves (Mesa is run again at them), as a float32 ``dot(L, H)`` of 1 + 2^-23 makes
``pow(1 - dot(L, H), 5)`` NaN at L = V. The reasoning and the measurements: ``docs/model-files.md``, "How
imported shaders are checked".
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.shader_oracle import ParamKind, evaluate_glsl, uniform_value

RELATIVE_TOLERANCE = 1e-5
"""The target: our value within this fraction of the larger of the two."""
ULPS = 4
"""Units of float32 rounding (2^-24) by which each quantity of the rounding bound is moved: a few operations'
rounding, and Mesa's ``pow`` (about 2·n units for an exponent n: 2 units on the base)."""
UNIT_ROUNDOFF = 2.0**-24
ABSOLUTE_FLOOR = ULPS * UNIT_ROUNDOFF
"""``ULPS`` units of 1.0."""

Evaluate = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
"""Ours: ``(L (n, 3), V (n, 3), p (k,)) -> (n, 3) float64``."""
Pair = tuple[np.ndarray, np.ndarray]
_FRAME = np.eye(3)
"""X, Y and N of the host's frame."""


@dataclass(frozen=True)
class Agreement:
    """How our values agree with Mesa's over the pairs above the horizon (three channels each).

    ``max_rel_error`` is ``max |ours - mesa| / max(|ours|, |mesa|)`` over the values both finite and above
    ``ABSOLUTE_FLOOR`` (below it, float32 keeps no relative precision to speak of);
    ``worst_ratio`` is the largest difference over what is allowed (``<= 1`` passes). ``nan_by_rounding``
    counts the NaNs on one side that rounding explains; ``nan_ours_only`` and ``nan_mesa_only`` the others,
    which fail. ``failures`` counts every value that fails.
    """

    values: int
    max_rel_error: float
    worst_ratio: float
    nan_both: int
    nan_by_rounding: int
    nan_ours_only: int
    nan_mesa_only: int
    failures: int

    @property
    def passed(self) -> bool:
        return self.failures == 0


def float32_inputs(a: np.ndarray) -> np.ndarray:
    """``a`` rounded to float32 and back to float64: the inputs as Mesa sees them."""
    return np.asarray(a, dtype=np.float32).astype(np.float64)


def parameter_vector(params: Sequence[tuple[ParamKind, str, Any]]) -> tuple[np.ndarray, list[int]]:
    """The parameter vector ``(k,) float64`` in declaration order (a float one slot, a colour three, a bool
    one: 0 or 1), and the indices of its real-valued slots (the floats' and colours')."""
    values: list[float] = []
    real: list[int] = []
    for kind, name, value in params:
        item = uniform_value(kind, name, value)
        items = item if isinstance(item, tuple) else (float(item),)
        if kind != "bool":
            real += range(len(values), len(values) + len(items))
        values += items
    return np.array(values, dtype=np.float64), real


def agreement_with_oracle(
    evaluate: Evaluate,
    shader: str,
    params: Sequence[tuple[ParamKind, str, Any]],
    L: np.ndarray,
    V: np.ndarray,
    *,
    source_name: str = "shader",
    first_line: int = 1,
) -> Agreement:
    """Our evaluation of ``shader`` against Mesa's, at the parameter values of ``params``.

    ``evaluate(L, V, p)`` is ours (``p`` laid out as :func:`parameter_vector` does). Raises what
    :func:`~app.shader_oracle.evaluate_glsl` raises.
    """
    mesa = evaluate_glsl(shader, params, L, V, source_name=source_name, first_line=first_line)
    lights, views = float32_inputs(L), float32_inputs(V)
    p, real = parameter_vector(params)
    p = float32_inputs(p)
    ours = evaluate(lights, views, p)
    bound = float32_propagation_bound(evaluate, lights, views, p, real)

    def mesa_at(moved_L: np.ndarray, moved_V: np.ndarray) -> np.ndarray:
        return evaluate_glsl(shader, params, moved_L, moved_V, source_name=source_name, first_line=first_line)

    explained = nan_from_rounding(lambda a, b: evaluate(a, b, p), mesa_at, ours, mesa, lights, views)
    return compare(ours, mesa, bound, lights, views, explained)


def compare(
    ours: np.ndarray,
    mesa: np.ndarray,
    bound: np.ndarray,
    L: np.ndarray,
    V: np.ndarray,
    nan_explained: np.ndarray | None = None,
) -> Agreement:
    """The agreement of ``ours`` with ``mesa`` (see the module docstring).

    Parameters
    ----------
    ours, mesa, bound : (n, 3)
        ``bound`` is :func:`float32_propagation_bound` at the inputs of ``ours``.
    L, V : (n, 3)
        Pairs with ``L_z <= 0`` or ``V_z <= 0`` are left out.
    nan_explained : (n, 3) bool, optional
        One-sided NaNs that rounding explains (:func:`nan_from_rounding`); none if omitted.
    """
    above = (np.asarray(L)[:, 2] > 0.0) & (np.asarray(V)[:, 2] > 0.0)
    a = np.asarray(ours, dtype=np.float64)[above]
    b = np.asarray(mesa, dtype=np.float64)[above]
    extra = np.asarray(bound, dtype=np.float64)[above]
    explained = np.zeros(a.shape, dtype=bool) if nan_explained is None else np.asarray(nan_explained)[above]
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    finite_pair = ~nan_a & ~nan_b
    with np.errstate(invalid="ignore", over="ignore"):
        diff = np.where(np.isinf(a) & (a == b), 0.0, np.abs(a - b))
        scale = np.fmax(np.abs(a), np.abs(b))
        allowed = RELATIVE_TOLERANCE * scale + np.where(np.isnan(extra), np.inf, extra) + ABSOLUTE_FLOOR
        rel = np.where(diff == 0.0, 0.0, diff / np.where(scale > 0.0, scale, 1.0))
        ratio = np.where(diff == 0.0, 0.0, diff / allowed)
        ratio = np.where(np.isinf(allowed) & np.isfinite(diff), 0.0, ratio)
    within = finite_pair & (diff <= allowed)
    one_sided = nan_a ^ nan_b
    measurable = finite_pair & (scale > ABSOLUTE_FLOOR)
    return Agreement(
        values=int(a.size),
        max_rel_error=float(np.max(rel[measurable])) if measurable.any() else 0.0,
        worst_ratio=float(np.max(ratio[finite_pair])) if finite_pair.any() else 0.0,
        nan_both=int(np.count_nonzero(nan_a & nan_b)),
        nan_by_rounding=int(np.count_nonzero(one_sided & explained)),
        nan_ours_only=int(np.count_nonzero(nan_a & ~nan_b & ~explained)),
        nan_mesa_only=int(np.count_nonzero(~nan_a & nan_b & ~explained)),
        failures=int(np.count_nonzero(finite_pair & ~within) + np.count_nonzero(one_sided & ~explained)),
    )


def float32_propagation_bound(
    evaluate: Evaluate,
    L: np.ndarray,
    V: np.ndarray,
    p: np.ndarray,
    perturbable: Iterable[int],
    ulps: float = ULPS,
) -> np.ndarray:
    """How far float32 rounding may move the value: the sum over the moves of the module docstring of
    ``max(|f(+) - f|, |f(-) - f|)`` (first order) or ``|f(+) + f(-) - 2 f| / 2`` (second order). A moved
    value that is NaN (a step outside a function's domain) is not counted.

    Parameters
    ----------
    evaluate : callable (L (n, 3), V (n, 3), p (k,)) -> (n, 3) float64
    L, V : (n, 3) float64, unit vectors
    p : (k,) float64
    perturbable : the indices of ``p`` that are real numbers (floats and colours, not bools)

    Returns
    -------
    (n, 3) float64
    """
    L = np.asarray(L, dtype=np.float64)
    V = np.asarray(V, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    u = ulps * UNIT_ROUNDOFF
    base = evaluate(L, V, p)
    bound = np.zeros_like(base)

    def change(value: np.ndarray) -> np.ndarray:
        step = value - base
        return np.where(np.isnan(step), 0.0, step)

    with np.errstate(invalid="ignore", over="ignore"):
        for j in perturbable:
            if p[j] != 0.0:
                q_plus, q_minus = p.copy(), p.copy()
                q_plus[j] *= 1.0 + u
                q_minus[j] *= 1.0 - u
                bound += np.fmax(
                    np.abs(change(evaluate(L, V, q_plus))), np.abs(change(evaluate(L, V, q_minus)))
                )
        for (L_plus, V_plus), (L_minus, V_minus) in _first_order_moves(L, V, u):
            bound += np.fmax(
                np.abs(change(evaluate(L_plus, V_plus, p))), np.abs(change(evaluate(L_minus, V_minus, p)))
            )
        for (L_plus, V_plus), (L_minus, V_minus) in _second_order_moves(L, V, u):
            bound += 0.5 * np.abs(change(evaluate(L_plus, V_plus, p)) + change(evaluate(L_minus, V_minus, p)))
    return np.where(np.isinf(bound), np.inf, bound)


def nan_from_rounding(
    ours_at: Callable[[np.ndarray, np.ndarray], np.ndarray],
    mesa_at: Callable[[np.ndarray, np.ndarray], np.ndarray],
    ours: np.ndarray,
    mesa: np.ndarray,
    L: np.ndarray,
    V: np.ndarray,
    ulps: float = ULPS,
) -> np.ndarray:
    """The one-sided NaNs ``(n, 3) bool`` that rounding explains: the NaN side is finite at one of the
    direction moves of :func:`float32_propagation_bound` (only the rows with such a NaN are evaluated again)."""
    one_sided = np.isnan(ours) ^ np.isnan(mesa)
    explained = np.zeros(one_sided.shape, dtype=bool)
    rows = np.flatnonzero(one_sided.any(axis=1))
    if rows.size == 0:
        return explained
    moved = [
        pair
        for plus, minus in _all_direction_moves(L[rows], V[rows], ulps * UNIT_ROUNDOFF)
        for pair in (plus, minus)
    ]
    moved_L = np.concatenate([m[0] for m in moved])
    moved_V = np.concatenate([m[1] for m in moved])
    shape = (len(moved), rows.size, 3)
    with np.errstate(invalid="ignore", over="ignore"):
        ours_finite = np.isfinite(ours_at(moved_L, moved_V).reshape(shape)).any(axis=0)
        mesa_finite = np.isfinite(np.asarray(mesa_at(moved_L, moved_V), dtype=np.float64).reshape(shape)).any(
            axis=0
        )
    mesa_nan, ours_nan = np.isnan(mesa[rows]), np.isnan(ours[rows])
    explained[rows] = one_sided[rows] & ((mesa_nan & mesa_finite) | (ours_nan & ours_finite))
    return explained


def _all_direction_moves(L: np.ndarray, V: np.ndarray, u: float) -> Iterator[tuple[Pair, Pair]]:
    yield from _first_order_moves(L, V, u)
    yield from _second_order_moves(L, V, u)


def _first_order_moves(L: np.ndarray, V: np.ndarray, u: float) -> Iterator[tuple[Pair, Pair]]:
    """``((L+, V+), (L-, V-))`` for each first-order move: a component of L or V scaled by ``1 ± u``; the
    cosine of L, V or H with X, Y or N moved by ``± u`` (H's by turning L and V together); L·H moved by
    ``± u`` (L and V opened or closed about H)."""
    for i in range(3):
        yield (_scaled(L, i, 1.0 + u), V), (_scaled(L, i, 1.0 - u), V)
        yield (L, _scaled(V, i, 1.0 + u)), (L, _scaled(V, i, 1.0 - u))
    H = _normalized(L + V)
    for axis in _FRAME:
        yield (_tilted(L, axis, u), V), (_tilted(L, axis, -u), V)
        yield (L, _tilted(V, axis, u)), (L, _tilted(V, axis, -u))
        yield _turned_both(L, V, *_cosine_turn(H, axis, u)), _turned_both(L, V, *_cosine_turn(H, axis, -u))
    yield _opened(L, V, *_cosine_turn(L, H, u)), _opened(L, V, *_cosine_turn(L, H, -u))


def _second_order_moves(L: np.ndarray, V: np.ndarray, u: float) -> Iterator[tuple[Pair, Pair]]:
    """``((L+, V+), (L-, V-))`` for each second-order move, a turn by ``± sqrt(2u)`` (which moves a cosine at
    its extremum by ``u``): L, V, or both together, about two axes across each; L and V opened about H
    and twisted about H."""
    angle = np.full(len(L), np.sqrt(2.0 * u))
    H = _normalized(L + V)
    for axis in _two_axes_across(L):
        yield (_turn(L, axis, angle), V), (_turn(L, axis, -angle), V)
    for axis in _two_axes_across(V):
        yield (L, _turn(V, axis, angle)), (L, _turn(V, axis, -angle))
    for axis in _two_axes_across(H):
        yield _turned_both(L, V, axis, angle), _turned_both(L, V, axis, -angle)
    opening_axis = np.cross(H, L)
    parallel = np.linalg.norm(opening_axis, axis=1) < 1e-12
    opening_axis[parallel] = _across(H[parallel])
    opening_axis = _normalized(opening_axis)
    yield _opened(L, V, opening_axis, angle), _opened(L, V, opening_axis, -angle)
    yield _opened(L, V, H, angle), _opened(L, V, H, -angle)


def _scaled(w: np.ndarray, component: int, factor: float) -> np.ndarray:
    moved = w.copy()
    moved[:, component] *= factor
    return moved


def _tilted(w: np.ndarray, target: np.ndarray, dc: float) -> np.ndarray:
    """``w`` turned so that its cosine with ``target`` moves by ``dc``."""
    return _turn(w, *_cosine_turn(w, target, dc))


def _two_axes_across(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    first = _across(w)
    return first, _normalized(np.cross(w, first))


def _normalized(w: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(w, axis=1, keepdims=True)
    return w / np.where(length > 0.0, length, 1.0)


def _across(w: np.ndarray) -> np.ndarray:
    """A unit axis perpendicular to each row of ``w``: across N where it can be, else across X."""
    axis = np.cross(w, _FRAME[2])
    along = np.linalg.norm(axis, axis=1) < 1e-12
    axis[along] = np.cross(w[along], _FRAME[0])
    return _normalized(axis)


def _cosine_turn(w: np.ndarray, target: np.ndarray, dc: float) -> tuple[np.ndarray, np.ndarray]:
    """The turn (unit axis ``(n, 3)``, angle ``(n,)``) that moves the cosine of each ``w`` with ``target``
    (one vector, or one per row) by ``dc``, clipped to [-1, 1]."""
    target = np.broadcast_to(target, w.shape)
    cosine = np.clip(np.sum(w * target, axis=1), -1.0, 1.0)
    axis = np.cross(w, target)
    parallel = np.linalg.norm(axis, axis=1) < 1e-12
    axis[parallel] = _across(target[parallel])
    angle = np.arccos(cosine) - np.arccos(np.clip(cosine + dc, -1.0, 1.0))
    return _normalized(axis), angle


def _turn(w: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues' rotation of each row of ``w`` about the unit ``axis`` by ``angle`` (right-handed)."""
    c = np.cos(angle)[:, None]
    s = np.sin(angle)[:, None]
    return w * c + np.cross(axis, w) * s + axis * np.sum(axis * w, axis=1, keepdims=True) * (1.0 - c)


def _turned_both(L: np.ndarray, V: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> Pair:
    return _turn(L, axis, angle), _turn(V, axis, angle)


def _opened(L: np.ndarray, V: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> Pair:
    """L turned by ``angle`` and V by ``-angle`` about ``axis``: about ``H x L`` this opens the pair about
    their half vector, which stays; about ``H`` it twists them."""
    return _turn(L, axis, angle), _turn(V, axis, -angle)
