"""Fitting an analytic model's parameters to a measured material: weighted least squares on ``f cos``.

The residual of one measurement ``(wi, wo, f)`` and one colour channel is
``sqrt(w) * (T(f cos theta_i) - T(g_params cos theta_i))`` with ``g`` the model and ``T`` the metric:

* ``"log"``: ``T(x) = log(1 + x)`` (Löw et al. 2012 and most fits since: a peak of 100 and a diffuse floor of
  0.1 weigh alike, so the highlight's height does not drown its shape);
* ``"cbrt"``: ``T(x) = x^(1/3)`` (the cube-root metric, milder compression with the same intent).

**Where the measurements are** (:func:`measurements`): a fit compares the model with the data where the data
is *exact*, not with an interpolant:

* a MERL table: its cell centres (the writer's tabulation points; the trilinear lookup returns the stored
  value there), every ``theta_h``, every other ``theta_d`` and every fourth ``phi_d`` (182 250 cells, fewer
  missing or below the horizon);
* an RGL ``.bsdf`` file: the nodes of its sample grids — each node warped through the file's VNDF to a half
  vector, hence to ``wi`` — where the lookup returns the stored value;
* any other BRDF: the MERL cell centres, at four ``phi_h`` for an anisotropic model.

**Weights** make the sum approximate an integral over pairs of directions: ``w`` is each point's share of
``d wi d wo`` (``4 cos theta_d sin theta_h sin theta_d d theta_h d theta_d d phi_d`` on the Rusinkiewicz
grid, where ``phi_d`` in ``[0, pi)`` holds each pair once and its swap ``wi <-> wo`` not; the inverse of the
warp's density times the conditioning slice's solid angle on an RGL grid). Only their ratios matter.

**Optimizer**: ``scipy.optimize.least_squares`` (trust-region reflective, bounds from the parameter
declarations), parameters declared log-scale optimized by their logarithm, every float and colour parameter
free unless fixed by the caller (booleans are options, not fitted), started from the defaults and from
``starts - 1`` seeded random points in the bounds; the best end point wins.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from core.brdf import BRDF, Model, ParamValue, get_model
from core.errors import ParameterError

Metric = Literal["log", "cbrt"]
METRICS: tuple[str, ...] = ("log", "cbrt")


@dataclass(frozen=True)
class Measurements:
    """Direction pairs where a material is known, with its value and each pair's weight."""

    wi: np.ndarray
    """``(n, 3)`` incident directions (above the horizon)."""
    wo: np.ndarray
    """``(n, 3)`` outgoing directions (above the horizon)."""
    f: np.ndarray
    """``(n, 3)`` the material's ``f_r`` there (RGB)."""
    weight: np.ndarray
    """``(n,)`` share of ``d wi d wo`` (sums to about the measure of the pairs covered)."""


@dataclass
class FitResult:
    """A fitted model: its parameters, the residual and what it cost."""

    model: str
    params: dict[str, ParamValue]
    metric: str
    residual: float
    """Weighted RMS of the metric's residual over points and channels (0 for a perfect fit)."""
    relative_error: float
    """Weighted median of ``|g cos - f cos| / (f cos)`` over points with luminance above 1 % of the peak."""
    seconds: float
    evaluations: int
    points: int
    starts: list[dict[str, Any]] = field(default_factory=list)

    def brdf(self) -> BRDF:
        return get_model(self.model).bind(self.params)

    def material(self, name: str) -> dict[str, Any]:
        """A scene-file material of the fitted model (``{"name", "model", "params"}``)."""
        params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.params.items()}
        return {"name": name, "model": self.model, "params": params}


# --------------------------------------------------------------------------------------------- measurements


def _rusinkiewicz_pairs(
    ih: np.ndarray, jd: np.ndarray, kp: np.ndarray, phi_h: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs at MERL cell centres ``(ih, jd, kp)`` rotated to half-vector azimuth ``phi_h``, and weights."""
    from core.merl import N_PHI_D, N_THETA_D, N_THETA_H, cell_centre_pairs

    wi, wo = cell_centre_pairs(ih, jd, kp)
    c, s = math.cos(phi_h), math.sin(phi_h)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    wi, wo = wi @ rot.T, wo @ rot.T
    ih, jd, kp = (a.reshape(-1) for a in np.broadcast_arrays(ih, jd, kp))
    u = (ih + 0.5) / N_THETA_H
    theta_h = u * u * (0.5 * math.pi)
    theta_d = (jd + 0.5) / N_THETA_D * (0.5 * math.pi)
    d_theta_h = 2.0 * u / N_THETA_H * (0.5 * math.pi)
    d_theta_d = 0.5 * math.pi / N_THETA_D
    d_phi_d = math.pi / N_PHI_D
    w = 4.0 * np.cos(theta_d) * np.sin(theta_h) * np.sin(theta_d) * d_theta_h * d_theta_d * d_phi_d
    return wi, wo, w


def _grid_measurements(brdf: BRDF, stride_d: int = 2, stride_p: int = 4) -> Measurements:
    from core.merl import N_PHI_D, N_THETA_D, N_THETA_H

    ih, jd, kp = np.meshgrid(
        np.arange(N_THETA_H),
        np.arange(0, N_THETA_D, stride_d),
        np.arange(0, N_PHI_D, stride_p),
        indexing="ij",
    )
    phis = [0.0] if brdf.model.isotropic else [0.0, 0.25 * math.pi, 0.5 * math.pi, 0.75 * math.pi]
    wis, wos, ws = [], [], []
    for phi_h in phis:
        wi, wo, w = _rusinkiewicz_pairs(ih, jd, kp, phi_h)
        wis.append(wi)
        wos.append(wo)
        # A coarser grid covers the same measure: each kept cell stands for stride_d x stride_p cells.
        ws.append(w * stride_d * stride_p * (2.0 * math.pi / len(phis)))
    wi, wo, w = np.concatenate(wis), np.concatenate(wos), np.concatenate(ws)
    keep = (wi[:, 2] > 1e-3) & (wo[:, 2] > 1e-3)
    wi, wo, w = wi[keep], wo[keep], w[keep]
    f = brdf.eval(wo, wi)
    return Measurements(wi, wo, f, w)


def _rgl_measurements(brdf: BRDF) -> Measurements:
    from core.rgl.export import node_pairs

    wi, wo, w = node_pairs(brdf.table)  # type: ignore[attr-defined]
    keep = (wi[:, 2] > 1e-3) & (wo[:, 2] > 1e-3)
    wi, wo, w = wi[keep], wo[keep], w[keep]
    return Measurements(wi, wo, brdf.eval(wo, wi), w)


def measurements(brdf: BRDF) -> Measurements:
    """Where ``brdf`` is known exactly, with its values and weights (see the module docstring)."""
    if brdf.model.name.startswith("rgl"):
        return _rgl_measurements(brdf)
    return _grid_measurements(brdf)


# --------------------------------------------------------------------------------------------- fitting


def _transform(metric: str):  # type: ignore[no-untyped-def]
    if metric == "log":
        return np.log1p
    if metric == "cbrt":
        return np.cbrt
    raise ParameterError(f"unknown fitting metric '{metric}'; known: {', '.join(METRICS)}")


@dataclass(frozen=True)
class _Slot:
    """One scalar of the optimization vector: a parameter (or one channel of a colour)."""

    name: str
    channel: int  # -1 for a float parameter
    lo: float
    hi: float
    log: bool

    def to_x(self, v: float) -> float:
        return math.log(max(v, self.lo, 1e-12)) if self.log else v

    def from_x(self, x: float) -> float:
        v = math.exp(x) if self.log else x
        return min(max(v, self.lo), self.hi)

    def bounds(self) -> tuple[float, float]:
        return (math.log(max(self.lo, 1e-12)), math.log(self.hi)) if self.log else (self.lo, self.hi)


def _slots(model: Model, fixed: Mapping[str, Any]) -> list[_Slot]:
    out = []
    for p in model.params:
        if p.kind == "bool" or p.name in fixed:
            continue
        log = p.log and p.lo > 0.0
        if p.kind == "color":
            out += [_Slot(p.name, c, p.lo, p.hi, log) for c in range(3)]
        else:
            out.append(_Slot(p.name, -1, p.lo, p.hi, log))
    return out


def _values(
    model: Model, slots: list[_Slot], x: np.ndarray, base: dict[str, ParamValue]
) -> dict[str, ParamValue]:
    values = dict(base)
    colours: dict[str, list[float]] = {}
    for slot, xi in zip(slots, x, strict=True):
        v = slot.from_x(float(xi))
        if slot.channel < 0:
            values[slot.name] = v
        else:
            colours.setdefault(slot.name, list(values[slot.name]))[slot.channel] = v  # type: ignore[arg-type]
    for name, rgb in colours.items():
        values[name] = (rgb[0], rgb[1], rgb[2])
    return values


def fit(
    source: BRDF,
    model_name: str,
    metric: Metric = "log",
    fixed: Mapping[str, Any] | None = None,
    starts: int = 3,
    seed: int = 0,
    data: Measurements | None = None,
    max_evaluations: int = 400,
) -> FitResult:
    """Fit ``model_name``'s parameters to ``source`` (see the module docstring); ``fixed`` holds parameters
    kept at given values (booleans among them choose a model's option)."""
    from scipy.optimize import least_squares

    from core.kernels import eval_batch

    model = get_model(model_name)
    transform = _transform(metric)
    if starts < 1:
        raise ParameterError(f"the fit needs at least one start, got {starts}")
    base = model.resolve(dict(fixed or {}))
    slots = _slots(model, fixed or {})
    if not slots:
        raise ParameterError(f"model '{model_name}' has no free parameter to fit")
    t0 = time.perf_counter()
    m = data if data is not None else measurements(source)
    cos_i = m.wi[:, 2:3]
    target = transform(np.maximum(m.f, 0.0) * cos_i)
    sw = np.sqrt(m.weight / m.weight.sum())[:, None]
    wi = np.ascontiguousarray(m.wi)
    wo = np.ascontiguousarray(m.wo)
    count = 0

    def residual(x: np.ndarray) -> np.ndarray:
        nonlocal count
        count += 1
        values = _values(model, slots, x, base)
        g = eval_batch(model.id, wi, wo, model.kernel_params(values), threads=True)
        r = sw * (transform(np.maximum(g, 0.0) * cos_i) - target)
        return np.nan_to_num(r, nan=1e3, posinf=1e3, neginf=-1e3).reshape(-1)

    lo = np.array([s.bounds()[0] for s in slots])
    hi = np.array([s.bounds()[1] for s in slots])
    rng = np.random.default_rng(seed)
    x_default = np.clip(
        np.array([s.to_x(_scalar(base, s)) for s in slots]), lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo)
    )
    candidates = [x_default] + [
        lo + (hi - lo) * rng.uniform(0.05, 0.95, len(slots)) for _ in range(starts - 1)
    ]
    best = None
    history = []
    for x0 in candidates:
        sol = least_squares(
            residual, x0, bounds=(lo, hi), method="trf", x_scale="jac", max_nfev=max_evaluations, xtol=1e-10,
            ftol=1e-12, gtol=1e-12,
        )  # fmt: skip
        history.append({"start": _values(model, slots, x0, base), "cost": float(sol.cost)})
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None
    values = _values(model, slots, best.x, base)
    g = eval_batch(model.id, wi, wo, model.kernel_params(values), threads=True)
    r = sw * (transform(np.maximum(g, 0.0) * cos_i) - target)
    lum_f = (m.f * cos_i) @ np.array([0.2126, 0.7152, 0.0722])
    lum_g = (g * cos_i) @ np.array([0.2126, 0.7152, 0.0722])
    big = lum_f > 0.01 * lum_f.max()
    rel = np.abs(lum_g[big] - lum_f[big]) / lum_f[big]
    return FitResult(
        model=model_name,
        params=values,
        metric=metric,
        residual=float(np.sqrt(np.sum(r * r) / 3.0)),
        relative_error=_weighted_median(rel, m.weight[big]) if big.any() else float("nan"),
        seconds=time.perf_counter() - t0,
        evaluations=count,
        points=len(m.weight),
        starts=history,
    )


def _scalar(values: Mapping[str, ParamValue], slot: _Slot) -> float:
    v = values[slot.name]
    return float(v[slot.channel]) if isinstance(v, tuple) else float(v)


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(x)
    c = np.cumsum(w[order])
    return float(x[order][np.searchsorted(c, 0.5 * c[-1])])


def parameter_errors(fitted: Mapping[str, ParamValue], truth: Mapping[str, ParamValue]) -> dict[str, float]:
    """Relative error of each fitted parameter against known values (colours: the worst channel; an
    absolute error where the true value is 0)."""
    out = {}
    for name, t in truth.items():
        f = fitted[name]
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        fs = np.atleast_1d(np.asarray(f, dtype=float))
        err = np.where(ts != 0.0, np.abs(fs - ts) / np.where(ts != 0.0, np.abs(ts), 1.0), np.abs(fs - ts))
        out[name] = float(err.max())
    return out


def free_parameters(model_name: str, fixed: Sequence[str] = ()) -> list[str]:
    model = get_model(model_name)
    return [p.name for p in model.params if p.kind != "bool" and p.name not in fixed]


# --------------------------------------------------------------------------------------------- comparison views


def incidence_plane(brdf: BRDF, theta_o_deg: float, n: int = 181) -> tuple[np.ndarray, np.ndarray]:
    """``f cos theta_i`` (luminance) along the plane of incidence for outgoing ``theta_o``: signed ``theta_i``
    in degrees ``(n,)`` (positive on the specular side, ``wo`` at ``-theta_o``) and the values ``(n,)``."""
    t = np.radians(np.linspace(-89.5, 89.5, n))
    to = math.radians(theta_o_deg)
    wo = np.array([-math.sin(to), 0.0, math.cos(to)])
    wi = np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], axis=1)
    lum = brdf.eval(np.broadcast_to(wo, wi.shape), wi) @ np.array([0.2126, 0.7152, 0.0722])
    return np.degrees(t), lum * wi[:, 2]


def error_map(
    source: BRDF, fitted: BRDF, n_h: int = 45, n_d: int = 45, phi_d_deg: float = 90.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Relative error ``(g - f) / f`` of the fitted luminance against the source over ``(theta_h, theta_d)`` at
    ``phi_d`` (the usual slice of a MERL table), ``phi_h = 0``: ``theta_h (n_h,)``, ``theta_d (n_d,)`` in
    degrees and ``err (n_d, n_h)`` (NaN where a direction is below the horizon or ``f`` is 0)."""
    th = np.radians(np.linspace(0.5, 89.5, n_h))
    td = np.radians(np.linspace(0.5, 89.5, n_d))
    hh, dd = np.meshgrid(th, td)
    pd = math.radians(phi_d_deg)
    d = np.stack([np.sin(dd) * math.cos(pd), np.sin(dd) * math.sin(pd) * np.ones_like(dd), np.cos(dd)], -1)
    ct, st = np.cos(hh), np.sin(hh)
    wi = np.stack([d[..., 0] * ct + d[..., 2] * st, d[..., 1], d[..., 2] * ct - d[..., 0] * st], -1).reshape(
        -1, 3
    )
    h = np.stack([st, np.zeros_like(st), ct], -1).reshape(-1, 3)
    wo = 2.0 * np.sum(wi * h, axis=1, keepdims=True) * h - wi
    w = np.array([0.2126, 0.7152, 0.0722])
    f = source.eval(wo, wi) @ w
    g = fitted.eval(wo, wi) @ w
    ok = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0) & (f > 0.0)
    err = np.full(f.shape, np.nan)
    err[ok] = (g[ok] - f[ok]) / f[ok]
    return np.degrees(th), np.degrees(td), err.reshape(n_d, n_h)
