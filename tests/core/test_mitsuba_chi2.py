"""A second opinion on every sampler: Mitsuba 3's own chi-square test (``mitsuba.chi2.ChiSquareTest``).

Every name of ``sampler_names()`` x a spread of materials x outgoing directions (``CASES``; ``uniform`` and
``cosine`` ignore the BRDF and ``wo``, so they run on one material only), and the two adaptive modes again
drawing from Mitsuba's own sample points (``adaptive_exact+points``, ``adaptive_warp+points``: the renderer's path
at a path's first two bounces, where the rejection-free mode descends its tree by the points). Run with
``pytest -m slow -s tests/core/test_mitsuba_chi2.py`` to see the table of p-values and timings.

What runs is Mitsuba's test: variant ``llvm_ad_rgb``, its ``SphericalDomain`` (``x = phi`` in ``[-pi, pi]``,
``y = -cos(theta)`` in ``[-1, 1]``), its default resolution (``res = 101``: 50 x 101 cells), its histogram
of 1e6 of our directions (in float32), its pooling of cells expecting < 5, its statistic and p-value, and its
Sidak correction (``run(alpha=0.01, test_count=len(CASES))``).

The adapter. Mitsuba calls ``sample_func(sample)`` once with ``sample_count`` uniform points and maps what it
returns to its grid; our samplers draw from their own seeded streams, so the adapter ignores the points'
values and returns that many directions of ``sampler.sample(wo, n, SEED)`` (a fixed set); the ``+points``
cases hand the points to ``sampler.sample_into(..., points=)`` instead. ``pdf_func(d)`` is
``sampler.pdf(wo, d)``.

One substitution: the expected counts. Mitsuba's ``tabulate_pdf`` integrates the pdf over each cell with a
4 x 4-point trapezoid rule (``ires = 4``). For three kinds of density we have, its error is far above the
statistical noise of 1e6 samples, so it rejects correct samplers. Measured (the same 1e6
directions for every table; p-values with Mitsuba's table at ``ires`` = 4 / 8 / 32, then with ours):

- lobes about as narrow as a cell near the pole, where the (phi, cos theta) cells are wide in theta:
  ``adaptive``, Poulin-Fournier at theta_o = 10 deg (the case of the issue): the pole row's cells
  (cos > 0.980) expect 24 110 counts in Mitsuba's table, 25 329 in ours, and hold 25 062 and 25 682;
  p = 0 / 0 / 0.17, ours 0.20;
- piecewise-constant densities (``uniform_cdf``, ``compress_cdf``, ``factored``) whose steps fall inside
  Mitsuba's cells: ``compress_cdf`` GGX at 45 deg, p = 0 / 0.049 / 0.37, ours 0.41; ``factored`` Phong at
  85 deg, 0 / 0.050 / 0.41, ours 0.85; ``uniform_cdf`` Poulin-Fournier at 10 deg, 0 / 1e-4 / 0.12, ours 0.17.
  (``factored`` Cook-Torrance m = 0.2 at 30 deg, which the issue saw rejected at p = 7e-6, passes today with
  either table: 0.032 / 0.035 / 0.88, ours 0.92.);
- the integrable singularity ``1 / (2 |wi + wo|)`` of half-vector samplers at ``wi = -wo``, just below the
  horizon at grazing ``wo``: Blinn's analytic sampler at 85 deg: Mitsuba's table sums to 1.211 / 1.089 / 1.033
  (at ``ires = 4`` its own sanity check, sum <= 1.1, fails), p = 0 at every ``ires``; ours sums to 1.000000,
  p = 0.80. Ward sx = 0.05, sy = 0.25 at 85 deg, phi_o = 35 deg: sums 0.831 / 1.047 / 0.999, p = 0; ours 0.69.

Where Mitsuba's table converges with ``ires`` it converges to ours: at ``ires = 32`` no cell differs from ours
by more than 110 counts in the cases above, except the two singular ones (6 000 and 26 000 counts, next to
``-wo``). So :class:`_CellIntegralChiSquareTest` replaces ``tabulate_pdf`` only: the same pdf integrated over
the same cells (taken from the test's ``res`` and the domain's bounds) by :func:`_cell_integrals`. Every row of
the printed table (``-s``; a row is printed before its case's verdict) shows Mitsuba's own p-value and table sum
beside ours. In a run of all 288 cases Mitsuba's own table rejected 130 (every sampler's but
``uniform``'s and ``cosine``'s); ours rejected none, its sums within 1 +- 1.6e-4.

Each cell is split into 4 x 4 sub-cells (a self-refining rule on the whole cell, or on 2 x 2 sub-cells, is
fooled by the regular steps of a tabulated density: ``uniform_cdf`` Ashikhmin-Shirley nu = 10, nv = 200 at
85 deg, whose table then sums to 0.9928 or 0.9920 instead of 1.00002), with extra edges graded geometrically
towards ``-wo`` (half-vector samplers put a ridge of density ~ ``1 / |wi + wo|`` there: the analytic Ward
above has 1.41 % of its draws in the cell of ``-wo``, which gets 13 892 expected counts without the grading and
14 020 with it, and the table's sum goes from 0.99987 to 0.999999; the grading stops at 1/4096 of a cell, and
24 levels change that cell by less than a count). Each sub-cell is integrated by the self-refining
Gauss-Legendre rule of :func:`core.chi2.integrate_cells` (order 4, to 0.1 expected counts, at most 4
refinements: 6 refinements cost 2-3 times as much and move no cell by more than 12 counts). The table must also
sum to 1 within 1e-3 (Mitsuba only checks > 1.1): a quadrature that missed mass, or a pdf that does not
integrate to 1, fails here rather than passes.

Runtime: 288 cases in 25-28 minutes on one core (``pytest -p no:xdist -m slow``, on a 2-core
machine shared with another job): about 1.5 s a case for the analytic samplers, 4-7 s for the tabulated and
adaptive ones (mostly the cell integrals: a piecewise-constant density takes ~26 million pdf evaluations), and
the adaptive tables' builds (up to half a minute for anisotropic Ashikhmin-Shirley). ``make test`` does not run
it (``-m 'not slow'`` in pytest's ``addopts``); ``make test-slow`` does.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

import numpy as np
import pytest

from core.brdf import get_model, make_brdf
from core.chi2 import integrate_cells
from core.geometry import degrees_to_dir
from core.sampling import make_sampler, sampler_names

mi = pytest.importorskip("mitsuba")
import drjit as dr  # noqa: E402  (installed with mitsuba)
from mitsuba.chi2 import ChiSquareTest, SphericalDomain  # noqa: E402

VARIANT = "llvm_ad_rgb"
N_SAMPLES = 1_000_000
SEED = 1
ALPHA = 0.01
INTEGRAL_TOL = 1e-3
SUBDIVISION = 4
GRADING_LEVELS = 12
CELL_TOL = 0.1 / N_SAMPLES  # per sub-cell
MAX_DEPTH = 4

ISO_VIEWS = ((10.0, 0.0), (45.0, 0.0), (85.0, 0.0))
ANISO_VIEWS = ISO_VIEWS + ((10.0, 35.0), (45.0, 35.0), (85.0, 35.0))
PLACED = ("adaptive_exact", "adaptive_warp")
"""Samplers also tested drawing from Mitsuba's own sample points (the adapter's ``placed`` path)."""
PLACED_SUFFIX = "+points"
BRDF_INDEPENDENT = {"uniform", "cosine"}
"""Samplers whose density depends on neither the BRDF nor ``wo``: tested with the first material only."""


@dataclass(frozen=True)
class Material:
    label: str
    model: str
    params: dict[str, Any] | None = None
    views: tuple[tuple[float, float], ...] = ISO_VIEWS

    def brdf(self) -> Any:
        if self.model == "merl":
            from core.merl import measured_brdf

            return measured_brdf(str(resources.files("resources.materials") / "red_plastic_ct.binary"))
        return make_brdf(self.model, self.params)

    def has_analytic_sampler(self) -> bool:
        return self.model != "merl" and get_model(self.model).sample is not None


MATERIALS = (
    Material("lambert", "lambert"),
    Material("phong", "phong"),
    Material("blinn", "blinn"),
    Material("cook_torrance", "cook_torrance"),
    # 30 deg: the case the issue saw rejected (factored sampler)
    Material("cook_torrance(m=0.2)", "cook_torrance", {"m": 0.2}, ISO_VIEWS + ((30.0, 0.0),)),
    Material("ggx", "ggx"),
    Material("ward(sx=0.05,sy=0.25)", "ward", {"sx": 0.05, "sy": 0.25}, ANISO_VIEWS),
    Material("ashikhmin_shirley(nu=10,nv=200)", "ashikhmin_shirley", {"nu": 10.0, "nv": 200.0}, ANISO_VIEWS),
    Material("poulin_fournier", "poulin_fournier", None, ANISO_VIEWS),
    Material("lafortune", "lafortune", None, ANISO_VIEWS),
    Material("oren_nayar(sigma=0.5)", "oren_nayar", {"sigma": 0.5}),
    Material(
        "disney(anisotropic=0.8,clearcoat=1)", "disney", {"anisotropic": 0.8, "clearcoat": 1.0}, ANISO_VIEWS
    ),
    Material("merl:red_plastic_ct", "merl"),
)


def _cases() -> list[tuple[str, Material, float, float]]:
    cases = []
    for name in sampler_names():
        for k, material in enumerate(MATERIALS):
            if name in BRDF_INDEPENDENT and k > 0:
                continue
            if name == "analytic" and not material.has_analytic_sampler():
                continue
            cases += [(name, material, theta, phi) for theta, phi in material.views]
    # the renderer's first two bounces: the adaptive modes' proposals from a caller's points
    # (``sample_into(..., points=)``: the rejection-free mode descends its tree by them)
    for name in PLACED:
        cases += [(name + PLACED_SUFFIX, m, theta, phi) for m in MATERIALS for theta, phi in m.views]
    return cases


CASES = _cases()
N_TESTS = len(CASES)


# ----------------------------------------------------------------------------------------------------------
# Mitsuba's test with exact cell integrals, and the adapter


def _cell_integrals(density: Any, phi_edges: np.ndarray, cos_edges: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """Integrals of ``density`` (per unit solid angle) over the cells ``(cos row, phi column)`` of the grid:
    each cell split into ``SUBDIVISION`` x ``SUBDIVISION`` sub-cells, plus sub-cell edges at
    ``-wo +- cell width * 2^-j`` (``j <= GRADING_LEVELS``; also across the seam phi = +-pi), every sub-cell
    integrated by :func:`core.chi2.integrate_cells` and added to the cell that contains it."""

    def split(edges: np.ndarray) -> np.ndarray:
        t = np.arange(SUBDIVISION) / SUBDIVISION
        return np.concatenate([(edges[:-1, None] + np.diff(edges)[:, None] * t).ravel(), edges[-1:]])

    def graded(edges: np.ndarray, centres: list[float], width: float) -> np.ndarray:
        extra = [
            c + sign * width * 2.0**-j for c in centres for j in range(GRADING_LEVELS + 1) for sign in (-1, 1)
        ]
        extra = [x for x in extra + centres if edges[0] < x < edges[-1]]
        return np.unique(np.concatenate([edges, extra]))

    phi_s = math.atan2(-wo[1], -wo[0])
    sub_phi = graded(
        split(phi_edges), [phi_s - 2.0 * math.pi, phi_s, phi_s + 2.0 * math.pi], phi_edges[1] - phi_edges[0]
    )
    sub_cos = graded(split(cos_edges), [-float(wo[2])], cos_edges[1] - cos_edges[0])
    sub = integrate_cells(density, sub_phi, sub_cos, order=4, cell_tol=CELL_TOL, max_depth=MAX_DEPTH)
    rows = np.searchsorted(cos_edges, 0.5 * (sub_cos[:-1] + sub_cos[1:])) - 1
    cols = np.searchsorted(phi_edges, 0.5 * (sub_phi[:-1] + sub_phi[1:])) - 1
    out = np.zeros((len(cos_edges) - 1, len(phi_edges) - 1))
    np.add.at(out, (rows[:, None], cols[None, :]), sub.reshape(len(rows), len(cols)))
    return out


class _CellIntegralChiSquareTest(ChiSquareTest):
    """Mitsuba's ``ChiSquareTest`` with ``tabulate_pdf`` computing each cell's expected count by
    :func:`_cell_integrals` (see the module docstring); everything else is Mitsuba's."""

    def __init__(self, density: Any, wo: np.ndarray, **kwargs: Any):
        super().__init__(**kwargs)
        self.density = density  # wi (m, 3) float64 -> pdf (m,) per unit solid angle
        self.wo = wo

    def tabulate_pdf(self) -> None:
        self.histogram_start = time.time()  # (sic) Mitsuba's names for the timing of the pdf table
        nx, ny = int(self.res.x), int(self.res.y)
        lo, hi = self.bounds.min, self.bounds.max
        phi_edges = np.linspace(float(lo.x), float(hi.x), nx + 1)
        y_edges = np.linspace(float(lo.y), float(hi.y), ny + 1)  # y = -cos(theta)
        probs = _cell_integrals(self.density, phi_edges, -y_edges[::-1], self.wo)
        table = probs[::-1].ravel()  # rows of increasing cos -> rows of increasing y
        self.pdf = mi.Float(table * self.sample_count)
        self.pdf_sum = dr.sum(self.pdf) / self.sample_count
        if not np.all(table >= 0.0):
            self._log(f"Failure: Encountered a cell with a negative PDF value: {table.min()}")
            self.fail = True
        if abs(table.sum() - 1.0) > INTEGRAL_TOL:
            self._log(f"Failure: PDF integrates to {table.sum():.6f}, not 1 (tolerance {INTEGRAL_TOL:g})")
            self.fail = True
        self.histogram_end = time.time()


def _mitsuba_functions(sampler: Any, wo: np.ndarray, placed: bool = False) -> tuple[Any, Any, Any]:
    """``sample_func`` and ``pdf_func`` for Mitsuba (float32 arrays), and the float64 density for the table.
    ``placed``: the draws take Mitsuba's sample points as the caller's points of ``sample_into`` (what the
    renderer hands the strategies at the first two bounces); otherwise they come from the sampler's stream."""
    drawn: dict[int, Any] = {}

    def sample_func(sample: Any) -> Any:
        n = dr.width(sample)
        if n not in drawn:  # the same directions for both tests of a case
            if placed:
                points = np.stack([np.asarray(sample.x), np.asarray(sample.y)], axis=1).astype(np.float64)
                points = np.minimum(points, 1.0 - 2.0**-53)  # float32 points round up to 1 at times
                wi, pdf, f = np.empty((n, 3)), np.empty(n), np.empty((n, 3))
                sampler.sample_into(
                    np.ascontiguousarray(np.tile(wo, (n, 1))), SEED, wi, pdf, f, points=points
                )
            else:
                wi = np.asarray(sampler.sample(wo, n, SEED)[0], dtype=np.float64)
            drawn[n] = mi.Vector3f(*(np.ascontiguousarray(wi[:, k], dtype=np.float32) for k in range(3)))
        return drawn[n]

    def density(wi: np.ndarray) -> np.ndarray:
        return np.asarray(sampler.pdf(np.broadcast_to(wo, wi.shape), wi), dtype=np.float64)

    def pdf_func(d: Any) -> Any:
        wi = np.stack([np.asarray(d.x), np.asarray(d.y), np.asarray(d.z)], axis=1).astype(np.float64)
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        return mi.Float(density(wi).astype(np.float32))

    return sample_func, pdf_func, density


# ----------------------------------------------------------------------------------------------------------
# Fixtures: the variant, a private table cache, built samplers, the results table


@pytest.fixture
def llvm_variant():
    """Mitsuba's variant for this test only (``tests/core/test_mitsuba_crosscheck.py`` uses ``scalar_rgb``)."""
    previous = mi.variant()
    try:
        mi.set_variant(VARIANT)
    except ImportError as exc:  # no libLLVM
        pytest.skip(f"Mitsuba variant {VARIANT} unavailable ({exc}); run `bash .ci/system-deps.sh` as root")
    yield
    if previous is not None and previous != VARIANT:
        mi.set_variant(previous)


@dataclass
class _Results:
    rows: list[str] = field(default_factory=list)
    started: float = field(default_factory=time.perf_counter)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Samplers keep their tables in a folder of this module; the table of results is printed at the end."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("BRDF_STUDIO_CACHE", str(tmp_path_factory.mktemp("tables")))
        res = _Results()
        yield res
    print(f"\nMitsuba chi2 ({VARIANT}, {N_SAMPLES:.0e} samples, alpha {ALPHA} Sidak over {N_TESTS} tests):")
    print("\n".join(res.rows))
    print(f"{len(res.rows)} tests in {time.perf_counter() - res.started:.0f} s")


_SAMPLERS: dict[tuple[str, str], Any] = {}


def _sampler(name: str, material: Material) -> tuple[Any, float]:
    """The sampler (built once per module), and the seconds its build took now (0 when it was built before)."""
    name = name.removesuffix(PLACED_SUFFIX)
    key = (name, material.label)
    if key in _SAMPLERS:
        return _SAMPLERS[key], 0.0
    t0 = time.perf_counter()
    _SAMPLERS[key] = make_sampler(name, material.brdf())
    return _SAMPLERS[key], time.perf_counter() - t0


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "material", "theta", "phi"),
    CASES,
    ids=[f"{n}-{m.label}-{t:g}-{p:g}" for n, m, t, p in CASES],
)
def test_mitsuba_chi2(name, material, theta, phi, llvm_variant, results):
    sampler, build_seconds = _sampler(name, material)
    wo = degrees_to_dir(theta, phi)
    sample_func, pdf_func, density = _mitsuba_functions(sampler, wo, placed=name.endswith(PLACED_SUFFIX))
    t0 = time.perf_counter()
    test = _CellIntegralChiSquareTest(
        density,
        wo,
        domain=SphericalDomain(),
        sample_func=sample_func,
        pdf_func=pdf_func,
        sample_count=N_SAMPLES,
    )
    passed = test.run(ALPHA, N_TESTS, quiet=True)
    # For information: the verdict with Mitsuba's own table of the same pdf (same directions).
    own = ChiSquareTest(
        domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func, sample_count=N_SAMPLES
    )
    own_passed = own.run(ALPHA, N_TESTS, quiet=True)
    seconds = time.perf_counter() - t0

    def first(value: Any) -> float:
        return float(np.asarray(value).ravel()[0])

    p, p_own = first(test.p_value), first(own.p_value)
    row = (
        f"{name:13s} {material.label:32s} theta_o={theta:4.0f} phi_o={phi:3.0f}  "
        f"p={p:9.3g} {'pass' if passed else 'FAIL'} (sum {first(test.pdf_sum):.5f})  "
        f"Mitsuba's table: p={p_own:9.3g} {'pass' if own_passed else 'fail'} (sum {first(own.pdf_sum):.5f})  "
        f"{seconds:5.1f} s" + (f" (make_sampler {build_seconds:.1f} s)" if build_seconds else "")
    )
    results.rows.append(row)
    print(row)
    assert passed, f"{name} {material.label} theta_o={theta} phi_o={phi}:\n{test.messages}"
    assert math.isfinite(p)
