"""Physical analysis of a BRDF: directional albedo with a stated error, reciprocity, energy conservation and
non-negativity, as library functions returning reports (the CLI and the app print or show them).

Directional albedo
------------------
``rho(wo) = integral over the upper hemisphere of f_r(wi, wo) cos(theta_i) d(omega_i)``, per RGB channel.
By reciprocity it is also the hemispherical-directional reflectance for light arriving from ``wo``.

Quadrature: globally adaptive cubature in spherical coordinates about the normal, ``(theta, phi)`` on
``[0, pi/2] x [phi_m - pi, phi_m + pi]`` (``phi_m`` the mirror azimuth), integrand
``f cos(theta) sin(theta)``. The horizon is a coordinate line, so the integrand has no kink inside a region.
Each rectangle gets the tensor 15-point Gauss-Kronrod rule (225 points) and its error estimate is
``|K15xK15 - G7xK15| + |K15xK15 - K15xG7|`` (one term per axis, also used to choose the axis to split).
The sum of the region errors is the stated error; the rectangles with the largest errors are bisected until it
is below ``max(atol, rtol * |rho|)`` in every channel or the evaluation budget is spent (then
``converged=False`` and the stated error is what was reached).

Sharp lobes (Phong n = 10^4, Ward alpha = 0.005, ...) are narrower than any starting grid, so an adaptive rule
could miss them and report a tiny, wrong error. Before adapting, the mesh is graded around every place a peak
can sit: the mirror direction, the retro-reflection direction ``wo`` and the maximum of ``f cos`` found by a
grid search refined by local zooming. Rectangles containing one of these points are bisected until they are
smaller than ``PEAK_CELL`` (1e-3 rad) on a side, so a lobe of width >= ~1e-3 rad is resolved by the rules.
The search finds a lobe anywhere as long as its tail is not zero (underflowed) at the nearest grid point,
0.03 rad away at most: a cosine lobe of exponent 10^6 (width 0.001 rad) placed away from the mirror is found
(tested). Limitation: a narrower lobe away from the mirror and retro directions, or a second sharp lobe
besides the highest one, can be missed, and then the stated error does not cover it.

``|K - G|`` is a conservative estimate for smooth integrands (K15 is usually far more accurate than G7). The
tests compare with closed forms (Lambert, a normalized cosine lobe at n = 10^4, a normalized Beckmann lobe of
width 0.005) and check that the true error is below the stated one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from core.brdf import BRDF
from core.errors import BrdfStudioError, ParameterError
from core.geometry import degrees_to_dir, spherical_to_dir

# 15-point Gauss-Kronrod rule on [-1, 1] (nodes >= 0; the 7-point Gauss rule uses the odd-indexed ones).
_XGK = np.array(
    [
        0.991455371120812639206854697526329,
        0.949107912342758524526189684047851,
        0.864864423359769072789712788640926,
        0.741531185599394439863864773280788,
        0.586087235467691130294144845693013,
        0.405845151377397166906606412076961,
        0.207784955007898467600689403773245,
        0.0,
    ]
)
_WGK = np.array(
    [
        0.022935322010529224963732008058970,
        0.063092092629978553290700663189204,
        0.104790010322250183839876322541518,
        0.140653259715525918745189590510238,
        0.169004726639267902826583426598550,
        0.190350578064785409913256402421014,
        0.204432940075298892414161999234649,
        0.209482141084727828012999174891714,
    ]
)
_WG = np.array(
    [
        0.129484966168869693270611432679082,
        0.279705391489276667901467771423780,
        0.381830050505118944950369775488975,
        0.417959183673469387755102040816327,
    ]
)
NODES = np.concatenate([-_XGK[:-1], _XGK[::-1]])
"""The 15 Kronrod nodes on [-1, 1], ascending."""
W_KRONROD = np.concatenate([_WGK[:-1], _WGK[::-1]])
W_GAUSS = np.zeros(15)
W_GAUSS[1::2] = np.concatenate([_WG[:-1], _WG[::-1]])

PEAK_CELL = 1e-3
"""Rectangles holding a candidate peak are refined to this size (radians) before adapting."""
DEFAULT_RTOL = 1e-6
MEASURED_RTOL = 1e-4
"""Default target for measured tables: their interpolant has kinks at every cell centre, so tight targets
cost many evaluations, and the table's own resolution error is far larger anyway."""
DEFAULT_ATOL = 1e-9
DEFAULT_MAX_EVALS = 3_000_000
ENERGY_THETAS_DEG = (0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 75.0, 80.0, 85.0, 89.0)


@dataclass(frozen=True)
class AlbedoResult:
    """Directional albedo at one outgoing direction, per RGB channel, with its stated error."""

    theta_deg: float
    phi_deg: float
    value: tuple[float, float, float]
    error: tuple[float, float, float]
    evaluations: int
    regions: int
    converged: bool

    def to_dict(self) -> dict:
        return asdict(self)


def _check_angle(theta_deg: float, phi_deg: float) -> None:
    if not (math.isfinite(theta_deg) and 0.0 <= theta_deg <= 90.0):
        raise ParameterError(f"theta must be within [0, 90] degrees, got {theta_deg:g}")
    if not math.isfinite(phi_deg):
        raise ParameterError(f"phi must be a finite angle in degrees, got {phi_deg:g}")


class _Integrand:
    """``f(wi, wo) cos(theta_i) sin(theta_i)`` on ``(theta, phi)`` points, counting evaluations."""

    def __init__(self, brdf: BRDF, wo: np.ndarray, threads: bool):
        self.brdf = brdf
        self.wo = wo
        self.threads = threads
        self.evaluations = 0

    def f_cos(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """``f cos(theta_i)`` (the integrand per unit disk area), ``(n, 3)``."""
        wi = np.ascontiguousarray(spherical_to_dir(theta, phi).reshape(-1, 3))
        wo = np.ascontiguousarray(np.broadcast_to(self.wo, wi.shape))
        self.evaluations += wi.shape[0]
        f = self.brdf.eval(
            wo, wi, threads=self.threads
        )  # the BRDF's own evaluation (a subclass may have one)
        return f * wi[:, 2:3]

    def rules(self, a0, a1, b0, b1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For rectangles ``[a0, a1] x [b0, b1]`` (theta x phi): Kronrod estimate ``(r, 3)`` and the
        per-axis error estimates ``(r, 3)`` each."""
        ha = 0.5 * (a1 - a0)
        hb = 0.5 * (b1 - b0)
        th = (0.5 * (a0 + a1))[:, None] + ha[:, None] * NODES[None, :]  # (r, 15)
        ph = (0.5 * (b0 + b1))[:, None] + hb[:, None] * NODES[None, :]
        T = np.broadcast_to(th[:, :, None], (len(a0), 15, 15))
        P = np.broadcast_to(ph[:, None, :], (len(a0), 15, 15))
        g = self.f_cos(T.ravel(), P.ravel()).reshape(len(a0), 15, 15, 3)
        g = g * np.sin(T)[..., None]
        area = (ha * hb)[:, None]
        kk = np.einsum("i,j,rijc->rc", W_KRONROD, W_KRONROD, g) * area
        gk = np.einsum("i,j,rijc->rc", W_GAUSS, W_KRONROD, g) * area
        kg = np.einsum("i,j,rijc->rc", W_KRONROD, W_GAUSS, g) * area
        return kk, np.abs(kk - gk), np.abs(kk - kg)


def _wrap(phi: float, centre: float) -> float:
    return centre + (phi - centre + math.pi) % (2.0 * math.pi) - math.pi


def _peak_search(integrand: _Integrand, phi_c: float) -> tuple[float, float]:
    """The maximum of ``f cos`` over a 48 x 96 grid, refined by local zooming; ``(theta, phi)``."""
    nt, nphi = 48, 96
    t = (np.arange(nt) + 0.5) * (0.5 * math.pi / nt)
    p = phi_c - math.pi + (np.arange(nphi) + 0.5) * (2.0 * math.pi / nphi)
    T, P = np.meshgrid(t, p, indexing="ij")
    lum = integrand.f_cos(T.ravel(), P.ravel()).sum(axis=1)
    k = int(np.argmax(lum))
    best_t, best_p, best = float(T.ravel()[k]), float(P.ravel()[k]), float(lum[k])
    step_t, step_p = 0.5 * math.pi / nt, 2.0 * math.pi / nphi
    offsets = np.linspace(-1.0, 1.0, 7)
    for _ in range(10):
        lt = np.clip(best_t + step_t * offsets, 0.0, 0.5 * math.pi)
        lp = best_p + step_p * offsets
        LT, LP = np.meshgrid(lt, lp, indexing="ij")
        v = integrand.f_cos(LT.ravel(), LP.ravel()).sum(axis=1)
        j = int(np.argmax(v))
        if v[j] > best:
            best_t, best_p, best = float(LT.ravel()[j]), float(LP.ravel()[j]), float(v[j])
        step_t *= 0.5
        step_p *= 0.5
    return best_t, _wrap(best_p, phi_c)


def _grade_around(peaks: list[tuple[float, float]], regions: np.ndarray, cell: float) -> np.ndarray:
    """Bisect rectangles ``(r, 4)`` holding a peak point until smaller than ``cell`` radians on a side."""
    for _ in range(64):
        a0, a1, b0, b1 = regions.T
        hit = np.zeros(len(regions), dtype=bool)
        for t, p in peaks:
            hit |= (a0 <= t) & (t <= a1) & (b0 <= p) & (p <= b1)
        size_t = a1 - a0
        size_p = (b1 - b0) * np.sin(np.minimum(a1, 0.5 * math.pi))
        split = hit & (np.maximum(size_t, size_p) > cell)
        if not split.any():
            break
        regions = np.concatenate([regions[~split], _bisect(regions[split], size_t[split] >= size_p[split])])
    return regions


def _bisect(regions: np.ndarray, along_theta: np.ndarray) -> np.ndarray:
    a0, a1, b0, b1 = regions.T
    ma = 0.5 * (a0 + a1)
    mb = 0.5 * (b0 + b1)
    first = np.where(along_theta[:, None], np.stack([a0, ma, b0, b1], 1), np.stack([a0, a1, b0, mb], 1))
    second = np.where(along_theta[:, None], np.stack([ma, a1, b0, b1], 1), np.stack([a0, a1, mb, b1], 1))
    return np.concatenate([first, second])


def albedo(
    brdf: BRDF,
    theta_deg: float,
    phi_deg: float = 0.0,
    rtol: float | None = None,
    atol: float = DEFAULT_ATOL,
    max_evals: int = DEFAULT_MAX_EVALS,
    threads: bool = False,
) -> AlbedoResult:
    """Directional albedo ``rho`` at outgoing direction ``(theta_deg, phi_deg)`` (degrees), RGB, with error.

    See the module docstring for the method; ``rtol``/``atol`` set the target of the stated error
    (``rtol`` defaults to ``DEFAULT_RTOL``, or ``MEASURED_RTOL`` for a measured BRDF).
    """
    if rtol is None:
        rtol = MEASURED_RTOL if brdf.model.measured else DEFAULT_RTOL
    theta_deg = float(theta_deg)
    phi_deg = float(phi_deg)
    _check_angle(theta_deg, phi_deg)
    wo = degrees_to_dir(theta_deg, phi_deg)
    integrand = _Integrand(brdf, wo, threads)
    theta_o = math.radians(theta_deg)
    phi_c = math.radians(phi_deg) + math.pi  # mirror azimuth, the centre of the phi range

    # Mirror, the maximum found by search, and the retro direction (on the seam of the phi range: both ends).
    peaks = [(theta_o, phi_c), _peak_search(integrand, phi_c)]
    peaks += [(theta_o, phi_c - math.pi), (theta_o, phi_c + math.pi)]
    t_edges = np.linspace(0.0, 0.5 * math.pi, 7)
    p_edges = phi_c + np.linspace(-math.pi, math.pi, 13)
    A, B = np.meshgrid(np.arange(6), np.arange(12), indexing="ij")
    regions = np.stack(
        [t_edges[A.ravel()], t_edges[A.ravel() + 1], p_edges[B.ravel()], p_edges[B.ravel() + 1]], 1
    )
    regions = _grade_around(peaks, regions, PEAK_CELL)

    est, err_t, err_p = integrand.rules(*regions.T)
    while True:
        if not (np.all(np.isfinite(est)) and np.all(np.isfinite(err_t)) and np.all(np.isfinite(err_p))):
            raise BrdfStudioError(
                f"{brdf.key()} gives non-finite values (NaN or Inf) near theta_o = {theta_deg:g} deg: "
                "its albedo is undefined"
            )
        err = err_t + err_p
        total = est.sum(axis=0)
        total_err = err.sum(axis=0)
        tol = np.maximum(atol, rtol * np.abs(total))
        if np.all(total_err <= tol):
            converged = True
            break
        ratio = (err / tol).max(axis=1)
        # Rectangles too small to split further (rounding) keep their error.
        splittable = (regions[:, 1] - regions[:, 0]) > 1e-12
        ratio = np.where(splittable, ratio, 0.0)
        order = np.argsort(ratio)[::-1]
        cum = np.cumsum(ratio[order])
        k = int(np.searchsorted(cum, 0.5 * cum[-1])) + 1
        k = min(k, (max_evals - integrand.evaluations) // (2 * 225))
        if k <= 0 or cum[-1] == 0.0:
            converged = False
            break
        pick = order[:k]
        keep = np.ones(len(regions), dtype=bool)
        keep[pick] = False
        ratio_t = (err_t[pick] / tol).max(axis=1)
        ratio_p = (err_p[pick] / tol).max(axis=1)
        children = _bisect(regions[pick], ratio_t >= ratio_p)
        c_est, c_et, c_ep = integrand.rules(*children.T)
        regions = np.concatenate([regions[keep], children])
        est = np.concatenate([est[keep], c_est])
        err_t = np.concatenate([err_t[keep], c_et])
        err_p = np.concatenate([err_p[keep], c_ep])
    return AlbedoResult(
        theta_deg=theta_deg,
        phi_deg=phi_deg,
        value=tuple(float(v) for v in total),  # type: ignore[arg-type]
        error=tuple(float(v) for v in total_err),  # type: ignore[arg-type]
        evaluations=integrand.evaluations,
        regions=len(regions),
        converged=converged,
    )


def albedo_table(
    brdf: BRDF, thetas_deg: Sequence[float] = (0.0, 30.0, 60.0, 80.0), **options
) -> list[AlbedoResult]:
    """:func:`albedo` at each of ``thetas_deg``."""
    return [albedo(brdf, t, **options) for t in thetas_deg]


# --------------------------------------------------------------------------------------------- reports


@dataclass(frozen=True)
class EnergyReport:
    """Energy conservation over a set of outgoing angles: the largest albedo found, per channel.

    ``verdict`` is ``"conserving"`` when the maximum plus its stated error is <= 1, ``"violating"`` when the
    maximum minus its error is > 1, else ``"undecided"``. The maximum is over the listed angles only.
    """

    max_albedo: tuple[float, float, float]
    error: tuple[float, float, float]
    theta_deg_at_max: tuple[float, float, float]
    thetas_deg: tuple[float, ...]
    verdict: str
    results: tuple[AlbedoResult, ...] = field(repr=False)

    @property
    def passed(self) -> bool:
        return self.verdict == "conserving"

    def to_dict(self) -> dict:
        d = asdict(self)
        d["results"] = [r.to_dict() for r in self.results]
        return d

    def summary(self) -> str:
        c = int(np.argmax(self.max_albedo))
        return (
            f"energy: {self.verdict}, max albedo {self.max_albedo[c]:.6f} ± {self.error[c]:.1e} "
            f"(channel {'RGB'[c]}, theta {self.theta_deg_at_max[c]:g} deg)"
        )


def energy_report(brdf: BRDF, thetas_deg: Sequence[float] = ENERGY_THETAS_DEG, **options) -> EnergyReport:
    """The largest directional albedo of ``brdf`` over ``thetas_deg`` (options as :func:`albedo`)."""
    results = tuple(albedo(brdf, t, **options) for t in thetas_deg)
    values = np.array([r.value for r in results])
    errors = np.array([r.error for r in results])
    k = np.argmax(values, axis=0)
    mx = values[k, [0, 1, 2]]
    er = errors[k, [0, 1, 2]]
    if np.all(values + errors <= 1.0):
        verdict = "conserving"
    elif np.any(values - errors > 1.0):
        verdict = "violating"
    else:
        verdict = "undecided"
    return EnergyReport(
        max_albedo=tuple(float(v) for v in mx),  # type: ignore[arg-type]
        error=tuple(float(v) for v in er),  # type: ignore[arg-type]
        theta_deg_at_max=tuple(float(thetas_deg[i]) for i in k),  # type: ignore[arg-type]
        thetas_deg=tuple(float(t) for t in thetas_deg),
        verdict=verdict,
        results=results,
    )


REPORT_THETAS_DEG = np.array([0.0, 0.5, 5.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.9, 90.0])
REPORT_PHIS_DEG = np.array([0.0, 37.0, 90.0, 135.0, 180.0, 222.0, 270.0, 333.0])


def check_directions(n_random: int = 20_000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Direction pairs ``(wo, wi)``, each ``(n, 3)``: every pair of a dense grid (grazing angles up to and at
    90 degrees) and ``n_random`` pairs uniform on the hemisphere (seeded)."""
    t, p = np.meshgrid(np.radians(REPORT_THETAS_DEG), np.radians(REPORT_PHIS_DEG), indexing="ij")
    grid = spherical_to_dir(t.ravel(), p.ravel())
    grid[np.repeat(REPORT_THETAS_DEG, len(REPORT_PHIS_DEG)) == 90.0, 2] = 0.0
    n = len(grid)
    wo = np.repeat(grid, n, axis=0)
    wi = np.tile(grid, (n, 1))
    rng = np.random.default_rng(seed)
    r = rng.random((n_random, 4))
    wo_r = spherical_to_dir(np.arccos(r[:, 0]), 2.0 * np.pi * r[:, 1])
    wi_r = spherical_to_dir(np.arccos(r[:, 2]), 2.0 * np.pi * r[:, 3])
    return np.concatenate([wo, wo_r]), np.concatenate([wi, wi_r])


@dataclass(frozen=True)
class ReciprocityReport:
    """``f(wi, wo)`` against ``f(wo, wi)`` over :func:`check_directions`.

    ``max_relative_error`` is ``max |a - b| / max(|a|, |b|)`` over pairs where ``max(|a|, |b|) > atol``;
    ``passed`` when it is <= ``rtol``. ``declared`` is the model's RECIPROCAL trait.
    """

    max_relative_error: float
    worst_wo: tuple[float, float, float]
    worst_wi: tuple[float, float, float]
    pairs: int
    rtol: float
    declared: bool
    passed: bool

    def to_dict(self) -> dict:
        return asdict(self)

    def summary(self) -> str:
        state = "reciprocal" if self.passed else "NOT reciprocal"
        return (
            f"reciprocity: {state} (max relative difference {self.max_relative_error:.1e} over {self.pairs} "
            f"pairs, tolerance {self.rtol:g}; declared {'yes' if self.declared else 'no'})"
        )


def reciprocity_report(
    brdf: BRDF, rtol: float = 1e-6, atol: float = 1e-12, n_random: int = 20_000, seed: int = 0
) -> ReciprocityReport:
    wo, wi = check_directions(n_random, seed)
    a = brdf.eval(wo, wi)
    b = brdf.eval(wi, wo)
    scale = np.maximum(np.abs(a), np.abs(b))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(scale > atol, np.abs(a - b) / np.where(scale > 0, scale, 1.0), 0.0)
    rel = np.where(np.isfinite(rel), rel, np.inf).max(axis=1)
    k = int(np.argmax(rel))
    worst = float(rel[k])
    return ReciprocityReport(
        max_relative_error=worst,
        worst_wo=tuple(float(x) for x in wo[k]),  # type: ignore[arg-type]
        worst_wi=tuple(float(x) for x in wi[k]),  # type: ignore[arg-type]
        pairs=len(wo),
        rtol=rtol,
        declared=brdf.model.reciprocal,
        passed=worst <= rtol,
    )


@dataclass(frozen=True)
class NonNegativityReport:
    """Finite and non-negative over :func:`check_directions` (and exactly 0 below the horizon)."""

    min_value: float
    negative: int
    non_finite: int
    nonzero_below_horizon: int
    pairs: int

    @property
    def passed(self) -> bool:
        return self.negative == 0 and self.non_finite == 0 and self.nonzero_below_horizon == 0

    def to_dict(self) -> dict:
        d = asdict(self)
        d["passed"] = self.passed
        return d

    def summary(self) -> str:
        state = "ok" if self.passed else "FAILED"
        return (
            f"non-negativity: {state} (min {self.min_value:.3g}, {self.negative} negative, "
            f"{self.non_finite} non-finite, {self.nonzero_below_horizon} non-zero below the horizon, "
            f"{self.pairs} pairs)"
        )


def nonnegativity_report(brdf: BRDF, n_random: int = 20_000, seed: int = 0) -> NonNegativityReport:
    wo, wi = check_directions(n_random, seed)
    f = brdf.eval(wo, wi)
    finite = np.isfinite(f)
    up = wi[:, 2] > 0.0
    fb = brdf.eval(wo[up], wi[up] * np.array([1.0, 1.0, -1.0]))
    return NonNegativityReport(
        min_value=float(np.min(np.where(finite, f, np.inf))) if finite.any() else float("nan"),
        negative=int(np.sum(finite & (f < 0.0))),
        non_finite=int(np.sum(~finite)),
        nonzero_below_horizon=int(np.sum(fb != 0.0)),
        pairs=len(wo),
    )
