"""Cross-check of our Lambert and GGX models against Mitsuba 3 (``scalar_rgb`` variant), an independent
implementation.

Conventions: Mitsuba's ``si.wi`` is the direction towards the viewer (our ``wo``) and the ``wo`` argument of
``BSDF.eval`` is the light direction (our ``wi``); ``eval`` returns ``f_r * cos(theta)`` of that argument, so
we compare with ``f_r(wi, wo) * wi.z``. Mitsuba's ``roughconductor`` uses the same GGX ``D``, the separable
Smith ``G1(wi) G1(wo)`` and the exact conductor Fresnel; with ``sample_visible`` its ``pdf`` is the
visible-normal density ``G1(wo) D(h) / (4 wo.z)``, equal to ours when ``kd = 0``. Mitsuba computes in
float32, hence the 1e-4 relative tolerance (observed: about 1e-6).

Skipped only when ``import mitsuba`` fails.
"""

from __future__ import annotations

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir
from core.models._fresnel import fresnel_conductor
from core.sampling import make_sampler

mi = pytest.importorskip("mitsuba")
mi.set_variant("scalar_rgb")

RTOL = 1e-4
THETAS = (0.5, 10.0, 30.0, 50.0, 70.0, 85.0, 89.0)
PHIS = (0.0, 75.0, 180.0, 290.0)


def _directions() -> np.ndarray:
    return np.stack([degrees_to_dir(t, p) for t in THETAS for p in PHIS])


def _mitsuba_eval(bsdf, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*wo)
    return np.array(bsdf.eval(ctx, si, mi.Vector3f(*wi)), dtype=np.float64)


def _mitsuba_pdf(bsdf, wo: np.ndarray, wi: np.ndarray) -> float:
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*wo)
    return float(bsdf.pdf(ctx, si, mi.Vector3f(*wi)))


def _compare(ours_brdf, theirs, check_pdf: bool = False) -> None:
    dirs = _directions()
    sampler = make_sampler("analytic", ours_brdf) if check_pdf else None
    for wo in dirs:
        ours = ours_brdf.eval(np.broadcast_to(wo, dirs.shape), dirs) * dirs[:, 2:3]
        ref = np.stack([_mitsuba_eval(theirs, wo, wi) for wi in dirs])
        np.testing.assert_allclose(ours, ref, rtol=RTOL, atol=1e-30, err_msg=f"wo = {wo}")
        if sampler is not None:
            pdf = sampler.pdf(np.broadcast_to(wo, dirs.shape), dirs)
            ref_pdf = np.array([_mitsuba_pdf(theirs, wo, wi) for wi in dirs])
            np.testing.assert_allclose(pdf, ref_pdf, rtol=RTOL, atol=1e-30, err_msg=f"pdf, wo = {wo}")


@pytest.mark.parametrize("kd", [(0.8, 0.8, 0.8), (0.9, 0.35, 0.05)])
def test_lambert_matches_mitsuba_diffuse(kd):
    theirs = mi.load_dict({"type": "diffuse", "reflectance": {"type": "rgb", "value": list(kd)}})
    _compare(get_model("lambert").bind(kd=kd), theirs)


@pytest.mark.parametrize(
    ("alpha", "eta", "k"),
    [
        (0.2, (0.200, 0.924, 1.102), (3.912, 2.452, 2.142)),  # copper, our defaults
        (0.05, (0.143, 0.374, 1.442), (3.983, 2.385, 1.603)),  # gold-like, glossy
        (0.7, (1.5, 1.5, 1.5), (0.0, 0.0, 0.0)),  # rough dielectric-like Fresnel
    ],
)
def test_ggx_matches_mitsuba_roughconductor(alpha, eta, k):
    theirs = mi.load_dict(
        {
            "type": "roughconductor",
            "distribution": "ggx",
            "sample_visible": True,
            "alpha": alpha,
            "eta": {"type": "rgb", "value": list(eta)},
            "k": {"type": "rgb", "value": list(k)},
        }
    )
    _compare(get_model("ggx").bind(alpha=alpha, eta=eta, k=k, kd=0.0), theirs, check_pdf=True)


def test_conductor_fresnel_matches_mitsuba():
    for n, k in ((0.617, 2.63), (0.2, 3.9), (1.5, 0.0), (2.9, 3.1)):
        for c in np.linspace(0.0, 1.0, 21):
            ref = float(mi.fresnel_conductor(float(c), mi.Complex2f(n, k)))
            assert fresnel_conductor(float(c), n, k) == pytest.approx(ref, rel=RTOL, abs=1e-7)
