"""The ``rgl_warp`` sampler (Dupuy & Jakob 2018's luminance warp) on analytic BRDFs, isotropic and
anisotropic: draws carry their pdf, none is lost (the density integrates to 1 over the sphere), chi-square
passes (Sidak-corrected 1 % over the cases), and its weights are nearly constant for a glossy lobe (what the warp is for)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import LUMINANCE, make_brdf
from core.geometry import degrees_to_dir
from core.sampling import make_sampler
from tests.core._rgl_checks import assert_warp_chi2

CASES = [
    ("phong", {"n": 100.0}, 30.0),
    ("ggx", {"alpha": 0.3}, 70.0),
    ("ward", {"sx": 0.05, "sy": 0.25}, 45.0),
]


@pytest.fixture(scope="module")
def samplers():
    return {name: make_sampler("rgl_warp", make_brdf(name, params), n_theta=10) for name, params, _ in CASES}


@pytest.mark.parametrize("name,params,theta", CASES, ids=[c[0] for c in CASES])
def test_chi2(samplers, name, params, theta):
    sampler = samplers[name]
    wo = degrees_to_dir(theta, 25.0)
    drawn = assert_warp_chi2(sampler, wo, n_tests=len(CASES), seed=5)
    ok = drawn.pdf > 0.0
    again = sampler.pdf(np.broadcast_to(wo, drawn.wi[ok][:20000].shape), drawn.wi[ok][:20000])
    assert np.allclose(again, drawn.pdf[ok][:20000], rtol=1e-9, atol=0.0)


def test_weights_follow_the_lobe(samplers):
    """f cos / pdf varies far less than under cosine sampling for a glossy lobe (Phong n = 100)."""
    wo = degrees_to_dir(30.0, 0.0)
    brdf = make_brdf("phong", {"n": 100.0})

    def rel_std(sampler) -> float:
        d = sampler.sample(wo, 200_000, seed=2)
        ok = d.pdf > 0.0
        w = (d.f[ok] @ LUMINANCE) * np.maximum(d.wi[ok, 2], 0.0) / d.pdf[ok]
        return float(w.std() / w.mean())

    warp, cosine = rel_std(samplers["phong"]), rel_std(make_sampler("cosine", brdf))
    assert warp < 0.25 * cosine, (warp, cosine)
    assert math.isfinite(warp)


def test_a_black_material_is_a_valid_table_that_reflects_nothing(tmp_path):
    """A black material has no retro-reflection to estimate an NDF from: its table takes the uniform NDF and
    keeps the shape of any other material's; it is written and read back, and its draws carry no energy."""
    from core.rgl.export import ExportOptions, tabulate
    from core.rgl.material import read_bsdf, write_bsdf

    options = ExportOptions(n_theta_i=4, vndf=(16, 16), samples=(8, 8))
    black = tabulate(make_brdf("lambert", {"kd": 0.0}), options)
    grey = tabulate(make_brdf("lambert", {"kd": 0.5}), options)
    for name in ("ndf", "sigma", "vndf", "luminance", "rgb"):
        a, b = getattr(black, name), getattr(grey, name)
        assert a.shape == b.shape and np.all(np.isfinite(a)), name
    assert np.all(black.ndf > 0.0) and np.all(black.sigma > 0.0) and np.all(black.rgb == 0.0)
    write_bsdf(tmp_path / "black.bsdf", black)
    back = read_bsdf(tmp_path / "black.bsdf")
    assert np.array_equal(back.rgb, black.rgb) and np.array_equal(back.ndf, black.ndf)
    sampler = make_sampler("rgl_warp", make_brdf("lambert", {"kd": 0.0}), n_theta=4, vndf=16, samples=8)
    drawn = sampler.sample(degrees_to_dir(40.0, 10.0), 4096, seed=3)
    assert np.all(np.isfinite(drawn.pdf)) and np.all(drawn.pdf >= 0.0)
    assert np.all(drawn.f == 0.0)  # no energy, whatever the density
