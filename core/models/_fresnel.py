"""Exact Fresnel reflectance for unpolarized light at a smooth interface (shared by the model modules).

Both functions return ``R = (|r_s|^2 + |r_p|^2) / 2`` with the amplitude coefficients of the Fresnel
equations (Born & Wolf, *Principles of Optics*, sec. 1.5.2 and, for absorbing media, sec. 14.2). The
outside medium has index 1 (air); the inside medium has the relative index ``eta`` (a dielectric, real) or
``n + i k`` (a conductor, complex). With ``w = sqrt(eta^2 - sin^2 theta)`` (the principal complex root,
``eta cos theta_t`` in Snell's notation):

    r_s = (cos - w) / (cos + w),    r_p = (eta^2 cos - w) / (eta^2 cos + w).

Working with ``w`` instead of ``cos theta_t`` keeps both formulas finite at normal incidence
(``R = ((n-1)^2 + k^2) / ((n+1)^2 + k^2)``) and at grazing incidence (``R = 1`` exactly at ``cos = 0``).
Because ``Im(eta^2) >= 0`` for ``k >= 0``, the principal root has ``Re(w) >= 0``, which is the physical
(decaying) transmitted wave, and total internal reflection (``eta < 1``) falls out of the same formula.
"""

from __future__ import annotations

import cmath
import math

from numba import njit

from core.jit import kernel


@kernel
def _fresnel_complex(cos_theta, eta):
    """Unpolarized reflectance for ``cos_theta`` in [0, 1] and complex relative index ``eta``."""
    c = min(max(cos_theta, 0.0), 1.0)
    sin2 = max(0.0, 1.0 - c * c)
    eta2 = eta * eta
    w = cmath.sqrt(eta2 - sin2)
    den_s = c + w
    den_p = eta2 * c + w
    # The denominators vanish only for eta = 1 at grazing incidence (no interface: the limit is 0) or
    # for eta = 0 (not a material); both are limits the callers never reach with validated parameters.
    if den_s == 0.0 or den_p == 0.0:
        return 0.0
    rs = (c - w) / den_s
    rp = (eta2 * c - w) / den_p
    r = 0.5 * ((rs.real * rs.real + rs.imag * rs.imag) + (rp.real * rp.real + rp.imag * rp.imag))
    return min(max(r, 0.0), 1.0)


@kernel
def fresnel_conductor(cos_theta, n, k):
    """Fresnel reflectance of a conductor with complex index ``n + i k`` (``n > 0``, ``k >= 0``) seen from air.

    ``cos_theta`` is the cosine between the incident direction and the (micro)surface normal; its absolute
    value is used, so either side of the surface gives the reflectance of the outside face. Returns a value in
    [0, 1]: ``((n-1)^2 + k^2) / ((n+1)^2 + k^2)`` at ``cos_theta = 1`` and exactly 1 at ``cos_theta = 0``.

    The same ``R`` as the complex form above, in real arithmetic (three square roots, no complex division:
    it is the innermost call of the microfacet conductors, about a third of the cost of the complex form).
    With ``w = a + i b`` (``a >= 0``), ``A = n^2 - k^2 - s^2``, ``m = |w|^2 = sqrt(A^2 + 4 n^2 k^2)``:

        R_s = (m - 2 a c + c^2) / (m + 2 a c + c^2)
        R_p = R_s (m c^2 - 2 a c s^2 + s^4) / (m c^2 + 2 a c s^2 + s^4)

    ``a = sqrt((m + A) / 2)``, or ``|n k| / b`` with ``b = sqrt((m - A) / 2)`` when ``A < 0``, where the
    first form would cancel (``a b = n k``).
    """
    c = min(abs(cos_theta), 1.0)
    c2 = c * c
    s2 = max(0.0, 1.0 - c2)
    A = n * n - k * k - s2
    B = 2.0 * n * k
    m = math.sqrt(A * A + B * B)
    if A >= 0.0:
        a = math.sqrt(0.5 * (m + A))
    else:
        b = math.sqrt(0.5 * (m - A))
        a = 0.5 * abs(B) / b
    den_s = m + 2.0 * a * c + c2
    if den_s <= 0.0:  # n = 1, k = 0 at grazing incidence: no interface, the limit is 0
        return 0.0
    rs = (m - 2.0 * a * c + c2) / den_s
    u = m * c2 + s2 * s2
    v = 2.0 * a * c * s2
    rp = rs * (u - v) / (u + v) if u + v > 0.0 else rs
    return min(max(0.5 * (rs + rp), 0.0), 1.0)


@kernel
def fresnel_dielectric(cos_theta, eta):
    """Fresnel reflectance of a dielectric interface with relative index ``eta = n_inside / n_outside``.

    ``cos_theta > 0`` means light arrives from outside; ``cos_theta < 0`` means it arrives from inside, where
    the relative index is ``1 / eta`` (total internal reflection gives 1). Returns a value in [0, 1]:
    ``((eta-1)/(eta+1))^2`` at normal incidence and 1 at grazing incidence (0 when ``eta == 1``).
    """
    if cos_theta < 0.0:
        return _fresnel_complex(-cos_theta, complex(1.0 / eta, 0.0))
    return _fresnel_complex(cos_theta, complex(eta, 0.0))


@njit(inline="always", nogil=True, cache=True)
def fresnel_schlick(cos_theta, f0):
    """Schlick's approximation ``f0 + (1 - f0) (1 - cos)^5`` (Schlick 1994), ``cos`` clamped to [0, 1]."""
    c = min(max(cos_theta, 0.0), 1.0)
    m = 1.0 - c
    m2 = m * m
    return f0 + (1.0 - f0) * (m2 * m2 * m)
