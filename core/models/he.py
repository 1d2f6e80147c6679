"""He-Torrance-Sillion-Greenberg physical reflection model (X. D. He, K. E. Torrance, F. X. Sillion and
D. P. Greenberg, "A comprehensive physical model for light reflection", SIGGRAPH 1991, 175-186).

Wave optics (Kirchhoff diffraction) from an isotropic surface with Gaussian heights of rms roughness
``sigma`` and Gaussian autocorrelation of length ``tau``, lit at wavelength ``lambda``. The paper splits the
BRDF into ``rho_sp + rho_dd + rho_ud``; this module evaluates ``rho_dd + rho_ud``.

Directional diffuse (the paper's eqs. for ``rho_bd,dd``, ``D``, ``G``, ``g``, ``sigma_0``, ``S``), with
``k_i = -wi`` the incident and ``k_r = wo`` the reflected propagation directions, ``v = k (k_r - k_i) =
k (wi + wo)``, ``k = 2 pi / lambda``:

    rho_dd = F(theta_b) / pi * G S D / (cos theta_i cos theta_r)
    D      = (pi^2 tau^2 / (4 lambda^2)) sum_{m>=1} g^m e^{-g} / (m! m) exp(-tau^2 v_xy^2 / (4 m))
    g      = (2 pi sigma_0 / lambda)^2 (cos theta_i + cos theta_r)^2
    G      = (v.v / v_z)^2 / |k_r x k_i|^4 [(s_r.k_i)^2 + (p_r.k_i)^2] [(s_i.k_r)^2 + (p_i.k_r)^2]
    S      = S_i S_r,  S(theta) = (1 - erfc(mu)/2) / (Lambda(mu) + 1),  mu = tau cot(theta) / (2 sigma),
             Lambda = (exp(-mu^2) / (sqrt(pi) mu) - erfc(mu)) / 2

* ``F`` is the exact Fresnel reflectance of the conductor ``n + i k`` (unpolarized) at the local angle
  ``theta_b`` between ``wi`` and the bisector of ``wi`` and ``wo`` (``cos theta_b = |wi + wo| / 2``).
* For unpolarized light the polarization vectors ``s, p`` of each beam form an orthonormal frame with its
  ``k``, so each bracket equals ``|k_r x k_i|^2`` and ``G`` reduces to ``(v.v / v_z)^2`` (exactly).
* ``sigma_0 = sigma (1 + z0^2/sigma^2)^(-1/2)`` is the effective roughness of the illuminated and visible
  surface, with ``z0`` the root of ``sqrt(pi/2) z0 = (sigma/4) (K_i + K_r) exp(-z0^2/(2 sigma^2))``,
  ``K = tan(theta) erfc(tau cot(theta) / (2 sigma))``, found by Halley's method (see ``_he_series``; the kernel
  reads its logarithm from a table of it against ``ln(K_i + K_r)``, within 4e-15). It tends to ``sigma`` at
  normal incidence and to 0 at grazing incidence.
* The series is summed adaptively around its peak for every ``g`` (see ``_he_series.diffuse_series``), so the
  smooth (``g << 1``, first term dominant), intermediate and rough (``g >> 1``) regimes use the same sum. The
  paper's rough-surface approximation ``sum ~ exp(-tau^2 v_xy^2 / (4 g)) / g`` is its large-``g`` limit, in
  which ``rho_dd`` becomes the Torrance-Sparrow form ``F D_Beckmann S / (4 cos_i cos_r)`` with Beckmann slope
  ``m = 2 sigma / tau``; the tests check both limits.
* Tabulated series (the kernel's cost): for ``0.1 <= g <= 128`` and ``a = tau^2 v_xy^2 / 4 <= 1024`` (the
  seed's settings reach ``g = 61.7``, ``a = 555``) the kernel reads ``ln`` of the sum from two tables computed
  once from the sum itself (shipped as ``_he_series.npz``, read at import), on nodes every 1/32 of ``ln g``
  and every 1/32 (``g >= 1``) or 1/64 (``g < 1``) of ``ln(1 + a)``, by six-by-six-node Lagrange interpolation
  (``_he_series.tabulated_series_log``); elsewhere it sums the series. The interpolant's error is of order ``h^6`` times derivatives of ``ln sum``, which are
  cumulants of ``m`` and ``1/m`` under the terms' weights (bounded, and largest where few terms matter: near
  ``g = 1``, ``a = 5``); it is bounded by measurement, not proof: 8.4e-10 at most on 16 points of every
  cell of both tables and 10^6 random points, 8.5e-10 for ``f`` against the summed kernel on 500 000
  pairs (random and grazing) at each of six settings. ``f`` is therefore within ``TABLE_TOL = 2e-9`` (relative) of the summed
  series' value, the tolerance of the tests against the previous formulation (``tests/core/models``); the
  paper's formulas are still met to 1e-8. A relative error of 2e-9 is far below anything a renderer or
  the sampler can resolve (the adaptive table's bounds are made from these same values); with the tables ``f``
  takes 190-250 ns a random pair, against 700-750 with the series summed (30 to 60 exponentials).

Uniform diffuse: the paper's ``rho_ud = a(lambda)``, a constant for the subsurface and multiply scattered
light; we parameterize it by its albedo ``kd``: ``rho_ud = kd / pi``.

Specular term (left out): ``rho_sp = |F(theta_i)|^2 e^{-g} S / (cos theta_i d omega_i) Delta`` is a Dirac delta
in the mirror direction (the coherently reflected beam, weight ``|F|^2 e^{-g(theta_i, theta_i)} S`` with the
effective roughness). A delta has no finite value, so it cannot be evaluated, tabulated or sampled as a density
by the generic machinery; a renderer must treat it as a separate perfect-mirror lobe. :func:`specular_weight`
gives its reflectance for that purpose. Consequently the directional albedo of this BRDF excludes that
fraction (large for smooth surfaces: ``e^{-g}`` is close to 1 when ``sigma << lambda``).

Wavelength and colour: the model is evaluated at the single wavelength ``lambda`` (the seed's 800 nm); the
complex index ``n + i k`` and ``kd`` are RGB, so the three channels share the geometry and differ by Fresnel.

Numerical care: ``S / cos`` is computed in a form free of ``0/0`` at grazing and normal incidence; ``K`` is
taken as 0 where ``erfc`` underflows (``ln K`` of ``log_k`` uses an asymptotic ``ln erfc`` there); the series
works in logarithms around its peak, its tables hold its logarithm (no underflow in them); the value
is finite for every pair of directions with ``z > 0`` and 0 otherwise. The formula is symmetric in ``wi`` and
``wo`` (reciprocal) and depends on azimuths only through ``wi + wo`` and the polar angles (isotropic). It is
not guaranteed to conserve energy (the Kirchhoff approximation is not), so the trait is not claimed.

Seed parameters: ``HE sigma = 0.5, tau = 3, lambda = 800`` (micrometres, micrometres, nanometres). The default
index ``n = 2.8, k = 8.4`` is a neutral metal-like conductor (the seed does not give one); ``kd = 0``.
"""

from __future__ import annotations

import math

import numpy as np

from core.brdf import Param, Traits, declare, param_offsets, param_row_size
from core.jit import kernel
from core.models._fresnel import fresnel_conductor
from core.models._he_series import (
    direction_k,
    effective_roughness_ratio,
    log_k,
    log_roughness_ratio_of_k,
    shadow_over_cos,
    tabulated_series_log,
)

CITATION = (
    "X. D. He, K. E. Torrance, F. X. Sillion and D. P. Greenberg, A comprehensive physical model for "
    "light reflection, Proc. SIGGRAPH 1991, 175-186."
)

INV_PI = 0.3183098861837907
TWO_PI = 6.283185307179586


PARAMS = (
    Param(
        "sigma",
        0.5,
        0.005,
        10.0,
        unit="µm",
        label="RMS roughness",
        log=True,
        doc="Standard deviation of the surface heights (the seed's sigma).",
    ),
    Param(
        "tau",
        3.0,
        0.05,
        100.0,
        unit="µm",
        label="Autocorrelation length",
        log=True,
        doc="Length of the Gaussian height autocorrelation (the seed's tau); rms slope ~ 2 sigma/tau.",
    ),
    Param(
        "wavelength",
        800.0,
        200.0,
        3000.0,
        unit="nm",
        label="Wavelength",
        doc="Wavelength of the light (the seed's lambda).",
    ),
    Param(
        "n",
        (2.8, 2.8, 2.8),
        0.02,
        10.0,
        label="Refractive index (real)",
        kind="color",
        doc="Real part of the complex refractive index, per RGB channel.",
    ),
    Param(
        "k",
        (8.4, 8.4, 8.4),
        0.0,
        20.0,
        label="Extinction coefficient",
        kind="color",
        doc="Imaginary part of the complex refractive index (0 for a dielectric), per RGB channel.",
    ),
    Param(
        "kd",
        (0.0, 0.0, 0.0),
        0.0,
        1.0,
        label="Uniform diffuse albedo",
        kind="color",
        doc="Albedo of the uniform diffuse term: rho_ud = a(lambda) = kd / pi.",
    ),
)
_SIGMA, _TAU, _LAMBDA, _N, _K, _KD = param_offsets(PARAMS, "sigma", "tau", "wavelength", "n", "k", "kd")
# derive_he appends k = 2 pi / lambda, tau / (2 sigma), sigma / tau and tau^2 k^2 / 16 to the parameters
_WAVENUMBER = param_row_size(PARAMS)
_TAU_2SIGMA, _SIGMA_TAU, _D_PREFACTOR = _WAVENUMBER + 1, _WAVENUMBER + 2, _WAVENUMBER + 3


def derive_he(p: np.ndarray) -> np.ndarray:
    """Append ``k = 2 pi / lambda`` (1/um), ``tau / (2 sigma)``, ``sigma / tau`` and ``tau^2 k^2 / 16``."""
    sigma, tau, lam_um = p[_SIGMA], p[_TAU], p[_LAMBDA] * 1e-3
    k = TWO_PI / lam_um
    return np.concatenate([p, [k, tau / (2.0 * sigma), sigma / tau, tau * tau * k * k / 16.0]])


@kernel
def _sin_from_cos(c):
    return math.sqrt(max(0.0, 1.0 - c * c))


@kernel
def eval_he(wi, wo, p):
    ci = wi[2]
    co = wo[2]
    if ci <= 0.0 or co <= 0.0:
        return 0.0, 0.0, 0.0
    kd_r = p[_KD] * INV_PI
    kd_g = p[_KD + 1] * INV_PI
    kd_b = p[_KD + 2] * INV_PI
    # Keep tan(theta) finite for directions a hair above the horizon (well below any measurable angle).
    ci = max(ci, 1e-12)
    co = max(co, 1e-12)
    si = _sin_from_cos(ci)
    so = _sin_from_cos(co)
    sigma = p[_SIGMA]
    wave_k = p[_WAVENUMBER]
    tau_2s = p[_TAU_2SIGMA]
    sig_tau = p[_SIGMA_TAU]

    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = ci + co
    hxy2 = hx * hx + hy * hy
    hh = hxy2 + hz * hz

    k_i, shadow_i = direction_k(ci, si, tau_2s, sig_tau)
    k_o, shadow_o = direction_k(co, so, tau_2s, sig_tau)
    # ln g = 2 ln(k sigma_0 (cos_i + cos_r)): the logarithm of sigma_0 / sigma comes from its table
    log_g = 2.0 * (math.log(wave_k * sigma * hz) + log_roughness_ratio_of_k(k_i + k_o))
    tau = p[_TAU]
    a = 0.25 * tau * tau * wave_k * wave_k * hxy2
    series = tabulated_series_log(log_g, a)
    if series == 0.0:
        return kd_r, kd_g, kd_b
    geom = hh / hz
    geom *= geom
    common = INV_PI * geom * shadow_i * shadow_o * p[_D_PREFACTOR] * series
    cos_b = min(0.5 * math.sqrt(hh), 1.0)
    # one Fresnel term for the channels that share the first one's index (a grey metal: all three)
    f_r = fresnel_conductor(cos_b, p[_N], p[_K])
    same_g = p[_N + 1] == p[_N] and p[_K + 1] == p[_K]
    f_g = f_r if same_g else fresnel_conductor(cos_b, p[_N + 1], p[_K + 1])
    same_b = p[_N + 2] == p[_N] and p[_K + 2] == p[_K]
    f_b = f_r if same_b else fresnel_conductor(cos_b, p[_N + 2], p[_K + 2])
    return kd_r + common * f_r, kd_g + common * f_g, kd_b + common * f_b


def specular_weight(params: np.ndarray, theta_i: float) -> np.ndarray:
    """Reflectance ``|F|^2 e^{-g} S`` of the specular (mirror, Dirac delta) term left out of ``eval_he``.

    ``params`` is the kernel vector of a bound He BRDF (``brdf.params``), ``theta_i`` in radians below 90
    degrees. Returns RGB: the fraction of the incident power reflected coherently into the mirror direction
    (``g`` and ``S`` evaluated with ``theta_r = theta_i``, as in the paper).
    """
    return np.asarray(_specular_weight(np.asarray(params, dtype=np.float64), float(theta_i)))


@kernel
def _specular_weight(p, theta_i):
    c = math.cos(theta_i)
    if c <= 0.0:
        return 0.0, 0.0, 0.0
    c = max(c, 1e-12)
    s = _sin_from_cos(c)
    lk = log_k(c, s, p[_TAU_2SIGMA])
    ratio = effective_roughness_ratio(lk, lk)
    kz = p[_WAVENUMBER] * p[_SIGMA] * ratio * 2.0 * c
    shadow = shadow_over_cos(c, s, p[_TAU_2SIGMA], p[_SIGMA_TAU]) * c
    w = math.exp(-kz * kz) * shadow * shadow
    return (
        w * fresnel_conductor(c, p[_N], p[_K]),
        w * fresnel_conductor(c, p[_N + 1], p[_K + 1]),
        w * fresnel_conductor(c, p[_N + 2], p[_K + 2]),
    )


NOTES = (
    "Directional-diffuse term with the full series, effective roughness (Newton), Smith/erfc "
    "shadowing, complex Fresnel; plus uniform diffuse kd/pi. The specular Dirac term is left out "
    "(see specular_weight). Single wavelength; RGB index. Not energy-conserving in general."
)


HE = declare(globals(), "He-Torrance-Sillion-Greenberg (1991)", Traits.ISOTROPIC | Traits.RECIPROCAL)
