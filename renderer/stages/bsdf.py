"""The BRDF stage of the strategies without tables: ``f`` and the strategy's pdf at the light samples, and one
BRDF sample each, through the models' dispatch ids (the strategies with tables draw theirs by their sampler
objects, :meth:`renderer.integrator.PathTracer._draw_by_samplers`)."""

from __future__ import annotations

import math

from numba import njit

from core import fastmath, merl
from core.dispatch import MERL, MERL_NEAREST, eval_model, pdf_model, sample_model
from core.jit import kernel
from core.models.lobes import cosine_hemisphere_pdf
from renderer.qmc import key, pair, uniform
from renderer.stages.primitives import BLOCK, PAIR_BSDF, SOBOL_DEPTH, U_LOBE

# how a material's BRDF samples are drawn: by its sampler object, slice by slice (strategies with tables), or
# here, in compiled code, through the model's dispatch id (strategies without tables)
BY_SAMPLER = 0
UNIFORM = 1
COSINE = 2
ANALYTIC = 3
COMPILED_STRATEGIES = {"uniform": UNIFORM, "cosine": COSINE, "analytic": ANALYTIC}
INV_TWO_PI = 0.15915494309189535
TWO_PI = 2.0 * math.pi


@njit(inline="always", nogil=True, cache=True)
def _cosine_hemisphere(u1, u2):
    """:func:`core.models.lobes.cosine_hemisphere` (Malley's method) with the azimuth's sine and cosine from
    :func:`core.fastmath.sin_cos`."""
    r = math.sqrt(u1)
    sn, cs = fastmath.sin_cos(TWO_PI * u2)
    return r * cs, r * sn, math.sqrt(max(0.0, 1.0 - u1))


@njit(inline="always", nogil=True, cache=True)
def _uniform_hemisphere(u1, u2):
    """:func:`core.models.lobes.uniform_hemisphere` with the azimuth's sine and cosine from
    :func:`core.fastmath.sin_cos`."""
    r = math.sqrt(max(0.0, 1.0 - u1 * u1))
    sn, cs = fastmath.sin_cos(TWO_PI * u2)
    return r * cs, r * sn, u1


@njit(inline="always", nogil=True, cache=True)
def _eval(mid, wi, wo, prm, table):
    """``eval_model(mid, wi, wo, prm)``, except that a MERL material's table is read from ``table``, its
    float32 copy: a 35 MB float64 table read at random points misses the cache far more often than the
    17.5 MB copy (490 against 350 ns an evaluation; the values differ by float32 rounding,
    ~6e-8 relative)."""
    if mid == MERL:
        r, g, b = merl.eval_merl(wi, wo, table)
    elif mid == MERL_NEAREST:
        r, g, b = merl.eval_merl_nearest(wi, wo, table)
    else:
        r, g, b = eval_model(mid, wi, wo, prm)
    return r, g, b


@njit(inline="always", nogil=True, cache=True)
def _bsdf_pair(p, keys, depth):
    """The two uniforms of path ``p``'s BRDF sample at bounce ``depth``: an Owen-scrambled Sobol point of
    the pixel's sample number below ``SOBOL_DEPTH``, deeper two independent hashes. Every strategy gets the
    same ones (:func:`bsdf_stage`; :func:`bsdf_points` for the strategies with tables)."""
    n_pix = keys.n_pix
    return pair(
        keys.first_sample + p // n_pix,
        key(key(keys.seed_key, p % n_pix), PAIR_BSDF + depth),
        depth < SOBOL_DEPTH,
    )


@njit(nogil=True, cache=True)
def bsdf_points(a, b, keys, depth, s_path, out):
    """``out[s]`` = the BRDF sample's two uniforms (:func:`_bsdf_pair`) of surface vertices ``[a, b)``: what
    a strategy with tables reads for its warp (``Sampler.sample_into``'s ``points``)."""
    for s in range(a, b):
        out[s, 0], out[s, 1] = _bsdf_pair(s_path[s], keys, depth)


@kernel
def bsdf_stage(a, b, depth, keys, est, materials, vtx, light, bsdf, scratch):
    """For the surface vertices ``[a, b)`` whose material's strategy has no tables (``mat_strategy[m]`` is
    ``UNIFORM``, ``COSINE`` or ``ANALYTIC``; ``BY_SAMPLER`` rows are left to their sampler objects): ``f``
    and the strategy's pdf at the light sample (if a candidate), and one BRDF sample with ``f`` there, the
    model reached by its dispatch id ``mat_model[m]`` with parameters ``mat_params[m]`` (MERL tables:
    ``mat_tables[m]``, float32; see :func:`_eval`), from :func:`_bsdf_pair`'s uniforms (as every strategy's).

    The uniforms of a block of ``BLOCK`` vertices are hashed first, in a loop of their own: there the hashes
    of independent paths overlap, where inside the long loop each vertex's chain of hashes would wait for the
    previous vertex's evaluations (68 ns a Lambert vertex in isolation instead of 81; the same numbers).

    A measured (MERL) material's lookups are deferred to the block's end (:func:`core.merl.find_cell`): the cells of
    its light and BRDF samples are found in the long loop, their corners read in a short loop of their own,
    then summed (:func:`core.merl.eval_merl_rows` explains why; the same values). ``mcell (BLOCK, 2, 3)`` int64
    and ``mfrac (BLOCK, 2, 3)`` are the cells' scratch (slot 0 the light sample's, 1 the BRDF sample's).

    The records (:mod:`renderer.stages.records`): the vertices ``vtx`` and their light samples ``light`` are
    read, ``light.f``, ``light.pdf_brdf`` (where ``est.nee``) and ``bsdf`` written; ``scratch`` holds the
    block's uniforms and cells; ``keys`` and ``depth`` key the random numbers."""
    nee, pass_key = est.nee, keys.pass_key
    mat_strategy, mat_model, mat_params, mat_tables = (
        materials.strategy, materials.model, materials.params, materials.tables
    )  # fmt: skip
    s_mat, s_path, s_wo = vtx.mat, vtx.path, vtx.wo
    l_wi_local, l_cand, l_f, l_pdf_brdf = light.wi_local, light.cand, light.f, light.pdf_brdf
    wi_local, pdf, f = bsdf.wi_local, bsdf.pdf, bsdf.f
    blk, mcell, mfrac = scratch.blk, scratch.mcell, scratch.mfrac
    touched = 0.0
    for s0 in range(a, b, BLOCK):
        s1 = min(b, s0 + BLOCK)
        deferred = 0
        for s in range(s0, s1):
            mcell[s - s0, 0, 0] = -1
            mcell[s - s0, 1, 0] = -1
            kind = mat_strategy[s_mat[s]]
            if kind == BY_SAMPLER:
                continue
            p = s_path[s]
            blk[s - s0, 0], blk[s - s0, 1] = _bsdf_pair(p, keys, depth)
            if kind == ANALYTIC:
                blk[s - s0, 2] = uniform(key(key(pass_key, p), depth), U_LOBE)
        for s in range(s0, s1):
            m = s_mat[s]
            kind = mat_strategy[m]
            if kind == BY_SAMPLER:
                continue
            mid = mat_model[m]
            prm = mat_params[m]
            table = mat_tables[m]
            wo = (s_wo[s, 0], s_wo[s, 1], s_wo[s, 2])
            if nee and l_cand[s]:
                wi = (l_wi_local[s, 0], l_wi_local[s, 1], l_wi_local[s, 2])
                if mid == MERL:
                    merl.find_cell(wi, wo, table, mcell[s - s0, 0], mfrac[s - s0, 0])
                    deferred += 1
                else:
                    l_f[s, 0], l_f[s, 1], l_f[s, 2] = _eval(mid, wi, wo, prm, table)
                if kind == UNIFORM:
                    l_pdf_brdf[s] = INV_TWO_PI if wi[2] >= 0.0 else 0.0
                elif kind == COSINE:
                    l_pdf_brdf[s] = cosine_hemisphere_pdf(wi[2])
                else:
                    l_pdf_brdf[s] = pdf_model(mid, wo, wi, prm)
            u1, u2 = blk[s - s0, 0], blk[s - s0, 1]
            if kind == UNIFORM:
                x, y, z = _uniform_hemisphere(u1, u2)
                q = INV_TWO_PI
            elif kind == COSINE:
                x, y, z = _cosine_hemisphere(u1, u2)
                q = cosine_hemisphere_pdf(z)
            else:
                x, y, z, q = sample_model(mid, wo, prm, u1, u2, blk[s - s0, 2])
            wi_local[s, 0], wi_local[s, 1], wi_local[s, 2] = x, y, z
            pdf[s] = q
            if q > 0.0 and mid == MERL:
                merl.find_cell((x, y, z), wo, table, mcell[s - s0, 1], mfrac[s - s0, 1])
                deferred += 1
            elif q > 0.0:
                f[s, 0], f[s, 1], f[s, 2] = _eval(mid, (x, y, z), wo, prm, table)
            else:
                f[s, 0], f[s, 1], f[s, 2] = 0.0, 0.0, 0.0
        if deferred == 0:
            continue
        for r in range(s1 - s0):  # the deferred lookups' corners, read with the whole block's in flight
            for slot in range(2):
                touched += merl.read_ahead(mat_tables[s_mat[s0 + r]], mcell[r, slot])
        for r in range(s1 - s0):
            for slot in range(2):
                if mcell[r, slot, 0] == -1:
                    continue
                out = l_f if slot == 0 else f
                out[s0 + r, 0], out[s0 + r, 1], out[s0 + r, 2] = merl.cell_value(
                    mat_tables[s_mat[s0 + r]], mcell[r, slot], mfrac[r, slot]
                )
    mfrac[0, 0, 0] = touched  # (the reads' sum, stored: not a dead computation to the compiler)
