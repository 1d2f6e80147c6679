"""From the tree's square to directions: the concentric map onto the unit disk, then a disk projection.

The seed samples on the unit disk, whose area is the projected solid angle. Its quadtree covered the disk's
bounding square and clipped every leaf to the disk ("improved area"), so rim leaves wasted trials and a leaf
could not carry a density of its own (part of it lies outside the disk). Its own list of future work asks
for an area-preserving mapping; Shirley & Chiu's concentric map (1997) is one: it sends the square
``[0, 1]^2`` onto the unit disk with constant Jacobian ``pi``, continuously, so a quadtree over the square
*is* a quadtree over the disk whose every leaf lies within it. Nothing is clipped, no trial falls outside, and
a leaf can hold a bilinear density (the rejection-free mode).

Two projections take a disk point ``X`` to a direction (both exact; a table picks one per node):

============== ======================== ================================================================
projection     ``|X|``                  ``dA / d(omega)`` (the disk area per solid angle at ``wi``)
============== ======================== ================================================================
orthographic   ``sin(theta)``           ``cos(theta)`` (the seed's disk: area is the projected solid angle)
equal-area     ``sqrt(1 - cos(theta))`` ``1/2`` (Lambert's azimuthal projection): a ring of directions near
                                        the horizon keeps its width, where the orthographic disk squeezes
                                        it by ``cos(theta)``; and no trigonometry, one square root each way
rim            ``sqrt(1 - sqrt(cos))``  ``1 / (4 sqrt(cos(theta)))``: a ring near the horizon widens by ``1/sqrt(cos)`` (the
                                        equal-area disk keeps it; the orthographic one squeezes it by
                                        ``cos``)
============== ======================== ================================================================

The rim projection serves the exact mode's grazing trees that miss the acceptance on the equal-area disk
(:data:`~core.sampling.adaptive.table.RIM_LIMIT`). Where ``f cos`` has a ridge within a degree of the
horizon (Duer's geometry term: ``|L + V|^2 / (N.(L + V))^4`` peaks at ``cos(theta_i)`` about a third of
``cos(theta_o)``), the equal-area disk holds it in a ring ``cos/2`` wide, 3e-3 at 89 degrees: a quadtree
needs leaves of level 12 along the whole rim to follow it, and fills its capacity first. On the rim disk the
ring is ``sqrt(cos)/2`` wide (4e-2), which leaves of level 6 follow.

Composed with the concentric map, the equal-area projection is the classic area-preserving map of the
square onto the hemisphere. A third choice, ``half_vector``, puts the equal-area disk on the half vector
``h`` instead of ``wi`` (``wi = 2 (wo.h) h - wo``, ``d(omega_i) = 4 (wo.h) d(omega_h)``): a microfacet lobe is
then nearly the same for every ``wo`` (its distribution of normals does not move), so an anisotropic
material needs few nodes (:mod:`core.sampling.adaptive.table` picks it where it holds the lobe stiller). A density ``q`` on the square is a density ``q / pi`` on the disk and
``q / pi * dA/d(omega)`` per unit solid angle. The function the trees approximate is therefore
``g(s) = f(wo, wi) cos(theta_i) pi / (dA/d(omega))`` (``pi f`` on the orthographic disk, ``2 pi f cos`` on the
equal-area one), whose integral over the square is ``I(wo) = int f cos d(omega)``.
"""

from __future__ import annotations

import math

from numba import njit

from core.fastmath import atan_unit, sincos_small

PI = math.pi
HALF_PI = 0.5 * math.pi
QUARTER_PI = 0.25 * math.pi
INV_PI = 1.0 / math.pi

ORTHOGRAPHIC = 0
EQUAL_AREA = 1
HALF_VECTOR = 2
RIM = 3
PROJECTIONS = ("orthographic", "equal_area", "half_vector", "rim")


@njit(inline="always", nogil=True, cache=True)
def square_to_disk(a, b):
    """Shirley-Chiu concentric map of ``(a, b)`` in ``[0, 1]^2`` onto the unit disk (the larger coordinate
    chosen first, one division and one polynomial pair after it: selects, not branches)."""
    u = 2.0 * a - 1.0
    v = 2.0 * b - 1.0
    if u == 0.0 and v == 0.0:
        return 0.0, 0.0
    wide = abs(u) > abs(v)  # phi = pi/4 v/u; else phi = pi/2 - pi/4 u/v
    big = u if wide else v
    small = v if wide else u
    sn, cs = sincos_small(QUARTER_PI * (small / big))
    first = cs if wide else sn
    second = sn if wide else cs
    return big * first, big * second


@njit(inline="always", nogil=True, cache=True)
def disk_to_square(x, y):
    """Inverse of :func:`square_to_disk` (points of the closed unit disk): the radius is the larger coordinate
    of the square's centred point, its sign that of the disk point's larger coordinate, and the other is the
    radius times the angle inside the quadrant, ``4/pi atan(small / big)`` (:func:`~core.fastmath.atan_unit`:
    one division and a polynomial; selects, not branches: the library's ``atan2`` and the quadrant's branches
    would cost 6-9 ns of a rejection-free density's 66-83 without ``f``)."""
    r = math.sqrt(x * x + y * y)
    wide = abs(x) > abs(y)
    big = x if wide else y
    small = y if wide else x
    t = small / big if big != 0.0 else 0.0
    a = atan_unit(abs(t)) * (1.0 / QUARTER_PI)
    side = r if big >= 0.0 else -r  # the square's coordinate along the larger axis
    other = side * (a if t >= 0.0 else -a)
    u = side if wide else other
    v = other if wide else side
    return min(max(0.5 * (u + 1.0), 0.0), 1.0), min(max(0.5 * (v + 1.0), 0.0), 1.0)


@njit(inline="always", nogil=True, cache=True)
def disk_to_direction(x, y, projection):
    """The direction of disk point ``(x, y)`` and ``dA/d(omega)`` there."""
    r2 = x * x + y * y
    if projection == ORTHOGRAPHIC:
        z = math.sqrt(max(0.0, 1.0 - r2))
        return x, y, z, z
    if projection == RIM:  # sqrt(cos) = 1 - r2; sin / r = sqrt((2 - r2) (1 + cos)), no cancellation
        s = max(0.0, 1.0 - r2)
        z = s * s
        t = math.sqrt((1.0 + s) * (1.0 + z))
        return x * t, y * t, z, 0.25 / s if s > 0.0 else math.inf
    t = math.sqrt(max(0.0, 2.0 - r2))
    return x * t, y * t, 1.0 - r2, 0.5  # equal-area (of wi, or of h for HALF_VECTOR)


@njit(inline="always", nogil=True, cache=True)
def direction_to_disk(wx, wy, wz, projection):
    """The disk point of an upper-hemisphere direction and ``dA/d(omega)`` there."""
    if projection == ORTHOGRAPHIC:
        return wx, wy, max(wz, 0.0)
    if projection == RIM:
        s = math.sqrt(max(wz, 0.0))
        t = 1.0 / math.sqrt((1.0 + s) * (1.0 + s * s))
        return wx * t, wy * t, 0.25 / s if s > 0.0 else math.inf
    t = 1.0 / math.sqrt(1.0 + max(wz, 0.0))
    return wx * t, wy * t, 0.5


@njit(inline="always", nogil=True, cache=True)
def square_to_direction(a, b, projection):
    """The direction of square point ``(a, b)`` and ``dA/d(omega)`` there."""
    x, y = square_to_disk(a, b)
    return disk_to_direction(x, y, projection)


@njit(inline="always", nogil=True, cache=True)
def direction_to_square(wx, wy, wz, projection):
    """The square point of an upper-hemisphere direction and ``dA/d(omega)`` there."""
    x, y, jac = direction_to_disk(wx, wy, wz, projection)
    a, b = disk_to_square(x, y)
    return a, b, jac
