"""Draws below the horizon: every non-adaptive sampler either does not return them (``pdf = 0``, ``f = 0``) or
reports their density in ``pdf`` too, so that its density integrates to 1 over the sphere
(the convention of :mod:`core.sampling.base`; issue 15, "A second opinion on every sampler").

For each sampler x material x grazing ``wo`` (GGX alpha = 0.5, whose visible normals reflect ``wo`` below the
horizon; Blinn's half-vector lobe; anisotropic Ward sx = 0.05, sy = 0.25 at phi_o = 35 deg), at theta_o = 80
and 89 deg, with ``N_DRAWS`` draws of a fixed seed:

(a) the fraction of all draws returned (``pdf > 0``) below the horizon (``wi.z <= 0``) equals the integral of
    ``pdf`` over the lower hemisphere within ``4 sigma`` of the binomial noise plus ``QUADRATURE_TOL``, or
    both are exactly 0;
(b) every returned draw carries the density ``pdf(wo, wi)`` gives at its ``wi``, to ``PDF_RTOL`` relative;
(c) a draw below the horizon or not returned carries ``f = 0``.

The lower-hemisphere integral is a composite Gauss-Legendre rule in polar coordinates ``(rho, psi)`` about
``-wo``: half-vector samplers have the integrable singularity ``1 / (2 |wi + wo|)`` there, just below the horizon
at grazing ``wo``, and the polar area element ``sin(rho)`` cancels it. For each ``psi`` the ``rho`` range is
split where ``(wi + wo).z = 0`` (the edge of GGX's visible normals) and ends exactly on the horizon. Against 4x
finer panels the integral moves by < 1e-6 for the analytic (smooth) densities and by 7e-5 for the factored
sampler's piecewise-constant one (Ward at 89 deg), whose estimates at intermediate resolutions spread over 3e-4:
hence ``QUADRATURE_TOL``. In the 10 cases with mass below the horizon the draws agree with it within 2.3 sigma.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from core.brdf import make_brdf
from core.geometry import degrees_to_dir
from core.sampling import make_sampler, sampler_names
from core.sampling.ris import ris_sample

ADAPTIVE = {"adaptive_exact", "adaptive_warp"}
"""Left out here while their package is reworked (issue 15); ``test_mitsuba_chi2.py`` covers them."""
N_DRAWS = 400_000
SEED = 15
PDF_RTOL = 1e-12
"""The draws' densities are computed by the same arithmetic as ``pdf``: equal in practice to the last bit."""
QUADRATURE_TOL = 5e-4
N_SIGMA = 4.0
PSI_PANELS, RHO_PANELS, ORDER = 128, 32, 8

MATERIALS = {
    "ggx(alpha=0.5)": ("ggx", {"alpha": 0.5}, 0.0),
    "blinn": ("blinn", None, 0.0),
    "ward(sx=0.05,sy=0.25)": ("ward", {"sx": 0.05, "sy": 0.25}, 35.0),
}
THETAS = (80.0, 89.0)
SMALL_TABLES: dict[str, dict[str, Any]] = {"uniform_cdf": {"n_theta_o": 8}, "compress_cdf": {"n_theta_o": 8}}
"""Fewer ``theta_o`` bins than the defaults (32, 16 anisotropic) to keep the builds short: the tables' draws stay
above the horizon whatever their resolution."""


def _non_adaptive() -> list[str]:
    return [name for name in sampler_names() if name not in ADAPTIVE]


_SAMPLERS: dict[tuple[str, str], Any] = {}


def _sampler(name: str, material: str) -> Any:
    key = (name, material)
    if key not in _SAMPLERS:
        model, params, _ = MATERIALS[material]
        _SAMPLERS[key] = make_sampler(name, make_brdf(model, params), **SMALL_TABLES.get(name, {}))
    return _SAMPLERS[key]


def below_horizon_integral(pdf: Any, wo: np.ndarray) -> float:
    """Integral of ``pdf`` (``wi (m, 3) -> (m,)`` per unit solid angle) over the lower hemisphere ``wi.z < 0``.

    Directions ``cos(rho) a + sin(rho) (cos(psi) t + sin(psi) b)`` about ``a = -wo`` with ``t`` in the plane of
    ``a`` and the normal (``t.z = sin(theta_o)``, ``b.z = 0``): ``z = -cos(theta_o) cos(rho) + sin(theta_o)
    cos(psi) sin(rho)``, negative for ``rho < pi/2 - delta`` with ``delta = atan2(sin(theta_o) cos(psi),
    cos(theta_o))``, and equal to ``-wo.z`` (where ``wi + wo`` crosses the horizon) at ``rho = -2 delta``.
    """
    a = -np.asarray(wo, dtype=np.float64)
    cos_o = float(wo[2])
    sin_o = math.sqrt(max(0.0, 1.0 - cos_o * cos_o))
    t = np.array([0.0, 0.0, 1.0]) - a[2] * a
    t = t / np.linalg.norm(t) if sin_o > 0.0 else np.array([1.0, 0.0, 0.0])
    b = np.cross(a, t)
    x, w = np.polynomial.legendre.leggauss(ORDER)
    x, w = 0.5 * (x + 1.0), 0.5 * w

    def nodes(lo: np.ndarray, hi: np.ndarray, panels: int) -> tuple[np.ndarray, np.ndarray]:
        """Composite rule on ``[lo, hi]`` per row: nodes and weights ``(m, panels * ORDER)``."""
        edges = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, panels + 1)[None, :]
        width = np.diff(edges, axis=1)[:, :, None]
        return (
            (edges[:, :-1, None] + width * x).reshape(len(lo), -1),
            (width * w).reshape(len(lo), -1),
        )

    psi, w_psi = (v[0] for v in nodes(np.array([-math.pi]), np.array([math.pi]), PSI_PANELS))
    delta = np.arctan2(sin_o * np.cos(psi), cos_o)
    split = np.maximum(-2.0 * delta, 0.0)
    rho_a, w_a = nodes(np.zeros_like(split), split, RHO_PANELS)
    rho_b, w_b = nodes(split, 0.5 * math.pi - delta, RHO_PANELS)
    rho, w_rho = np.concatenate([rho_a, rho_b], axis=1), np.concatenate([w_a, w_b], axis=1)
    around = np.cos(psi)[:, None, None] * t + np.sin(psi)[:, None, None] * b
    wi = np.cos(rho)[..., None] * a + np.sin(rho)[..., None] * around
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    weight = np.sin(rho) * w_rho * w_psi[:, None]
    used = weight > 0.0  # not the nodes of empty ranges (at wi = -wo when theta_o = 90 deg)
    return float(np.sum(np.asarray(pdf(wi[used]), dtype=np.float64) * weight[used]))


def test_below_horizon_integral_of_known_densities():
    """The rule on densities whose lower-hemisphere mass is 1/2: uniform over the sphere (``wo`` at 89 deg),
    and ``1 / (4 pi |wi + wo|)`` (it integrates to 1 over the sphere) with ``wo`` on the horizon, where it is
    symmetric in ``z``: the half-vector samplers' singularity, at the point where the rule's ranges meet."""

    def uniform(wi: np.ndarray) -> np.ndarray:
        return np.full(len(wi), 0.25 / math.pi)

    assert below_horizon_integral(uniform, degrees_to_dir(89.0, 20.0)) == pytest.approx(0.5, abs=1e-12)
    wo = degrees_to_dir(90.0, 20.0)

    def singular(wi: np.ndarray) -> np.ndarray:
        return 1.0 / (4.0 * math.pi * np.linalg.norm(wi + wo, axis=1))

    assert below_horizon_integral(singular, wo) == pytest.approx(0.5, abs=1e-9)


@pytest.mark.parametrize("theta", THETAS)
@pytest.mark.parametrize("material", list(MATERIALS))
@pytest.mark.parametrize("name", _non_adaptive())
def test_draws_below_horizon_are_in_pdf_or_not_returned(name, material, theta):
    sampler = _sampler(name, material)
    wo = degrees_to_dir(theta, MATERIALS[material][2])
    drawn = sampler.sample(wo, N_DRAWS, SEED)
    returned = drawn.pdf > 0.0
    below = drawn.wi[:, 2] <= 0.0

    # (b) the returned draws carry the density pdf gives at them
    at = sampler.pdf(np.broadcast_to(wo, drawn.wi.shape), drawn.wi)
    off = returned & ~np.isclose(at, drawn.pdf, rtol=PDF_RTOL, atol=0.0)
    assert not np.any(off), (
        f"{int(off.sum())} draws carry a pdf other than pdf(wo, wi), e.g. wi={drawn.wi[off][0]}: "
        f"{drawn.pdf[off][0]!r} vs {at[off][0]!r}"
    )
    # (c) no energy below the horizon or in a draw not returned
    assert np.all(drawn.f[below | ~returned] == 0.0)

    # (a) the fraction returned below the horizon is the lower hemisphere's share of pdf
    fraction = float(np.mean(returned & below))
    integral = below_horizon_integral(lambda wi: sampler.pdf(np.broadcast_to(wo, wi.shape), wi), wo)
    if integral == 0.0:
        assert fraction == 0.0, f"{fraction:.3g} of the draws are returned below the horizon; pdf is 0 there"
        return
    sigma = math.sqrt(integral * (1.0 - integral) / N_DRAWS)
    assert abs(fraction - integral) <= N_SIGMA * sigma + QUADRATURE_TOL, (
        f"{fraction:.5f} of the draws returned below the horizon, pdf integrates to {integral:.5f} there "
        f"(sigma {sigma:.1e})"
    )


def test_ris_keeps_no_draw_below_horizon():
    """RIS's target ``f cos L`` is 0 below the horizon: such a candidate is kept only when every candidate of
    its sample has target 0, and then with weight 0."""
    sampler = make_sampler("analytic", make_brdf("ggx", {"alpha": 0.5}))
    kept = ris_sample(sampler, degrees_to_dir(89.0), lambda wi: np.ones(len(wi)), 20_000, 4, seed=SEED)
    below = kept.wi[:, 2] <= 0.0
    assert np.all(kept.weight[below] == 0.0)
    assert np.all(kept.f[below] == 0.0)
