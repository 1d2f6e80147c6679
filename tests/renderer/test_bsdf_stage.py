"""The compiled BRDF stage (``renderer.stages.bsdf.bsdf_stage``) on a measured material mixed with an analytic one:
the lookups it defers to a block's end (its cells first, the corners' reads of the whole block, then the sums)
give ``core.merl.eval_merl``'s values to the bit at the light samples and at the BRDF samples, across blocks
and in blocks that mix materials, and the rows without a light candidate keep their ``f``."""

from __future__ import annotations

from importlib import resources

import numpy as np
from numba import njit

from core.brdf import make_brdf
from core.dispatch import LAMBERT, MERL
from core.merl import eval_merl, measured_brdf
from renderer.stages.bsdf import COSINE, bsdf_stage
from renderer.stages.primitives import BLOCK
from renderer.stages.records import (
    BsdfSamples,
    Estimator,
    LightSamples,
    Materials,
    PassKeys,
    Scratch,
    Vertices,
)


@njit(cache=False)
def _lookups(wi, wo, table, out):
    for i in range(wi.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = eval_merl(
            (wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), table
        )


def _directions(rng: np.random.Generator, n: int, below: float) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:, 2] = np.abs(d[:, 2]) * np.where(rng.random(n) < below, -1.0, 1.0)
    return np.ascontiguousarray(d)


def test_measured_lookups_deferred_to_the_blocks_end_are_the_lookups() -> None:
    merl = measured_brdf(str(resources.files("resources.materials") / "red_plastic_ct.binary"))
    lambert = make_brdf("lambert", {"kd": 0.5})
    rng = np.random.default_rng(4)
    n = 3 * BLOCK + 21
    mat_tables = np.zeros((2, merl.params.shape[0]), dtype=np.float32)
    mat_tables[0] = merl.params
    mat_params = np.zeros((2, len(lambert.params)))
    mat_params[1] = lambert.params
    materials = Materials(np.array([COSINE, COSINE]), np.array([MERL, LAMBERT]), mat_params, mat_tables)
    vtx, samples, bsdf = Vertices.empty(n), LightSamples.empty(n), BsdfSamples.empty(n)
    s_mat, s_wo = vtx.mat, vtx.wo
    s_mat[:] = np.where(rng.random(n) < 0.7, 0, 1)
    s_mat[:BLOCK] = 0  # a block of the measured material only
    vtx.path[:] = np.arange(n)
    s_wo[:] = _directions(rng, n, below=0.05)
    l_wi_local, l_cand, l_f, f = samples.wi_local, samples.cand, samples.f, bsdf.f
    l_wi_local[:] = _directions(rng, n, below=0.1)
    l_cand[:] = rng.random(n) < 0.8
    for a in (l_f, f, samples.pdf_brdf, bsdf.pdf):
        a.fill(7.0)
    wi_local, pdf = bsdf.wi_local, bsdf.pdf
    wi_local.fill(7.0)
    keys = PassKeys(n, 0, np.uint64(11), np.uint64(12))
    est = Estimator(power=True, nee=True, ris=False)
    bsdf_stage(0, n, 0, keys, est, materials, vtx, samples, bsdf, Scratch.empty(BLOCK))

    measured = s_mat == 0
    want_l, want_f = np.empty((n, 3)), np.empty((n, 3))
    _lookups(l_wi_local, s_wo, mat_tables[0], want_l)
    _lookups(wi_local, s_wo, mat_tables[0], want_f)
    light = measured & l_cand
    np.testing.assert_array_equal(l_f[light], want_l[light])
    assert np.all(l_f[~l_cand] == 7.0)
    drawn = measured & (pdf > 0.0)
    np.testing.assert_array_equal(f[drawn], want_f[drawn])
    assert np.all(f[measured & ~(pdf > 0.0)] == 0.0)
    assert np.any(want_l[light] > 0.0) and np.any(want_f[drawn] > 0.0)
    assert np.any(want_l[light] == 0.0)  # light samples below the horizon read 0
    # the analytic rows of the mixed blocks: the model's own value
    other = ~measured
    np.testing.assert_array_equal(
        l_f[other & l_cand], lambert.eval(s_wo[other & l_cand], l_wi_local[other & l_cand])
    )
    np.testing.assert_array_equal(
        f[other & (pdf > 0)], lambert.eval(s_wo[other & (pdf > 0)], wi_local[other & (pdf > 0)])
    )
