"""Chi-square goodness-of-fit tests for direction samplers (the statistical proof that a sampler draws from
the density it claims).

The method follows the idea of Mitsuba 3's ``chi2.py`` and pbrt-v4's ``bsdfs_test`` (our own code):

1. draw ``n`` directions (>= 1e6 for the project's tests) and histogram them on a grid of cells;
2. integrate the claimed density over every cell with a tensor Gauss-Legendre rule that refines itself
   (a cell is split in 2x2 until the rule on the cell and on its four quarters agree to ``cell_tol``), so
   narrow lobes are integrated accurately; the expected count of a cell is ``n`` times its integral;
3. fail at once if a sample lands where the density is zero (the pdf at the sample is ``<= 0`` or not finite,
   or its cell has expected count 0), or if the density does not integrate to one within ``integral_tol``;
4. sort the cells by expected count and pool consecutive ones until every pooled cell expects >= 5;
5. Pearson's statistic, its p-value from the chi-square law with ``cells - 1`` degrees of freedom
   (:func:`scipy.stats.chi2.sf`), compared with the Sidak-corrected level ``1 - (1 - alpha)^(1/n_tests)``.

Two grids over the same directions:

``sphere``
    ``phi`` in ``[0, 2 pi)`` x ``cos(theta)`` in ``[-1, 1]``: equal solid angle per cell (the whole sphere, so a
    sampler's mass below the horizon is tested too).
``disk``
    the projection ``(x, y)`` of the upper hemisphere onto the unit disk, cells uniform in ``phi`` and ``r^2``
    (equal *disk* area, i.e. equal projected solid angle: fine near the horizon, where the sphere grid is
    coarse). Directions below the horizon fall into one extra cell. The per-cell integral uses the change of
    variable ``t = cos(theta) = sqrt(1 - r^2)``, in which ``pdf_disk dx dy = pdf_solid_angle dt dphi``, so
    densities with the ``1 / cos(theta)`` rim behaviour of ``pdf_disk`` are integrated without a singularity.

A ``sample(n, seed) -> wi (n, 3)`` callable and a ``pdf(wi (m, 3)) -> (m,)`` callable (density per unit solid
angle) describe the sampler under test; :func:`sampler_functions` makes them from a
:class:`core.sampling.Sampler` and an outgoing direction.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from scipy import stats

SampleFn = Callable[[int, int], np.ndarray]
PdfFn = Callable[[np.ndarray], np.ndarray]
Domain = Literal["sphere", "disk"]
Variable = Literal["cos", "theta"]

TWO_PI = 2.0 * math.pi
MIN_EXPECTED = 5.0

DEFAULT_RESOLUTION: dict[str, tuple[int, int]] = {
    # (cells in phi, cells in the second coordinate: cos(theta) over [-1, 1], or r^2 over [0, 1])
    "sphere": (100, 50),
    "disk": (64, 32),
}


def sidak_alpha(alpha: float, n_tests: int) -> float:
    """Per-test significance level so that ``n_tests`` independent tests together reject a true hypothesis
    with probability ``alpha``."""
    return 1.0 - (1.0 - alpha) ** (1.0 / max(1, int(n_tests)))


@dataclass
class Chi2Result:
    """Outcome of one test. ``passed`` is the verdict; ``reason`` says why in one readable line."""

    passed: bool
    reason: str
    p_value: float
    statistic: float
    dof: int
    alpha: float
    """The (Sidak-corrected) significance level the p-value was compared with."""
    integral: float
    """Integral of the claimed pdf over the whole sphere (should be 1)."""
    n_samples: int
    domain: str
    observed: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    expected: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))

    def summary(self) -> str:
        verdict = "PASS" if self.passed else "FAIL"
        return (
            f"{verdict} chi2[{self.domain}] p={self.p_value:.4g} (alpha={self.alpha:.3g}) "
            f"stat={self.statistic:.1f} dof={self.dof} integral={self.integral:.6f} n={self.n_samples}: "
            f"{self.reason}"
        )

    def as_dict(self) -> dict[str, Any]:
        return {
            "passed": self.passed,
            "reason": self.reason,
            "p_value": self.p_value,
            "statistic": self.statistic,
            "dof": self.dof,
            "alpha": self.alpha,
            "integral": self.integral,
            "n_samples": self.n_samples,
            "domain": self.domain,
        }


# ----------------------------------------------------------------------------------------------------------
# Grids: cell edges in (phi, cos theta) and the binning of directions


@dataclass(frozen=True)
class _Grid:
    domain: str
    phi_edges: np.ndarray
    cos_edges: np.ndarray  # increasing cos(theta) edges of the rows integrated cell by cell
    below_cell: bool  # disk: one extra cell gathers every direction with z <= 0

    @property
    def n_cells(self) -> int:
        return (len(self.phi_edges) - 1) * (len(self.cos_edges) - 1) + (1 if self.below_cell else 0)


def _grid(domain: str, resolution: tuple[int, int] | None) -> _Grid:
    if domain not in DEFAULT_RESOLUTION:
        raise ValueError(f"unknown chi2 domain '{domain}' (use 'sphere' or 'disk')")
    n_phi, n_second = resolution or DEFAULT_RESOLUTION[domain]
    phi_edges = np.linspace(0.0, TWO_PI, n_phi + 1)
    if domain == "sphere":
        return _Grid(domain, phi_edges, np.linspace(-1.0, 1.0, n_second + 1), False)
    # r^2 edges k/n  <->  cos edges sqrt(1 - k/n), listed increasing in cos
    r2 = np.linspace(0.0, 1.0, n_second + 1)
    cos_edges = np.sqrt(np.maximum(0.0, 1.0 - r2))[::-1].copy()
    cos_edges[0] = 0.0
    cos_edges[-1] = 1.0
    return _Grid(domain, phi_edges, cos_edges, True)


def _bin(grid: _Grid, wi: np.ndarray) -> np.ndarray:
    """Cell index of every direction; cells are numbered row-major (cos row, phi column), the disk's
    below-horizon cell last."""
    n_phi = len(grid.phi_edges) - 1
    n_rows = len(grid.cos_edges) - 1
    phi = np.mod(np.arctan2(wi[:, 1], wi[:, 0]), TWO_PI)
    col = np.minimum((phi * (n_phi / TWO_PI)).astype(np.int64), n_phi - 1)
    z = np.clip(wi[:, 2], -1.0, 1.0)
    if grid.domain == "sphere":
        row = np.minimum(((z + 1.0) * (0.5 * n_rows)).astype(np.int64), n_rows - 1)
        return row * n_phi + col
    # disk: rows uniform in r^2 = x^2 + y^2, counted from the centre; stored increasing in cos (rim first)
    r2 = np.clip(wi[:, 0] ** 2 + wi[:, 1] ** 2, 0.0, 1.0)
    ring = np.minimum((r2 * n_rows).astype(np.int64), n_rows - 1)
    row = n_rows - 1 - ring
    idx = row * n_phi + col
    idx[z <= 0.0] = n_rows * n_phi
    return idx


# ----------------------------------------------------------------------------------------------------------
# Self-refining tensor Gauss-Legendre integration of the pdf over cells


def _cell_rule(
    pdf: PdfFn, phi0: np.ndarray, phi1: np.ndarray, c0: np.ndarray, c1: np.ndarray, order: int,
    variable: Variable = "cos",
) -> np.ndarray:  # fmt: skip
    """Tensor Gauss-Legendre estimate of the integral of ``pdf`` over each (phi, cos) rectangle, its nodes
    spaced evenly in ``cos theta`` (``variable="cos"``) or in ``theta`` (``"theta"``, with the Jacobian
    ``sin theta``): near the pole a cell even in ``cos`` is wide in ``theta`` (``theta ~ sqrt(2 (1 - cos))``),
    and structure a few degrees wide there (a table's first rows, a narrow lobe at normal incidence) falls
    between nodes even in ``cos`` at every level of refinement."""
    x, w = np.polynomial.legendre.leggauss(order)
    t = 0.5 * (x + 1.0)
    phi = phi0[:, None] + (phi1 - phi0)[:, None] * t[None, :]  # (m, k)
    if variable == "theta":
        th0, th1 = np.arccos(np.clip(c1, -1.0, 1.0)), np.arccos(np.clip(c0, -1.0, 1.0))  # increasing
        th = th0[:, None] + (th1 - th0)[:, None] * t[None, :]
        tt = np.tile(th, (1, order))
        cc, sin = np.cos(tt), np.sin(tt)
        jac, width = sin, th1 - th0
    else:
        cos = c0[:, None] + (c1 - c0)[:, None] * t[None, :]
        cc = np.tile(cos, (1, order))
        sin = np.sqrt(np.maximum(0.0, 1.0 - cc * cc))
        jac, width = 1.0, c1 - c0
    pp = np.repeat(phi, order, axis=1)  # (m, k*k): phi varies slowest
    dirs = np.stack([sin * np.cos(pp), sin * np.sin(pp), cc], axis=-1).reshape(-1, 3)
    vals = np.asarray(pdf(dirs), dtype=np.float64).reshape(len(phi0), order * order) * jac
    vals = np.where(np.isfinite(vals), vals, np.inf)
    ww = np.outer(w, w).ravel() * 0.25
    return (vals @ ww) * (phi1 - phi0) * width


def integrate_cells(
    pdf: PdfFn,
    phi_edges: np.ndarray,
    cos_edges: np.ndarray,
    order: int = 4,
    cell_tol: float = 1e-9,
    max_depth: int = 7,
    variable: Variable = "cos",
    min_depth: int = 0,
) -> np.ndarray:
    """Integral of ``pdf`` (per unit solid angle) over every cell of the (cos row, phi column) grid.

    Each cell is integrated with an ``order x order`` Gauss-Legendre rule and with the same rule on its
    four quarters; where the two differ by more than ``cell_tol`` (absolute, in probability) the quarters
    are refined in turn, down to ``max_depth`` levels (and at least ``min_depth``, whatever they agree on).
    The result is the finest estimate. ``variable``: the rule's nodes even in ``cos theta`` or in ``theta``
    (:func:`_cell_rule`); the cells are the same.
    """
    n_phi = len(phi_edges) - 1
    n_rows = len(cos_edges) - 1
    c0, p0 = np.meshgrid(cos_edges[:-1], phi_edges[:-1], indexing="ij")
    c1, p1 = np.meshgrid(cos_edges[1:], phi_edges[1:], indexing="ij")
    owner = np.arange(n_rows * n_phi)
    phi0, phi1, cc0, cc1 = p0.ravel(), p1.ravel(), c0.ravel(), c1.ravel()
    coarse = _cell_rule(pdf, phi0, phi1, cc0, cc1, order, variable)
    out = np.zeros(n_rows * n_phi)
    tol = cell_tol
    for depth in range(max_depth + 1):
        pm = 0.5 * (phi0 + phi1)
        cm = 0.5 * (cc0 + cc1)
        q_phi0 = np.concatenate([phi0, pm, phi0, pm])
        q_phi1 = np.concatenate([pm, phi1, pm, phi1])
        q_c0 = np.concatenate([cc0, cc0, cm, cm])
        q_c1 = np.concatenate([cm, cm, cc1, cc1])
        quarters = _cell_rule(pdf, q_phi0, q_phi1, q_c0, q_c1, order, variable)
        m = len(phi0)
        fine = quarters[:m] + quarters[m : 2 * m] + quarters[2 * m : 3 * m] + quarters[3 * m :]
        done = (np.abs(fine - coarse) <= tol) & (depth >= min_depth)
        if depth == max_depth:
            done[:] = True
        np.add.at(out, owner[done], fine[done])
        keep = ~done
        if not np.any(keep):
            break
        sel = np.concatenate([keep, keep, keep, keep])
        owner = np.tile(owner, 4)[sel]
        phi0, phi1, cc0, cc1 = q_phi0[sel], q_phi1[sel], q_c0[sel], q_c1[sel]
        coarse = quarters[sel]
        tol = 0.25 * tol  # the same absolute budget shared by the four quarters
    return out


def _expected_probabilities(
    pdf: PdfFn, grid: _Grid, order: int, cell_tol: float, variable: Variable = "cos"
) -> np.ndarray:
    probs = integrate_cells(pdf, grid.phi_edges, grid.cos_edges, order, cell_tol, variable=variable)
    if grid.below_cell:  # one cell, integrated on the sphere grid's lower half (mass below can be sharp)
        phi_edges, cos_edges = np.linspace(0.0, TWO_PI, 101), np.linspace(-1.0, 0.0, 26)
        lower = integrate_cells(pdf, phi_edges, cos_edges, order, cell_tol, variable=variable)
        probs = np.concatenate([probs, [lower.sum()]])
    return probs


RESCUE_DEPTH = 5
"""How finely :func:`_rescue_missed_cells` re-integrates a cell: ``4^5`` parts, each under the rule."""


def _rescue_missed_cells(
    pdf: PdfFn, grid: _Grid, probs: np.ndarray, observed: np.ndarray, order: int, cell_tol: float
) -> np.ndarray:
    """``probs`` with every grid cell that holds samples but integrated to 0 integrated again, in ``theta``
    and split ``RESCUE_DEPTH`` times before the rule's agreement is asked.

    Self-refining quadrature refines where its nodes see the density change; a sliver of density that no
    node of a cell touches reads 0 at every level (Phong's lobe at a grazing view crosses the pole in a
    strip 1 degree wide, inside a polar cell 16 degrees tall). The pdf is positive at the samples that
    land there (checked before), so such a cell is integrated again finely enough to see them; a cell whose
    second integral is 0 too fails the test as before."""
    n_phi = len(grid.phi_edges) - 1
    n_grid = n_phi * (len(grid.cos_edges) - 1)
    missed = np.flatnonzero((observed[:n_grid] > 0) & (probs[:n_grid] <= 0.0))
    if len(missed) == 0:
        return probs
    probs = probs.copy()
    for k in missed:
        row, col = divmod(int(k), n_phi)
        probs[k] = integrate_cells(
            pdf, grid.phi_edges[col : col + 2], grid.cos_edges[row : row + 2], order, cell_tol,
            max_depth=RESCUE_DEPTH + 2, variable="theta", min_depth=RESCUE_DEPTH,
        )[0]  # fmt: skip
    return probs


# ----------------------------------------------------------------------------------------------------------
# Pearson's test


def pool_cells(observed: np.ndarray, expected: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pool cells in order of increasing expected count until each pooled cell expects >= 5.

    Cells with expected count 0 must be removed beforehand (they are handled as an immediate failure).
    """
    order = np.argsort(expected, kind="stable")
    obs_sorted = observed[order]
    exp_sorted = expected[order]
    pooled_obs: list[float] = []
    pooled_exp: list[float] = []
    acc_o = acc_e = 0.0
    for o, e in zip(obs_sorted, exp_sorted, strict=True):
        acc_o += o
        acc_e += e
        if acc_e >= MIN_EXPECTED:
            pooled_obs.append(acc_o)
            pooled_exp.append(acc_e)
            acc_o = acc_e = 0.0
    if acc_e > 0.0 or acc_o > 0.0:
        if pooled_exp:
            pooled_obs[-1] += acc_o
            pooled_exp[-1] += acc_e
        else:
            pooled_obs.append(acc_o)
            pooled_exp.append(acc_e)
    return np.asarray(pooled_obs), np.asarray(pooled_exp)


def pearson(observed: np.ndarray, expected: np.ndarray) -> tuple[float, int, float]:
    """Pearson's statistic, degrees of freedom and p-value of already pooled cells."""
    stat = float(np.sum((observed - expected) ** 2 / expected))
    dof = max(1, len(observed) - 1)
    return stat, dof, float(stats.chi2.sf(stat, dof))


def _describe(w: np.ndarray) -> str:
    theta = math.degrees(math.acos(max(-1.0, min(1.0, float(w[2])))))
    phi = math.degrees(math.atan2(float(w[1]), float(w[0]))) % 360.0
    return f"(theta={theta:.3f} deg, phi={phi:.3f} deg)"


def chi2_test(
    sample: SampleFn,
    pdf: PdfFn,
    n_samples: int = 1_000_000,
    domain: Domain = "sphere",
    seed: int = 0,
    alpha: float = 0.01,
    n_tests: int = 1,
    resolution: tuple[int, int] | None = None,
    integral_tol: float = 1e-3,
    order: int = 4,
    cell_tol: float | None = None,
    variable: Variable = "cos",
) -> Chi2Result:
    """Test that ``sample`` draws directions with density ``pdf`` (per unit solid angle).

    Parameters
    ----------
    sample : callable ``(n, seed) -> wi (n, 3)``
    pdf : callable ``wi (m, 3) -> (m,)``, the claimed density per unit solid angle over the sphere
    n_samples : number of directions drawn (>= 1e6 for the project's tests)
    domain : ``"sphere"`` or ``"disk"`` (see the module docstring)
    alpha, n_tests : significance level and the number of tests it is shared among (Sidak)
    integral_tol : the pdf must integrate to 1 within this
    cell_tol : absolute tolerance of each cell's integral (default: 1e-3 / n_samples, i.e. 1e-3 counts)
    variable : the integration rule's nodes even in ``"cos"`` theta or in ``"theta"`` (:func:`_cell_rule`:
        for densities with structure near the pole, such as tables in even steps of ``theta``)
    """
    grid = _grid(domain, resolution)
    level = sidak_alpha(alpha, n_tests)
    wi = np.asarray(sample(int(n_samples), int(seed)), dtype=np.float64)
    n = len(wi)

    def result(passed: bool, reason: str, **kw: Any) -> Chi2Result:
        base: dict[str, Any] = dict(
            p_value=float("nan"), statistic=float("nan"), dof=0, alpha=level, integral=float("nan"),
            n_samples=n, domain=domain,
        )  # fmt: skip
        base.update(kw)
        return Chi2Result(passed, reason, **base)

    if wi.ndim != 2 or wi.shape[1] != 3 or n != int(n_samples):
        return result(False, f"sampler returned an array of shape {wi.shape}, expected ({n_samples}, 3)")
    finite = np.all(np.isfinite(wi), axis=1)
    if not np.all(finite):
        k = int(np.flatnonzero(~finite)[0])
        return result(False, f"sample {k} is not finite: {wi[k]}")
    norms = np.linalg.norm(wi, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-6):
        k = int(np.argmax(np.abs(norms - 1.0)))
        return result(False, f"sample {k} is not a unit vector (|wi| = {norms[k]:.9f})")
    at_samples = np.asarray(pdf(wi), dtype=np.float64)
    bad = ~(np.isfinite(at_samples) & (at_samples > 0.0))
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        return result(
            False,
            f"{int(bad.sum())} samples land where the pdf is zero or not finite, e.g. {_describe(wi[k])} "
            f"with pdf {at_samples[k]}",
        )

    tol = cell_tol if cell_tol is not None else 1e-3 / max(n, 1)
    probs = _expected_probabilities(pdf, grid, order, tol, variable)
    integral = float(probs.sum())
    if not np.all(np.isfinite(probs)):
        return result(False, "the pdf is not finite somewhere on the grid", integral=integral)
    if np.any(probs < 0.0):
        return result(False, "the pdf is negative somewhere on the grid", integral=integral)
    observed = np.bincount(_bin(grid, wi), minlength=grid.n_cells).astype(np.float64)
    probs = _rescue_missed_cells(pdf, grid, probs, observed, order, tol)
    integral = float(probs.sum())
    expected = probs * n
    empty = expected <= 0.0
    if np.any(observed[empty] > 0):
        k = int(np.flatnonzero(empty & (observed > 0))[0])
        return result(
            False,
            f"{int(observed[empty].sum())} samples land in cells where the pdf integrates to 0 (cell {k})",
            integral=integral, observed=observed, expected=expected,
        )  # fmt: skip
    if abs(integral - 1.0) > integral_tol:
        return result(
            False,
            f"the pdf integrates to {integral:.6f}, not 1 (tolerance {integral_tol:g})",
            integral=integral, observed=observed, expected=expected,
        )  # fmt: skip
    obs_p, exp_p = pool_cells(observed[~empty], expected[~empty])
    stat, dof, p = pearson(obs_p, exp_p)
    passed = p > level
    reason = (
        f"samples consistent with the pdf ({len(exp_p)} pooled cells)"
        if passed
        else f"samples do not follow the pdf: p = {p:.3g} <= {level:.3g} ({len(exp_p)} pooled cells)"
    )
    return Chi2Result(
        passed, reason, p, stat, dof, level, integral, n, domain, observed=observed, expected=expected
    )


def two_sample_test(
    wi_a: np.ndarray,
    wi_b: np.ndarray,
    domain: Domain = "sphere",
    alpha: float = 0.01,
    n_tests: int = 1,
    resolution: tuple[int, int] | None = None,
) -> Chi2Result:
    """Chi-square homogeneity test: were the two direction sets drawn from the same distribution?

    Cells are pooled (in order of increasing combined count) until each pooled cell holds >= 10 directions
    of the two sets together; the statistic is ``sum (a k1 - b k2)^2 / (a + b)`` with ``k1 = sqrt(nb/na)``,
    ``k2 = sqrt(na/nb)``, with ``cells - 1`` degrees of freedom.
    """
    grid = _grid(domain, resolution)
    level = sidak_alpha(alpha, n_tests)
    wi_a = np.asarray(wi_a, dtype=np.float64)
    wi_b = np.asarray(wi_b, dtype=np.float64)
    na, nb = len(wi_a), len(wi_b)
    a = np.bincount(_bin(grid, wi_a), minlength=grid.n_cells).astype(np.float64)
    b = np.bincount(_bin(grid, wi_b), minlength=grid.n_cells).astype(np.float64)
    order = np.argsort(a + b, kind="stable")
    pa: list[float] = []
    pb: list[float] = []
    sa = sb = 0.0
    for x, y in zip(a[order], b[order], strict=True):
        sa += x
        sb += y
        if sa + sb >= 2.0 * MIN_EXPECTED:
            pa.append(sa)
            pb.append(sb)
            sa = sb = 0.0
    if (sa + sb) > 0 and pa:
        pa[-1] += sa
        pb[-1] += sb
    aa, bb = np.asarray(pa), np.asarray(pb)
    k1, k2 = math.sqrt(nb / na), math.sqrt(na / nb)
    stat = float(np.sum((k1 * aa - k2 * bb) ** 2 / (aa + bb)))
    dof = max(1, len(aa) - 1)
    p = float(stats.chi2.sf(stat, dof))
    passed = p > level
    reason = (
        f"the two sample sets agree ({len(aa)} pooled cells)"
        if passed
        else f"the two sample sets differ: p = {p:.3g} <= {level:.3g} ({len(aa)} pooled cells)"
    )
    return Chi2Result(passed, reason, p, stat, dof, level, float("nan"), na + nb, domain)


def integrate_pdf(pdf: PdfFn, resolution: tuple[int, int] = (64, 64), cell_tol: float = 1e-10) -> float:
    """Integral of a density per unit solid angle over the whole sphere (self-refining quadrature)."""
    n_phi, n_cos = resolution
    return float(
        integrate_cells(
            pdf, np.linspace(0.0, TWO_PI, n_phi + 1), np.linspace(-1.0, 1.0, n_cos + 1), cell_tol=cell_tol
        ).sum()
    )


def sampler_functions(sampler: Any, wo: np.ndarray) -> tuple[SampleFn, PdfFn]:
    """``sample(n, seed)`` and ``pdf(wi)`` callables for a :class:`core.sampling.Sampler` at direction ``wo``."""
    wo = np.asarray(wo, dtype=np.float64).reshape(3)

    def sample(n: int, seed: int) -> np.ndarray:
        return sampler.sample(wo, n, seed).wi

    def pdf(wi: np.ndarray) -> np.ndarray:
        return sampler.pdf(np.broadcast_to(wo, wi.shape), wi)

    return sample, pdf
