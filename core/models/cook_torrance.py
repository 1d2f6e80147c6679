"""Cook-Torrance microfacet model (R. L. Cook and K. E. Torrance, "A Reflectance Model for Computer
Graphics", ACM Transactions on Graphics 1(1), 7-24, 1982; SIGGRAPH '81).

    f_r = kd / pi + ks F(wi.h) D(h) G(wi, wo) / (pi (n.wi) (n.wo))

- ``D``: Beckmann's distribution of microfacet slopes with RMS slope ``m``,
  ``D = exp(-tan^2(alpha) / m^2) / (4 m^2 cos^4(alpha))``, ``alpha`` the angle between ``h`` and ``n``. This
  is the normalization printed in the SIGGRAPH '81 version: with the paper's ``1 / pi`` it makes the specular
  term equal to the microfacet BRDF ``F D_B G / (4 (n.wi)(n.wo))`` with the unit-projected-area Beckmann
  ``D_B = exp(-tan^2 alpha / m^2) / (pi m^2 cos^4 alpha)`` (the TOG 1982 printing drops the 4, which makes
  the specular albedo up to four times the Fresnel reflectance; see Walter et al. 2007, sec. 5.1).
- ``G``: the V-cavity masking-shadowing of Torrance & Sparrow (1967),
  ``G = min(1, 2 (n.h)(n.wo) / (wo.h), 2 (n.h)(n.wi) / (wo.h))``.
- ``F``: the exact unpolarized Fresnel reflectance of a conductor with complex index ``n_real + i n_imag``
  at the microfacet, ``cos = wi.h`` (``core.models._fresnel``); ``ks`` tints it (RGB).

Reciprocal (every factor is symmetric in ``wi, wo``) and isotropic. Not declared energy-conserving: the
diffuse and specular coefficients are independent, so ``kd + ks`` can reach 2.

Sampling: with probability ``P_s = Y(ks) / (Y(ks) + Y(kd))`` (``Y`` = luminance) a half vector from
``D_B(h) cos(theta_h)`` (Beckmann slopes are Gaussian: exact inversion), reflected about ``h``, with the
Jacobian ``d(omega_h) / d(omega_i) = 1 / (4 |wo.h|)``; otherwise the cosine hemisphere. The mixture density
is exact everywhere (samples below the horizon included).
"""

from __future__ import annotations

import math

from numba import njit

from core.model import Model, Param, Traits, register
from core.models._fresnel import fresnel_conductor
from core.models.lobes import cosine_hemisphere, cosine_hemisphere_pdf

PI = math.pi
INV_PI = 1.0 / math.pi
TWO_PI = 2.0 * math.pi
LUMA = (0.2126, 0.7152, 0.0722)


@njit(inline="always", nogil=True, cache=True)
def luminance3(r, g, b):
    return LUMA[0] * r + LUMA[1] * g + LUMA[2] * b


@njit(inline="always", nogil=True, cache=True)
def lobe_probability(w_lobe, w_diffuse):
    """Probability of the specular lobe in a lobe + cosine mixture, from non-negative weights."""
    total = w_lobe + w_diffuse
    if total <= 0.0:
        return 0.5
    return w_lobe / total


@njit(nogil=True, cache=True)
def beckmann_sample_h(ax, ay, u1, u2):
    """A half vector (upper hemisphere) whose slopes ``(-h.x/h.z, -h.y/h.z)`` are Gaussian with variances
    ``ax^2 / 2``, ``ay^2 / 2``: density ``D_B(h) cos(theta_h)`` per unit solid angle of ``h`` (anisotropic
    Beckmann; also Ward's lobe, Walter 2005)."""
    r = math.sqrt(-math.log(1.0 - u1))  # 1 - u1 in (0, 1]
    phi = TWO_PI * u2
    sx = ax * r * math.cos(phi)
    sy = ay * r * math.sin(phi)
    inv = 1.0 / math.sqrt(sx * sx + sy * sy + 1.0)
    return -sx * inv, -sy * inv, inv


@njit(nogil=True, cache=True)
def beckmann_pdf_h(hx, hy, hz, ax, ay):
    """Density of :func:`beckmann_sample_h` per unit solid angle at unit ``h`` with ``hz > 0``:
    the slope density ``exp(-(x^2/ax^2 + y^2/ay^2)) / (pi ax ay)`` times ``d(slope) / d(omega_h) =
    1 / cos^3(theta_h)``."""
    if hz <= 0.0:
        return 0.0
    e = ((hx / ax) ** 2 + (hy / ay) ** 2) / (hz * hz)
    if e > 700.0:
        return 0.0
    return math.exp(-e) / (PI * ax * ay * hz * hz * hz)


@njit(nogil=True, cache=True)
def reflect_about(wo, hx, hy, hz):
    d2 = 2.0 * (wo[0] * hx + wo[1] * hy + wo[2] * hz)
    return d2 * hx - wo[0], d2 * hy - wo[1], d2 * hz - wo[2]


@njit(nogil=True, cache=True)
def beckmann_reflection_pdf(wo, wi, ax, ay):
    """Density per unit solid angle of ``wi`` = ``wo`` reflected about a :func:`beckmann_sample_h` half
    vector. ``h = +-(wi + wo) / |wi + wo|`` with the sign giving ``h.z >= 0``, and
    ``|wo.h| = |wi + wo| / 2``; 0 at ``wi = -wo`` (measure zero)."""
    sx = wi[0] + wo[0]
    sy = wi[1] + wo[1]
    sz = wi[2] + wo[2]
    norm = math.sqrt(sx * sx + sy * sy + sz * sz)
    if norm == 0.0:
        return 0.0
    if sz < 0.0:
        sx, sy, sz = -sx, -sy, -sz
    p_h = beckmann_pdf_h(sx / norm, sy / norm, sz / norm, ax, ay)
    return p_h / (2.0 * norm)  # 4 |wo.h| = 2 |wi + wo|


@njit(nogil=True, cache=True)
def eval_cook_torrance(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    m = p[0]
    hx = wi[0] + wo[0]
    hy = wi[1] + wo[1]
    hz = wi[2] + wo[2]
    norm = math.sqrt(hx * hx + hy * hy + hz * hz)
    hx /= norm
    hy /= norm
    hz /= norm
    c = wi[0] * hx + wi[1] * hy + wi[2] * hz  # = wo.h > 0 when both lie above the horizon
    tan2 = (hx * hx + hy * hy) / (hz * hz)
    e = tan2 / (m * m)
    spec = 0.0
    if e < 700.0:
        d = math.exp(-e) / (4.0 * m * m * hz * hz * hz * hz)
        g = min(1.0, 2.0 * hz * wo[2] / c, 2.0 * hz * wi[2] / c)
        f = fresnel_conductor(c, p[1], p[2])
        spec = f * d * g / (PI * wi[2] * wo[2])
    return (
        p[6] * INV_PI + p[3] * spec,
        p[7] * INV_PI + p[4] * spec,
        p[8] * INV_PI + p[5] * spec,
    )


@njit(nogil=True, cache=True)
def pdf_cook_torrance(wo, wi, p):
    ps = lobe_probability(luminance3(p[3], p[4], p[5]), luminance3(p[6], p[7], p[8]))
    lobe = beckmann_reflection_pdf(wo, wi, p[0], p[0]) if ps > 0.0 else 0.0
    return ps * lobe + (1.0 - ps) * cosine_hemisphere_pdf(wi[2])


@njit(nogil=True, cache=True)
def sample_cook_torrance(wo, p, u1, u2, u3):
    ps = lobe_probability(luminance3(p[3], p[4], p[5]), luminance3(p[6], p[7], p[8]))
    if u3 < ps:
        hx, hy, hz = beckmann_sample_h(p[0], p[0], u1, u2)
        wi = reflect_about(wo, hx, hy, hz)
    else:
        wi = cosine_hemisphere(u1, u2)
    return wi[0], wi[1], wi[2], pdf_cook_torrance(wo, wi, p)


COOK_TORRANCE = register(
    Model(
        name="cook_torrance",
        label="Cook-Torrance (1982)",
        citation=(
            "R. L. Cook and K. E. Torrance, A Reflectance Model for Computer Graphics, "
            "ACM Transactions on Graphics 1(1):7-24, 1982."
        ),
        params=(
            Param("m", 0.35, 0.005, 1.0, label="RMS microfacet slope", log=True),
            Param("n_real", 0.617, 0.01, 10.0, label="Refractive index (real part)"),
            Param("n_imag", 2.63, 0.0, 10.0, label="Extinction coefficient (imaginary part)"),
            Param("ks", (0.7, 0.7, 0.7), 0.0, 1.0, label="Specular coefficient", kind="color"),
            Param("kd", (0.3, 0.3, 0.3), 0.0, 1.0, label="Diffuse albedo", kind="color"),
        ),
        traits=Traits.ISOTROPIC | Traits.RECIPROCAL,
        eval=eval_cook_torrance,
        sample=sample_cook_torrance,
        pdf=pdf_cook_torrance,
        doc=__doc__ or "",
        notes="Beckmann D with the SIGGRAPH '81 normalization (see the module docstring).",
    )
)
