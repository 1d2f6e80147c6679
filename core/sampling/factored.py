"""Factored BRDF importance sampling (Lawrence, Rusinkiewicz & Ramamoorthi 2004).

``f cos`` is tabulated for a set of outgoing directions ``wo_v`` (rows) against a 2-D parameterization
``(theta_p, phi_p)`` of ``wi`` (columns): the half vector when ``reparam`` is on, ``wi`` itself otherwise.
Non-negative matrix factorization gives ``Y ~ sum_j F_j(wo) G_j(theta_p, phi_p)``; each ``G_j`` is factored
again as ``sum_k u_jk(theta_p) v_jk(phi_p)``. Sampling picks a term ``(j, k)`` with probability
``F_j(wo) * w_jk`` (normalized), then ``theta_p`` from the piecewise-constant ``u_jk`` and ``phi_p`` from
``v_jk``, uniform in solid angle inside a cell. The density is the exact mixture of all terms,

``pdf_p(theta_p, phi_p) = sum_jk P(j, k | wo) u_jk(theta_p) v_jk(phi_p) / sin(theta_p)``,

converted to ``wi`` by the half-vector Jacobian ``1 / (4 |wo . h|)`` when reparameterized; ``wo`` reflected about
a half vector can then fall below the horizon, and ``pdf`` reports the density of those draws too. Every draw
carries the density ``pdf`` gives at it. Every 1-D factor is floored at ``defensive`` of its mean so the density
is positive wherever the BRDF can be.

Resolutions and ``J x K`` per model follow the seed's table (slide "We adjust manually the seven parameters");
isotropic BRDFs use outgoing bins over ``theta_o`` only (rotated by ``phi_o``) instead of the seed's 16 x 16.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from core import fastmath
from core.brdf import BRDF, LUMINANCE
from core.errors import ParameterError
from core.jit import kernel
from core.kernels import eval_batch
from core.rng import next_u01, stream
from core.sampling.base import (
    SampleBatch,
    Sampler,
    SamplerOption,
    check_buffers,
    check_points,
    register_sampler,
)
from core.sampling.distributions import find_interval, guided_interval, interval_guides
from core.sampling.tabulated import (
    EVERY_ROW,
    bin_directions,
    bin_of,
    table_azimuth,
    table_azimuth_estimate,
)

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class FactorSettings:
    n_theta_o: int = 16
    n_phi_o: int = 16
    n_theta_p: int = 32
    n_phi_p: int = 16
    terms_j: int = 2
    terms_k: int = 2
    reparam: bool = False


# The seed's table: N_theta_p x N_phi_p, J x K and the half-angle reparameterization flag per model.
SEED_SETTINGS: dict[str, FactorSettings] = {
    "ashikhmin_shirley": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=1, terms_k=2),
    "beard_maxwell": FactorSettings(n_theta_p=100, n_phi_p=32, terms_j=2, terms_k=3),
    "blinn": FactorSettings(n_theta_p=100, n_phi_p=32, terms_j=3, terms_k=3, reparam=True),
    "coupled": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=1, terms_k=3),
    "he": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=2, terms_k=1),
    "lafortune": FactorSettings(n_theta_p=100, n_phi_p=32, terms_j=2, terms_k=2, reparam=True),
    "lewis": FactorSettings(n_theta_p=100, n_phi_p=32, terms_j=2, terms_k=2, reparam=True),
    "minnaert": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=1, terms_k=2),
    "oren_nayar": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=1, terms_k=3),
    "phong": FactorSettings(n_theta_p=100, n_phi_p=32, terms_j=2, terms_k=2, reparam=True),
    "poulin_fournier": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=2, terms_k=2),
    "schlick_d": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=1, terms_k=3, reparam=True),
    "schlick_s": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=2, terms_k=3),
    "strauss": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=3, terms_k=3),
    "cook_torrance": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=1, terms_k=1),
    "ward": FactorSettings(n_theta_p=32, n_phi_p=16, terms_j=2, terms_k=2, reparam=True),
}


def nmf(Y: np.ndarray, rank: int, iterations: int = 300, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Non-negative ``W (m, rank)``, ``H (rank, n)`` with ``W @ H ~ Y`` (Lee & Seung multiplicative updates,
    Euclidean loss). Deterministic for a given ``seed``."""
    rng = np.random.default_rng(seed)
    m, n = Y.shape
    scale = math.sqrt(max(Y.mean(), 1e-300) / rank)
    W = rng.uniform(0.5, 1.5, (m, rank)) * scale
    H = rng.uniform(0.5, 1.5, (rank, n)) * scale
    eps = 1e-300
    for _ in range(iterations):
        H *= (W.T @ Y) / (W.T @ W @ H + eps)
        W *= (Y @ H.T) / (W @ (H @ H.T) + eps)
    return W, H


@njit(inline="always", nogil=True, cache=True)
def _cell_pdf(it, ip, b, term_cdf, u_pdf, v_pdf):
    """Mixture density per unit solid angle of the parameter directions in cell ``(it, ip)``."""
    total = 0.0
    for t in range(u_pdf.shape[0]):
        w = term_cdf[b, t + 1] - term_cdf[b, t]
        total += w * u_pdf[t, it] * v_pdf[t, ip]
    return total


@kernel
def _pdf_at(wo, wi, b, c_ref, s_ref, reparam, term_cdf, u_pdf, v_pdf, n_tp, n_pp):
    """Density per unit solid angle of ``wi`` (either hemisphere) for ``wo`` (above the horizon, in bin ``b``,
    its table's azimuth by cosine and sine ``c_ref, s_ref``). Reparameterized, the sampler reflects ``wo``
    about half vectors, which can send ``wi`` below the horizon: the density is reported there too, so that
    it integrates to 1 over the sphere."""
    if reparam:
        hx = wi[0] + wo[0]
        hy = wi[1] + wo[1]
        hz = wi[2] + wo[2]
        norm = math.sqrt(hx * hx + hy * hy + hz * hz)
        if norm == 0.0:
            return 0.0
        hx /= norm
        hy /= norm
        hz /= norm
        if hz < 0.0:  # a half vector with wo.h < 0 reflects to this wi too
            hx, hy, hz = -hx, -hy, -hz
        dh = hx * wo[0] + hy * wo[1] + hz * wo[2]
        d = (hx, hy, hz)
        jac = 1.0 / (4.0 * abs(dh)) if dh != 0.0 else 0.0
    else:
        if wi[2] <= 0.0:
            return 0.0
        d = (wi[0], wi[1], wi[2])
        jac = 1.0
    it = fastmath.polar_cell(min(1.0, d[2]), n_tp)  # the cell of theta_p = acos(d_z)
    # phi_p's cell from the arc tangent's estimate, from the exact angle only near the cell's edges
    t = table_azimuth_estimate(d, c_ref, s_ref) / TWO_PI * n_pp
    ip = int(t)
    margin = fastmath.AZIMUTH_MARGIN / TWO_PI * n_pp
    if not (margin < t - ip < 1.0 - margin and ip < n_pp):
        ip = min(int(table_azimuth(d, c_ref, s_ref) / TWO_PI * n_pp), n_pp - 1)
    return _cell_pdf(it, ip, b, term_cdf, u_pdf, v_pdf) * jac


# A drawn parameter direction this far inside its cell (as a fraction of the cell, in cos theta_p and in phi_p)
# is in that cell for :func:`_pdf_at` too: its arc cosine and arc tangent err by ~1e-15, the margin is > 1e-12.
_INSIDE = 1e-9
_U_GUIDE = 64  # guide entries per factor's CDF (:func:`core.sampling.distributions.interval_guides`)


class FactoredTables(NamedTuple):
    """A :class:`FactoredSampler`'s tables as its draw reads them."""

    n_theta_o: int
    n_phi_o: int
    reparam: bool
    term_cdf: np.ndarray
    u_cdf: np.ndarray
    u_pdf: np.ndarray
    v_cdf: np.ndarray
    v_pdf: np.ndarray
    cos_edges: np.ndarray
    u_guide: np.ndarray
    v_guide: np.ndarray


@kernel
def _factored_sample_rows(wo, u, seed, points, t, wi_out, pdf_out):
    """One draw per row of ``wo`` from the uniforms ``u (n, 3)`` (column 0 the term, 1 and 2 the cell and the
    point in it), into ``wi_out`` and ``pdf_out``; with ``u`` empty, row ``i``'s uniforms come from the counter
    stream ``(seed, i)`` (:func:`core.rng.stream`), columns 1 and 2 from ``points (n, 2)`` when it has rows: a
    renderer's slices draw no numpy stream, and copy and read no ``(n, 3)`` array beside their points.
    The density is :func:`_pdf_at`'s at the direction returned;
    without the half-vector reparameterization, a direction drawn at least ``_INSIDE`` inside its cell takes
    the cell's density directly (the one :func:`_pdf_at` finds there, by the same sum: the same bits)."""
    n_theta_o, n_phi_o, reparam, term_cdf, u_cdf, u_pdf, v_cdf, v_pdf, cos_edges, u_guide, v_guide = t
    n_terms = u_cdf.shape[0]
    n_tp = u_cdf.shape[1] - 1
    n_pp = v_cdf.shape[1] - 1
    d_phi = TWO_PI / n_pp
    given = u.shape[0] > 0
    placed = points.shape[0] > 0
    for i in range(wo.shape[0]):
        w = (wo[i, 0], wo[i, 1], wo[i, 2])
        if w[2] <= 0.0:
            wi_out[i, 0] = 0.0
            wi_out[i, 1] = 0.0
            wi_out[i, 2] = 1.0
            pdf_out[i] = 0.0
            continue
        if given:
            v0, v1, v2 = u[i, 0], u[i, 1], u[i, 2]
        else:
            state, v0 = next_u01(stream(seed, i))
            if placed:
                v1, v2 = points[i, 0], points[i, 1]
            else:
                state, v1 = next_u01(state)
                state, v2 = next_u01(state)
        b, c_ref, s_ref = bin_of(w, n_theta_o, n_phi_o)
        t = find_interval(term_cdf[b], 0, n_terms + 1, v0)
        # theta_p: choose a cell by u's CDF (cells uniform in theta), then uniform in cos inside the cell
        it = guided_interval(u_cdf[t], 0, n_tp + 1, u_guide[t], v1)
        c0 = u_cdf[t, it]
        c1 = u_cdf[t, it + 1]
        frac = (v1 - c0) / (c1 - c0) if c1 > c0 else 0.5
        frac = min(max(frac, 0.0), 1.0)
        ca = cos_edges[it]
        cb = cos_edges[it + 1]
        cos_p = ca + frac * (cb - ca)
        ip = guided_interval(v_cdf[t], 0, n_pp + 1, v_guide[t], v2)
        g0 = v_cdf[t, ip]
        g1 = v_cdf[t, ip + 1]
        fr2 = (v2 - g0) / (g1 - g0) if g1 > g0 else 0.5
        fr2 = min(max(fr2, 0.0), 1.0)
        phi_p = (ip + fr2) * d_phi
        sin_p = math.sqrt(max(0.0, 1.0 - cos_p * cos_p))
        sp, cp = fastmath.sin_cos(phi_p)
        d = (sin_p * (cp * c_ref - sp * s_ref), sin_p * (sp * c_ref + cp * s_ref), cos_p)
        if reparam:
            dh = w[0] * d[0] + w[1] * d[1] + w[2] * d[2]
            wi = (2.0 * dh * d[0] - w[0], 2.0 * dh * d[1] - w[1], 2.0 * dh * d[2] - w[2])
        else:
            wi = d
        wi_out[i, 0] = wi[0]
        wi_out[i, 1] = wi[1]
        wi_out[i, 2] = wi[2]
        # The density ``pdf`` reports at the direction returned, by the same routine: through the drawn h the
        # Jacobian differed from it by up to ~1e-8 relative near wi = -wo. A d rounded onto the horizon gets
        # density 0, as ``pdf`` gives it there: that draw is not returned (pdf 0, f 0).
        inside = _INSIDE <= frac <= 1.0 - _INSIDE and _INSIDE <= fr2 <= 1.0 - _INSIDE and g1 > g0 and c1 > c0
        if not reparam and inside:
            pdf_out[i] = _cell_pdf(it, ip, b, term_cdf, u_pdf, v_pdf)  # (x 1.0, the Jacobian without reparam)
        else:
            pdf_out[i] = _pdf_at(w, wi, b, c_ref, s_ref, reparam, term_cdf, u_pdf, v_pdf, n_tp, n_pp)


@kernel
def _factored_pdf_rows(wo, wi, mask, n_theta_o, n_phi_o, reparam, term_cdf, u_pdf, v_pdf, n_tp, n_pp, out):
    """The density at the rows of ``(wo, wi)`` where ``mask`` holds (every row for an empty ``mask``)."""
    every = mask.shape[0] == 0
    for i in range(wo.shape[0]):
        if not (every or mask[i]):
            continue
        w = (wo[i, 0], wo[i, 1], wo[i, 2])
        if w[2] <= 0.0:
            out[i] = 0.0
            continue
        b, c_ref, s_ref = bin_of(w, n_theta_o, n_phi_o)
        d = (wi[i, 0], wi[i, 1], wi[i, 2])
        out[i] = _pdf_at(w, d, b, c_ref, s_ref, reparam, term_cdf, u_pdf, v_pdf, n_tp, n_pp)


_NO_U = np.zeros((0, 3))
_NO_POINTS = np.zeros((0, 2))


def _guides(cdfs: np.ndarray) -> np.ndarray:
    """Guide rows (:func:`~core.sampling.distributions.interval_guides`) of each row of ``cdfs (terms, k + 1)``."""
    rows, width = cdfs.shape
    offsets = np.arange(rows + 1, dtype=np.int64) * width
    guides = interval_guides(np.ascontiguousarray(cdfs).ravel(), offsets, _U_GUIDE)
    return np.ascontiguousarray(guides - offsets[:-1, None].astype(np.int32))


class FactoredSampler(Sampler):
    """Lawrence et al. 2004: sample the NMF factors of ``f cos``; exact mixture pdf."""

    name = "factored"
    warp_dims = (1, 2)  # u[:, 0] chooses the term

    def __init__(
        self, brdf: BRDF, settings: FactorSettings | None = None, defensive: float = 1e-3, **options: Any
    ):
        super().__init__(brdf)
        base = settings or SEED_SETTINGS.get(brdf.model.name, FactorSettings())
        if brdf.model.isotropic:
            base = FactorSettings(**{**base.__dict__, "n_phi_o": 1})
        fields = set(FactorSettings.__dataclass_fields__)
        unknown = set(options) - fields
        if unknown:
            raise ParameterError(f"unknown factored-sampler option(s): {', '.join(sorted(unknown))}")
        s = FactorSettings(**{**base.__dict__, **options})
        for k, v in s.__dict__.items():
            if k != "reparam" and int(v) < 1:
                raise ParameterError(f"factored-sampler option {k} must be a positive integer, got {v}")
        self.settings = s
        self.defensive = float(defensive)
        t0 = time.perf_counter()
        self._build()
        self.build_seconds = time.perf_counter() - t0

    def _views(self) -> np.ndarray:
        return bin_directions(self.settings.n_theta_o, self.settings.n_phi_o)

    def _param_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre parameter directions ``(n_tp * n_pp, 3)`` and cell solid angles ``(n_tp, 1)``."""
        s = self.settings
        edges = np.arange(s.n_theta_p + 1) * HALF_PI / s.n_theta_p
        cos_c = 0.5 * (np.cos(edges[:-1]) + np.cos(edges[1:]))  # centre in solid angle
        th = np.arccos(cos_c)
        ph = (np.arange(s.n_phi_p) + 0.5) * TWO_PI / s.n_phi_p
        t, p = np.meshgrid(th, ph, indexing="ij")
        d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
        solid = (np.cos(edges[:-1]) - np.cos(edges[1:]))[:, None] * (TWO_PI / s.n_phi_p)
        return d, solid

    def _matrix(self) -> np.ndarray:
        """``Y[view, param cell]``: luminance of ``f cos`` per unit solid angle of the parameter direction."""
        s = self.settings
        d, _ = self._param_grid()
        rows = []
        for wo in self._views():
            wo_rep = np.broadcast_to(wo, d.shape)
            if s.reparam:
                dh = d @ wo
                wi = 2.0 * dh[:, None] * d - wo_rep
                jac = 4.0 * np.abs(dh)  # d(omega_i) = 4 |wo.h| d(omega_h)
            else:
                wi = d
                jac = np.ones(len(d))
            f = eval_batch(
                self.brdf.model, np.ascontiguousarray(wi), np.ascontiguousarray(wo_rep), self.brdf.params
            )
            g = np.maximum(f @ LUMINANCE, 0.0) * np.maximum(wi[:, 2], 0.0) * jac
            rows.append(g)
        return np.asarray(rows)

    def _build(self) -> None:
        s = self.settings
        Y = self._matrix()
        _, solid = self._param_grid()
        F, G = nmf(Y, s.terms_j)
        terms_u, terms_v, term_w = [], [], []
        for j in range(s.terms_j):
            Gj = G[j].reshape(s.n_theta_p, s.n_phi_p) * solid  # mass per cell
            U, V = nmf(Gj, s.terms_k, seed=j + 1)
            for k in range(s.terms_k):
                u = U[:, k]
                v = V[k]
                mass_u, mass_v = u.sum(), v.sum()
                if mass_u <= 0 or mass_v <= 0:
                    u, v = np.ones_like(u), np.ones_like(v)
                    mass_u, mass_v = u.sum(), v.sum()
                u = np.maximum(u / mass_u, self.defensive / len(u))
                v = np.maximum(v / mass_v, self.defensive / len(v))
                terms_u.append(u / u.sum())
                terms_v.append(v / v.sum())
                term_w.append((j, mass_u * mass_v))
        n_terms = len(terms_u)
        P = np.zeros((len(F), n_terms))
        for t, (j, w) in enumerate(term_w):
            P[:, t] = F[:, j] * w
        P = np.maximum(P, 0.0)
        totals = P.sum(axis=1, keepdims=True)
        P = np.where(totals > 0, P / np.where(totals > 0, totals, 1.0), 1.0 / n_terms)
        P = np.maximum(P, self.defensive / n_terms)
        P /= P.sum(axis=1, keepdims=True)
        self._term_cdf = np.concatenate([np.zeros((len(P), 1)), np.cumsum(P, axis=1)], axis=1)
        self._term_cdf[:, -1] = 1.0
        U = np.asarray(terms_u)
        V = np.asarray(terms_v)
        self._u_cdf = np.concatenate([np.zeros((n_terms, 1)), np.cumsum(U, axis=1)], axis=1)
        self._v_cdf = np.concatenate([np.zeros((n_terms, 1)), np.cumsum(V, axis=1)], axis=1)
        self._u_cdf[:, -1] = 1.0
        self._v_cdf[:, -1] = 1.0
        # Densities per unit solid angle: cell mass / cell solid angle, split into theta and phi factors.
        edges = np.arange(s.n_theta_p + 1) * HALF_PI / s.n_theta_p
        d_cos = np.cos(edges[:-1]) - np.cos(edges[1:])
        self._u_pdf = U / d_cos[None, :]
        # cos theta_p at the cells' edges: a draw reads two instead of calling the library cosine twice
        self._cos_edges = np.array([math.cos(i * (HALF_PI / s.n_theta_p)) for i in range(s.n_theta_p + 1)])
        self._v_pdf = V / (TWO_PI / s.n_phi_p)
        self._u_guide = _guides(self._u_cdf)
        self._v_guide = _guides(self._v_cdf)
        self._fit_error = float(np.linalg.norm(Y - F @ G) / max(np.linalg.norm(Y), 1e-300))

    def _directions_into(self, wo: np.ndarray, u: np.ndarray, wi: np.ndarray, pdf: np.ndarray) -> None:
        self._draw(wo, u, 0, _NO_POINTS, wi, pdf)

    def _draw(self, wo: np.ndarray, u: np.ndarray, seed: int, points: np.ndarray, wi: np.ndarray,
              pdf: np.ndarray) -> None:  # fmt: skip
        s = self.settings
        tables = FactoredTables(
            int(s.n_theta_o), int(s.n_phi_o), bool(s.reparam), self._term_cdf, self._u_cdf, self._u_pdf, self._v_cdf,
            self._v_pdf, self._cos_edges, self._u_guide, self._v_guide,
        )  # fmt: skip
        _factored_sample_rows(wo, u, int(seed) % (1 << 63), points, tables, wi, pdf)

    def sample_each(self, wo: np.ndarray, seed: int = 0) -> SampleBatch:
        """One sample per row of ``wo``, its uniforms from the counter stream ``(seed, row)`` (as
        :meth:`sample_into`'s: the same draws for the same seed)."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        wi = np.empty_like(wo)
        pdf = np.empty(wo.shape[0])
        self._draw(wo, _NO_U, seed, _NO_POINTS, wi, pdf)
        return self._with_f(wo, wi, pdf)

    def sample_into(self, wo: np.ndarray, seed: int, wi: np.ndarray, pdf: np.ndarray, f: np.ndarray,
                    points: np.ndarray | None = None) -> None:  # fmt: skip
        """:meth:`core.sampling.base.Sampler.sample_into`, the uniforms from the counter stream ``(seed,
        row)`` in the kernel (the term's always; the warp's unless ``points`` are given)."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        check_buffers(wo.shape[0], wi=wi, pdf=pdf, f=f)
        placed = _NO_POINTS if points is None else check_points(points, wo.shape[0])
        self._draw(wo, _NO_U, seed, placed, wi, pdf)
        self._f_into(wo, wi, pdf, f)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        out = np.empty(wo.shape[0])
        self._pdf_where(wo, wi, EVERY_ROW, out)
        return out

    def _pdf_where(self, wo: np.ndarray, wi: np.ndarray, mask: np.ndarray, pdf: np.ndarray) -> None:
        s = self.settings
        _factored_pdf_rows(
            wo, wi, mask, s.n_theta_o, s.n_phi_o, s.reparam, self._term_cdf, self._u_pdf, self._v_pdf,
            s.n_theta_p, s.n_phi_p, pdf,
        )  # fmt: skip

    def info(self) -> dict[str, Any]:
        s = self.settings
        mem = sum(a.nbytes for a in (self._term_cdf, self._u_cdf, self._u_pdf, self._v_cdf, self._v_pdf))
        return {
            "sampler": self.name,
            "memory_bytes": int(mem),
            "build_seconds": self.build_seconds,
            "views": f"{s.n_theta_o}x{s.n_phi_o}",
            "param_grid": f"{s.n_theta_p}x{s.n_phi_p}",
            "terms": f"{s.terms_j}x{s.terms_k}",
            "reparam": s.reparam,
            "fit_relative_error": self._fit_error,
        }


register_sampler(
    "factored",
    lambda brdf, **o: FactoredSampler(brdf, **o),
    (
        SamplerOption("n_theta_o", "int", 1, 256, doc="outgoing-direction bins in theta"),
        SamplerOption("n_phi_o", "int", 1, 64, doc="outgoing-direction bins in phi (anisotropic BRDFs)"),
        SamplerOption("n_theta_p", "int", 1, 1024, doc="factor grid rows"),
        SamplerOption("n_phi_p", "int", 1, 1024, doc="factor grid columns"),
        SamplerOption("terms_j", "int", 1, 16, doc="terms of the outer factorization"),
        SamplerOption("terms_k", "int", 1, 16, doc="terms of the inner factorization"),
        SamplerOption("reparam", "bool", doc="factor about the half vector"),
        SamplerOption("defensive", "float", 0.0, 0.5, lo_open=True, doc="mixture weight of uniform sampling"),
    ),
    lambda brdf, o: (
        48.0 * o.get("n_theta_o", 16) * o.get("n_phi_o", 16) * o.get("n_theta_p", 100) * o.get("n_phi_p", 32)
    ),  # the matrix Y and the factorization's copies of it
)
