"""The records the compiled stages take: named structures of arrays, as pbrt-v4's wavefront work items.

A stage reads a record's fields by name (``rays.o``, ``lights.area.cdf``), so that it takes a few records,
not each array as an argument of its own. Two kinds:

- the scene's, built once per :class:`renderer.integrator.PathTracer` (:func:`triangles`, :func:`lights`,
  :class:`PinholeCamera`, :class:`Materials`, :class:`Estimator`) or once per pass (:class:`PassKeys`);
- a wavefront's rows (:class:`Rays`, :class:`Hits`, :class:`Vertices`, :class:`LightSamples`,
  :class:`BsdfSamples`, :class:`ShadowRays`, :class:`Scratch`), allocated once per size by
  :class:`renderer.wavefront.Buffers` and reused by every wavefront its thread traces.

numba compiles a stage once per record type (a ``NamedTuple`` of arrays and numbers) and caches it on disk as
it does any signature; the records are ordinary tuples, so a stage compiled without reference counting
(:func:`core.jit.kernel`) borrows their arrays from its caller as it borrows plain array arguments.
No compiled module imports this one: an edit here recompiles no kernel.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from renderer.envmap import ENV_CONSTANT, ENV_MAP, ENV_NONE, ConstantEnvironment, EnvironmentMap

if TYPE_CHECKING:
    from renderer.world import World


# ---------------------------------------------------------------------------------------------- the scene's
class PinholeCamera(NamedTuple):
    """A pinhole camera: image size in pixels, position, unit frame and ``tan(fov / 2)``."""

    width: int
    height: int
    origin: np.ndarray
    """(3,) float64"""
    forward: np.ndarray
    """(3,) float64, unit"""
    right: np.ndarray
    """(3,) float64, unit"""
    up: np.ndarray
    """(3,) float64, unit"""
    tan_half: float
    aspect: float
    """width / height"""


class Triangles(NamedTuple):
    """The scene's triangles as the stages read them, indexed by Embree's primitive id."""

    normal: np.ndarray
    """(T, 3) float64: unit geometric normals"""
    vnormals: np.ndarray
    """(T, 3, 3) float64: the vertices' normals"""
    smooth: np.ndarray
    """(T,) bool: shaded with the interpolated vertex normals"""
    material: np.ndarray
    """(T,) int64: material index (``NO_MATERIAL`` for a light's own triangles)"""
    emissive: np.ndarray
    """(T,) bool"""
    emission: np.ndarray
    """(T, 3) float64: emitted radiance"""
    two_sided: np.ndarray
    """(T,) bool: emits from both sides"""
    eps: float
    """How far a hit point is pushed off its surface along the geometric normal (Embree's tnear is 0)."""


class AreaLights(NamedTuple):
    """The emissive triangles, chosen by area x luminance (their normals and radiance are :class:`Triangles`')."""

    ids: np.ndarray
    """(K,) int64: the emissive triangles"""
    cdf: np.ndarray
    """(K,) float64: the CDF of their choice"""
    pmf_per_area: np.ndarray
    """(T,) float64: every triangle's probability of choice over its area (0 for the others)"""
    v0: np.ndarray
    """(T, 3) float64: every triangle's first vertex"""
    e1: np.ndarray
    """(T, 3) float64: its edge to the second vertex"""
    e2: np.ndarray
    """(T, 3) float64: its edge to the third vertex"""


class PointLights(NamedTuple):
    """Point lights, chosen by luminance."""

    position: np.ndarray
    """(P, 3) float64"""
    intensity: np.ndarray
    """(P, 3) float64"""
    cdf: np.ndarray
    """(P,) float64"""
    pmf: np.ndarray
    """(P,) float64"""


class Sky(NamedTuple):
    """The sky for :func:`renderer.envmap.env_eval_one` and :func:`renderer.envmap.env_sample_one`
    (:func:`sky_record`): its kind and, for a map, its sampling tables, with 1-element
    placeholders where a kind has none."""

    kind: int
    """``ENV_NONE``, ``ENV_CONSTANT`` or ``ENV_MAP``"""
    radiance: np.ndarray
    """(3,) float64: a constant sky's radiance"""
    row_cdf: np.ndarray
    col_cdf_flat: np.ndarray
    guide: np.ndarray
    """int32: where the CDFs' searches start (:func:`renderer.envmap.guide_table`)"""
    edges: np.ndarray
    """the pixels' edges (:func:`renderer.envmap.pixel_edges`)"""
    pmf: np.ndarray
    """(h, w) float64: the pixels' probabilities"""
    image: np.ndarray
    """(h, w, 3) float64"""
    rotation: float
    """in ``[0, 2 pi)``"""


class Lights(NamedTuple):
    """Everything next-event estimation samples, and the probabilities of its light types (area, point, sky):
    a light sample's first uniform ``u`` picks area below ``c_area``, point below ``c_point``, else sky."""

    area: AreaLights
    point: PointLights
    sky: Sky
    p_area: float
    p_point: float
    p_env: float
    c_area: float
    """``p_area``"""
    c_point: float
    """``p_area + p_point``"""

    def with_shares(self, p_area: float, p_point: float, p_env: float) -> Lights:
        """These lights with the light types' probabilities ``p_area, p_point, p_env``."""
        return self._replace(
            p_area=p_area, p_point=p_point, p_env=p_env, c_area=p_area, c_point=p_area + p_point
        )


class Materials(NamedTuple):
    """Per material index: how its BRDF samples are drawn (``BY_SAMPLER``, ``UNIFORM``, ``COSINE``,
    ``ANALYTIC``), its model's dispatch id, its parameters and, for a measured material, its table."""

    strategy: np.ndarray
    """(M,) int64"""
    model: np.ndarray
    """(M,) int64"""
    params: np.ndarray
    """(M, P) float64: every model's but a measured one's, rows padded to one length"""
    tables: np.ndarray
    """(M, Q) float32: the measured (MERL) materials' tables"""


class Estimator(NamedTuple):
    """The choices of the estimator a render makes once."""

    power: bool
    """MIS by the power heuristic (else the balance heuristic)"""
    nee: bool
    """a light sample at every vertex (there are lights to sample)"""
    ris: bool
    """the sky's direct light by resampled importance sampling (rays that escape after a bounce add none)"""


class PassKeys(NamedTuple):
    """What a pass's path ``j`` is: sample ``first_sample + j // n_pix`` of pixel ``j % n_pix``; and the keys
    of its random numbers (:mod:`renderer.qmc`)."""

    n_pix: int
    first_sample: int
    seed_key: np.uint64
    """the render's: the pixels' Sobol scrambles"""
    pass_key: np.uint64
    """the pass's: its hashed uniforms"""


def sky_record(env: ConstantEnvironment | EnvironmentMap | None) -> Sky:
    """The :class:`~renderer.stages.records.Sky` record the compiled wavefront reads for a sky (``None``,
    constant or map), its arrays contiguous, with 1-element placeholders where a kind has none."""
    one, no_guide = np.zeros(1), np.zeros(1, dtype=np.int32)
    if env is None:
        return Sky(ENV_NONE, np.zeros(3), one, one, no_guide, one, np.zeros((1, 1)), np.zeros((1, 1, 3)), 0.0)
    if isinstance(env, ConstantEnvironment):
        return Sky(ENV_CONSTANT, np.ascontiguousarray(env.radiance), one, one, no_guide, one, np.zeros((1, 1)),
                   np.zeros((1, 1, 3)), 0.0)  # fmt: skip
    c = np.ascontiguousarray
    return Sky(ENV_MAP, np.zeros(3), c(env._row_cdf), c(env._col_cdf_flat), c(env._guide), c(env._edges),
               c(env._pixel_pmf), c(env.image), float(env.rotation))  # fmt: skip


def triangles(world: World) -> Triangles:
    """The :class:`Triangles` record of ``world``'s arrays."""
    w = world
    return Triangles(w.tri_normal, w.tri_vnormals, w.tri_smooth, w.tri_material, w.tri_emissive, w.tri_emission,
                     w.tri_two_sided, float(w.eps))  # fmt: skip


def lights(world: World, sky: Sky, p_area: float, p_point: float, p_env: float) -> Lights:
    """The :class:`Lights` record of ``world``'s lights and ``sky``, with those light-type probabilities."""
    w = world
    area = AreaLights(w.emit_ids, w.emit_cdf, w.emit_pmf_per_area, w.v0, w.e1, w.e2)
    point = PointLights(w.point_pos, w.point_intensity, w.point_cdf, w.point_pmf)
    return Lights(area, point, sky, 0.0, 0.0, 0.0, 0.0, 0.0).with_shares(p_area, p_point, p_env)


# ---------------------------------------------------------------------------------------------- a wavefront's
class Rays(NamedTuple):
    """The rays of the current bounce, one row per live path."""

    o: np.ndarray
    """(n, 3) float64: origins"""
    d: np.ndarray
    """(n, 3) float64: unit directions"""
    o32: np.ndarray
    """(n, 3) float32: the origins as Embree takes them"""
    d32: np.ndarray
    """(n, 3) float32: the directions as Embree takes them"""
    beta: np.ndarray
    """(n, 3) float64: the paths' throughput"""
    path: np.ndarray
    """(n,) int64: the path of each ray"""
    prev_pdf: np.ndarray
    """(n,) float64: the density of the BRDF sample that made the ray (0 for camera rays)"""

    @classmethod
    def empty(cls, n: int) -> Rays:
        f64, f32 = np.float64, np.float32
        return cls(np.empty((n, 3), f64), np.empty((n, 3), f64), np.empty((n, 3), f32), np.empty((n, 3), f32),
                   np.empty((n, 3), f64), np.empty(n, np.int64), np.empty(n, f64))  # fmt: skip


class Hits(NamedTuple):
    """Embree's closest hits of :class:`Rays`, and the material of each ray that goes on."""

    prim: np.ndarray
    """(n,) int32: the triangle hit (negative: none)"""
    t: np.ndarray
    """(n,) float32: the distance"""
    bu: np.ndarray
    """(n,) float32: barycentric u"""
    bv: np.ndarray
    """(n,) float32: barycentric v"""
    mat: np.ndarray
    """(n,) int64: the material index of each ray that goes on, ``NO_MATERIAL`` for the others"""

    @classmethod
    def empty(cls, n: int) -> Hits:
        f32 = np.float32
        return cls(np.empty(n, np.int32), np.empty(n, f32), np.empty(n, f32), np.empty(n, f32),
                   np.empty(n, np.int64))  # fmt: skip


class Vertices(NamedTuple):
    """The surface vertices of a bounce, sorted by material: row ``s`` is ray ``order[s]``'s hit."""

    order: np.ndarray
    """(n,) int64: the ray of each vertex (:func:`renderer.stages.hits.sort_by_material`)"""
    mat: np.ndarray
    """(n,) int64: material index"""
    ng: np.ndarray
    """(n, 3) float64: geometric normal, towards the viewer"""
    ns: np.ndarray
    """(n, 3) float64: shading normal (its tangents are a function of it:
    :func:`renderer.stages.primitives.tangents`)"""
    wo: np.ndarray
    """(n, 3) float64: the direction to the viewer in the shading frame"""
    origin: np.ndarray
    """(n, 3) float64: the hit point pushed off the surface"""
    beta: np.ndarray
    """(n, 3) float64: the path's throughput"""
    path: np.ndarray
    """(n,) int64"""

    @classmethod
    def empty(cls, n: int) -> Vertices:
        i64 = np.int64
        return cls(
            np.empty(n, i64), np.empty(n, i64), *(np.empty((n, 3)) for _ in range(5)), np.empty(n, i64)
        )


class LightSamples(NamedTuple):
    """One light sample per surface vertex (row ``s`` is vertex ``s``'s), and what its BRDF makes of it."""

    wi: np.ndarray
    """(n, 3) float32: the world direction (it only makes the shadow ray)"""
    wi_local: np.ndarray
    """(n, 3) float64: the direction in the shading frame"""
    le: np.ndarray
    """(n, 3) float64: the radiance (or a point light's intensity over the squared distance)"""
    pdf: np.ndarray
    """(n,) float64: its density (per solid angle; a point light's probability of choice)"""
    tmax: np.ndarray
    """(n,) float32: the shadow ray's distance limit (at most 1e30, as Embree takes it)"""
    delta: np.ndarray
    """(n,) bool: from a point light (no MIS)"""
    cand: np.ndarray
    """(n,) bool: worth a BRDF evaluation (positive pdf and radiance, above both surfaces)"""
    f: np.ndarray
    """(n, 3) float64: the BRDF there"""
    pdf_brdf: np.ndarray
    """(n,) float64: the BRDF sampler's density there"""
    contrib: np.ndarray
    """(n, 3) float64: the MIS-weighted contribution, added if its shadow ray is not blocked"""

    @classmethod
    def empty(cls, n: int) -> LightSamples:
        f64, f32 = np.float64, np.float32
        return cls(np.empty((n, 3), f32), np.empty((n, 3), f64), np.empty((n, 3), f64), np.empty(n, f64),
                   np.empty(n, f32), np.empty(n, np.bool_), np.empty(n, np.bool_), np.empty((n, 3), f64),
                   np.empty(n, f64), np.empty((n, 3), f64))  # fmt: skip


class BsdfSamples(NamedTuple):
    """One BRDF sample per surface vertex, with ``f`` there."""

    wi_local: np.ndarray
    """(n, 3) float64: the direction in the shading frame"""
    pdf: np.ndarray
    """(n,) float64: its density per solid angle"""
    f: np.ndarray
    """(n, 3) float64"""
    points: np.ndarray
    """(n, 2) float64: the Sobol points the strategies with tables warp (:func:`renderer.stages.bsdf.bsdf_points`)"""

    @classmethod
    def empty(cls, n: int) -> BsdfSamples:
        return cls(np.empty((n, 3)), np.empty(n), np.empty((n, 3)), np.empty((n, 2)))


class ShadowRays(NamedTuple):
    """The light samples' shadow rays, packed, in Embree's float32."""

    o32: np.ndarray
    """(n, 3) float32"""
    d32: np.ndarray
    """(n, 3) float32"""
    tmax32: np.ndarray
    """(n,) float32"""
    slot: np.ndarray
    """(n,) int64: the vertex (and light sample) of each"""

    @classmethod
    def empty(cls, n: int) -> ShadowRays:
        f32 = np.float32
        return cls(np.empty((n, 3), f32), np.empty((n, 3), f32), np.empty(n, f32), np.empty(n, np.int64))


class Scratch(NamedTuple):
    """The stages' scratch rows, one block of ``BLOCK`` vertices each."""

    frames: np.ndarray
    """(BLOCK, 11) float64: the surface stage's frames and light points"""
    blk: np.ndarray
    """(BLOCK, 3) float64: the BRDF stage's uniforms"""
    mcell: np.ndarray
    """(BLOCK, 2, 3) int64: the cells of the BRDF stage's deferred measured lookups"""
    mfrac: np.ndarray
    """(BLOCK, 2, 3) float64: and their fractions"""

    @classmethod
    def empty(cls, block: int) -> Scratch:
        return cls(np.empty((block, 11)), np.empty((block, 3)), np.empty((block, 2, 3), np.int64),
                   np.empty((block, 2, 3)))  # fmt: skip
