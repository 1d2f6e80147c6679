"""Export any BRDF into the RGL ``.bsdf`` parameterization (Dupuy & Jakob 2018), as their acquisition does
for a measured material, with the analytic ``f`` in place of the goniophotometer:

1. **NDF.** The retro-reflection ``f(m, m)`` of a microfacet BRDF is ``D(m) G F / (4 cos^2 theta_m)``, so
   ``Y(f(m, m)) cos^2 theta_m`` estimates ``D`` (the first step of the paper's power iteration); it is
   normalized (``integral D cos theta_m = 1``) and mixed with 10 % of the uniform ``1 / pi`` so that every
   half vector keeps some density (the stored values divide by ``D``). Any positive ``D`` gives a correct
   file; a good one gives a good warp.
2. **Projected area** ``sigma(w) = integral D(m) <w . m> dm`` by a midpoint rule in ``(u(theta), u(phi))``.
3. **VNDF** per conditioning direction: ``D(m) <wo . m> 2 pi^2 u sin theta_m``, the visible normals' density
   in the ``u`` coordinates of ``m`` (the warp normalizes it).
4. **Sample square.** Each node ``s`` of the sample grid is warped by the VNDF to a half vector ``m``, hence
   to ``wi = reflect(wo, m)``, and stores ``f(wi, wo) cos theta_i / (D / 4 sigma)`` with ``D`` and ``sigma``
   read back from the tables exactly as the reader reads them, so a lookup at a node returns ``f`` there
   (up to float32 rounding); between nodes it interpolates.
5. **Luminance** of the stored values plus 0.1 % of their mean: the sampler's second warp, never zero where
   the material reflects.

Resolution (:class:`ExportOptions`) is the only approximation; an isotropic file at the defaults is
~0.5 MB, an anisotropic one ~4 MB. Anisotropic models whose traits say mirror-symmetric are stored over a
quadrant of ``phi_o`` (the reader mirrors the rest), others over the whole circle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from core.brdf import BRDF, luminance
from core.rgl import lookup as L
from core.rgl.lookup import eval_rgl
from core.rgl.marginal import warp_sample
from core.rgl.material import RGLTable, kernel_vector

PI = math.pi


@dataclass(frozen=True)
class ExportOptions:
    """Grid sizes of an exported ``.bsdf`` file (``(rows, columns)`` = ``(phi, theta)`` for the tables over
    directions)."""

    n_theta_i: int = 16
    theta_max_deg: float = 87.0
    """The last conditioning polar angle; beyond it the reader holds the last slice."""
    n_phi_quadrant: int = 7
    """Azimuth nodes of a mirror-symmetric anisotropic material over ``[-pi, -pi/2]``."""
    n_phi_circle: int = 25
    """Azimuth nodes of another anisotropic material over ``[-pi, pi]``."""
    vndf: tuple[int, int] = (64, 64)
    samples: tuple[int, int] = (32, 32)
    ndf: tuple[int, int] = (64, 64)
    sigma: tuple[int, int] = (32, 32)
    quadrature: tuple[int, int] = (128, 128)
    ndf_uniform_share: float = 0.1
    luminance_floor: float = 1e-3


def _directions(u_theta: np.ndarray, u_phi: np.ndarray) -> np.ndarray:
    """Unit vectors at ``(u(theta), u(phi))`` (broadcast), shape ``(..., 3)``."""
    theta = np.square(u_theta) * (0.5 * PI)
    phi = (2.0 * u_phi - 1.0) * PI
    st = np.sin(theta)
    return np.stack(np.broadcast_arrays(np.cos(phi) * st, np.sin(phi) * st, np.cos(theta)), axis=-1)


class _NDF:
    """The normalized, floored NDF estimate of a BRDF (step 1)."""

    def __init__(self, brdf: BRDF, options: ExportOptions):
        self.brdf = brdf
        self.share = options.ndf_uniform_share
        nt, nphi = options.quadrature
        ut = (np.arange(nt) + 0.5) / nt
        up = (np.arange(nphi) + 0.5) / nphi
        self.m = _directions(ut[None, :], up[:, None]).reshape(-1, 3)
        theta = np.square(ut) * (0.5 * PI)
        # d omega = sin theta d theta d phi = sin theta (pi u du) (2 pi dv)
        dw = np.sin(theta) * PI * ut * (1.0 / nt) * 2.0 * PI * (1.0 / nphi)
        self.dw = np.broadcast_to(dw[None, :], (nphi, nt)).reshape(-1)
        raw = self._raw(self.m)
        total = float(np.sum(raw * self.m[:, 2] * self.dw))
        self.scale = (1.0 - self.share) / total if total > 0.0 else 0.0
        self.d_quad = self(self.m)

    def _raw(self, m: np.ndarray) -> np.ndarray:
        f = luminance(self.brdf.eval(m, m))
        return np.maximum(np.nan_to_num(f, nan=0.0, posinf=0.0), 0.0) * np.square(np.maximum(m[:, 2], 0.0))

    def __call__(self, m: np.ndarray) -> np.ndarray:
        flat = m.reshape(-1, 3)
        if self.scale > 0.0:
            d = self._raw(flat) * self.scale + self.share / PI
        else:  # no retro-reflection at all (a black material): the uniform NDF, a valid table of any shape
            d = np.full(flat.shape[0], 1.0 / PI)
        return d.reshape(m.shape[:-1])

    def projected_area(self, w: np.ndarray) -> np.ndarray:
        flat = w.reshape(-1, 3)
        out = np.empty(flat.shape[0])
        weights = self.d_quad * self.dw
        for start in range(0, flat.shape[0], 256):
            cos = np.maximum(flat[start : start + 256] @ self.m.T, 0.0)
            out[start : start + 256] = cos @ weights
        return out.reshape(w.shape[:-1])


@njit(cache=True, nogil=True)
def _warp_nodes(p, off_data, off_marg, off_cond, w, h, slices, nw, nh, out):
    """``out (slices, nh, nw, 3)``: the VNDF warp of every sample-grid node, slice by slice, and its density
    in ``u`` coordinates."""
    for s in range(slices):
        sl = (s, 0, 0, 0.0, 0.0)
        for b in range(nh):
            for a in range(nw):
                x, y, pdf = warp_sample(
                    p, off_data, off_marg, off_cond, w, h, sl, a / (nw - 1.0), b / (nh - 1.0)
                )
                out[s, b, a, 0] = x
                out[s, b, a, 1] = y
                out[s, b, a, 2] = pdf


@njit(cache=True, nogil=True)
def _eval_pairs(wi, wo, p, out):
    for i in range(wi.shape[0]):
        r, g, b = eval_rgl((wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p)
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b


def eval_table(p: np.ndarray, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """``f`` of an RGL kernel vector at pairs ``wi, wo (n, 3)`` (without the model dispatch)."""
    wi = np.ascontiguousarray(wi, dtype=np.float64)
    wo = np.ascontiguousarray(wo, dtype=np.float64)
    out = np.empty((wi.shape[0], 3))
    _eval_pairs(wi, wo, p, out)
    return out


def _grid(res: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Node coordinates ``(u_theta (1, w), u_phi (h, 1))`` of a ``(h, w)`` table."""
    h, w = res
    return np.linspace(0.0, 1.0, w)[None, :], np.linspace(0.0, 1.0, h)[:, None]


def warped_nodes(p: np.ndarray, table: RGLTable) -> np.ndarray:
    """The sample grid's nodes warped by the VNDF of every slice: ``(slices, nh, nw, 3)`` holding
    ``u(theta_m), u(phi_m)`` and the warp's density there (``p`` is ``kernel_vector(table)``)."""
    slices = table.phi_i.size * table.theta_i.size
    vh, vw = table.vndf.shape[2:]
    nh, nw = table.rgb.shape[3:]
    out = np.empty((slices, nh, nw, 3))
    _warp_nodes(
        p,
        int(p[L.H_OFF_VNDF]),
        int(p[L.H_OFF_VNDF_MARG]),
        int(p[L.H_OFF_VNDF_COND]),
        vw,
        vh,
        slices,
        nw,
        nh,
        out,
    )
    return out


def slice_directions(table: RGLTable) -> np.ndarray:
    """The conditioning direction of every slice, ``(slices, 3)``, slices ``[phi][theta]``."""
    th = table.theta_i.astype(np.float64)[None, :]
    ph = table.phi_i.astype(np.float64)[:, None]
    wo = np.stack(np.broadcast_arrays(np.cos(ph) * np.sin(th), np.sin(ph) * np.sin(th), np.cos(th)), -1)
    return wo.reshape(-1, 3)


def node_pairs(table: RGLTable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair ``(wi, wo)`` at a node of the file (a slice's direction and a node of its sample grid),
    with its share of ``d wi d wo``: ``(n, 3), (n, 3), (n,)``; pairs whose half vector faces away from
    ``wo`` are left out. An isotropic file's pairs have ``phi_o = 0``; an anisotropic file's lie in its
    stored range of ``phi_o``."""
    p = kernel_vector(table)
    u = warped_nodes(p, table)
    wo = slice_directions(table)
    theta = table.theta_i.astype(np.float64)
    d_theta = np.gradient(theta) if theta.size > 1 else np.array([0.5 * PI])
    if table.isotropic:
        d_phi = np.array([2.0 * PI])
    else:
        phi = table.phi_i.astype(np.float64)
        d_phi = np.gradient(phi) * table.reduction
    d_wo = (d_phi[:, None] * (np.sin(theta) * d_theta)[None, :]).reshape(-1)
    nh, nw = table.rgb.shape[3:]
    wis, wos, ws = [], [], []
    for s in range(wo.shape[0]):
        m = _directions(u[s, :, :, 0], u[s, :, :, 1]).reshape(-1, 3)
        pdf_u = u[s, :, :, 2].reshape(-1)
        cos_om = m @ wo[s]
        ok = (cos_om > 0.0) & (pdf_u > 0.0)
        wi = 2.0 * cos_om[ok, None] * m[ok] - wo[s]
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        ux = u[s, :, :, 0].reshape(-1)[ok]
        jac = (
            np.maximum(2.0 * PI * PI * ux * np.sin(np.square(ux) * 0.5 * PI), L.JACOBIAN_FLOOR)
            * 4.0
            * cos_om[ok]
        )
        pdf_wi = pdf_u[ok] / jac
        wis.append(wi)
        wos.append(np.broadcast_to(wo[s], wi.shape))
        ws.append(d_wo[s] / (pdf_wi * nh * nw))
    return np.concatenate(wis), np.ascontiguousarray(np.concatenate(wos)), np.concatenate(ws)


def tabulate(brdf: BRDF, options: ExportOptions | None = None, description: str | None = None) -> RGLTable:
    """An RGL table of ``brdf`` (any model, analytic or measured); see the module docstring."""
    o = options or ExportOptions()
    model = brdf.model
    if model.isotropic:
        phi_i = np.array([0.0])
    elif model.mirror_symmetric:
        phi_i = np.linspace(-PI, -0.5 * PI, o.n_phi_quadrant)
    else:
        phi_i = np.linspace(-PI, PI, o.n_phi_circle)
    theta_i = np.linspace(0.0, math.radians(o.theta_max_deg), o.n_theta_i)
    phi_i = phi_i.astype(np.float32)
    theta_i = theta_i.astype(np.float32)
    n_phi, n_theta = phi_i.size, theta_i.size
    slices = n_phi * n_theta

    ndf_fn = _NDF(brdf, o)
    ut, up = _grid(o.ndf)
    ndf = ndf_fn(_directions(ut, up)).astype(np.float32)
    ut, up = _grid(o.sigma)
    sigma = ndf_fn.projected_area(_directions(ut, up)).astype(np.float32)

    th = theta_i.astype(np.float64)[None, :]
    ph = phi_i.astype(np.float64)[:, None]
    wo = np.stack(np.broadcast_arrays(np.cos(ph) * np.sin(th), np.sin(ph) * np.sin(th), np.cos(th)), -1)
    wo = wo.reshape(slices, 3)  # the slices' conditioning directions, [phi][theta] (as slice_directions)
    ut, up = _grid(o.vndf)
    m = _directions(ut, up)  # (h, w, 3); phi relative to phi_o = 0 for isotropic files, absolute otherwise
    d = ndf_fn(m)
    jac = 2.0 * PI * PI * ut * np.sin(np.square(ut) * (0.5 * PI))
    vndf = np.empty((slices, *o.vndf), dtype=np.float32)
    for s in range(slices):
        vndf[s] = d * np.maximum(m @ wo[s], 0.0) * jac
    vndf = vndf.reshape(n_phi, n_theta, *o.vndf)

    nh, nw = o.samples
    ones = RGLTable(
        description="",
        jacobian=True,
        theta_i=theta_i,
        phi_i=phi_i,
        ndf=ndf,
        sigma=sigma,
        vndf=vndf,
        luminance=np.ones((n_phi, n_theta, nh, nw), dtype=np.float32),
        rgb=np.ones((n_phi, n_theta, 3, nh, nw), dtype=np.float32),
    )
    p = kernel_vector(ones)

    u = warped_nodes(p, ones)
    rgb = np.zeros((slices, nh, nw, 3))
    for s in range(slices):
        m_s = _directions(u[s, :, :, 0], u[s, :, :, 1]).reshape(-1, 3)
        w_o = np.broadcast_to(wo[s], m_s.shape)
        cos_om = m_s @ wo[s]
        wi = 2.0 * cos_om[:, None] * m_s - w_o
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        ok = (wi[:, 2] > 0.0) & (cos_om > 0.0)
        if not ok.any():
            continue
        f = brdf.eval(w_o[ok], wi[ok])
        factor = eval_table(p, wi[ok], w_o[ok])[:, 0]
        vals = np.zeros((ok.sum(), 3))
        good = factor > 0.0
        vals[good] = f[good] / factor[good, None]
        out = np.zeros((m_s.shape[0], 3))
        out[ok] = np.nan_to_num(vals, nan=0.0, posinf=0.0, neginf=0.0)
        rgb[s] = out.reshape(nh, nw, 3)
    lum = luminance(rgb)
    lum = lum + o.luminance_floor * lum.reshape(slices, -1).mean(axis=1)[:, None, None] + 1e-12
    return replace(
        ones,
        description=description or f"BRDF Studio export of {brdf.key()}",
        luminance=lum.reshape(n_phi, n_theta, nh, nw).astype(np.float32),
        rgb=np.moveaxis(rgb, -1, 1).reshape(n_phi, n_theta, 3, nh, nw).astype(np.float32),
    )
