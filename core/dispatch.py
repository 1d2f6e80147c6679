"""Every model's kernels reachable from compiled code by a small integer id: one switch, compiled once.

pbrt-v4 dispatches its BxDFs through a tagged pointer; the numba equivalent is a model id and the model's
kernel parameter vector, with one ``if/elif`` over the registered kernels. A loop over any mix of materials
(a batch evaluation, the adaptive sampler's construction and draws, a renderer's wavefront) calls
:func:`eval_model` and is an ordinary ``@njit(cache=True)`` function: numba compiles it once per machine
(at setup, ``python -m core.warmup``) and loads it from disk afterwards.

The switch functions are inlined into their callers (``inline="always"``): a loop whose id is the same on
every iteration then runs within ~20 % of a loop written for that one model (LLVM inlines the model's
kernel), where an out-of-line switch costs 2.5x (Phong: 15 against 37 M evaluations/s).

Models loaded from files share one branch (:data:`FILE_MODEL`, see :mod:`core.model_files.call`).

Adding a built-in model: its module under ``core/models/`` and one entry here (an id in :data:`MODEL_IDS` and a
branch in each switch). ``tests/core/test_dispatch.py`` checks that every registered model has an id and
that each switch agrees with the model's own kernels.
"""

from __future__ import annotations

from numba import njit

from core import merl  # the module, not its kernels: core.merl reaches this switch too (see merl._tabulate)
from core.model_files.call import eval_file_model, pdf_file_model, sample_file_model
from core.models.ashikhmin_shirley import (
    eval_ashikhmin_shirley,
    pdf_ashikhmin_shirley,
    sample_ashikhmin_shirley,
)
from core.models.beard_maxwell import eval_beard_maxwell
from core.models.blinn import eval_blinn, pdf_blinn, sample_blinn
from core.models.cook_torrance import eval_cook_torrance, pdf_cook_torrance, sample_cook_torrance
from core.models.coupled import eval_coupled, pdf_coupled, sample_coupled
from core.models.disney import eval_disney, pdf_disney, sample_disney
from core.models.ggx import eval_ggx, pdf_ggx, sample_ggx
from core.models.he import eval_he
from core.models.lafortune import eval_lafortune, pdf_lafortune, sample_lafortune
from core.models.lambert import eval_lambert, pdf_lambert, sample_lambert
from core.models.lewis import eval_lewis, pdf_lewis, sample_lewis
from core.models.minnaert import eval_minnaert
from core.models.oren_nayar import eval_oren_nayar
from core.models.phong import eval_phong, pdf_phong, sample_phong
from core.models.poulin_fournier import eval_poulin_fournier
from core.models.schlick import eval_schlick, pdf_schlick, sample_schlick
from core.models.strauss import eval_strauss
from core.models.ward import eval_ward, pdf_ward, sample_ward
from core.rgl.lookup import eval_rgl, pdf_rgl, sample_rgl

LAMBERT = 0
ASHIKHMIN_SHIRLEY = 1
BEARD_MAXWELL = 2
BLINN = 3
COOK_TORRANCE = 4
COUPLED = 5
GGX = 6
HE = 7
LAFORTUNE = 8
LEWIS = 9
MINNAERT = 10
OREN_NAYAR = 11
PHONG = 12
POULIN_FOURNIER = 13
SCHLICK_D = 14
SCHLICK_S = 15
STRAUSS = 16
WARD = 17
MERL = 18
MERL_NEAREST = 19
RGL = 20
RGL_ANISOTROPIC = 21
RGL_GENERAL = 22
DISNEY = 23
FILE_MODEL = 1000
"""Every model loaded from a file (:mod:`core.model_files`): reached through the native functions whose
addresses its parameter row carries, so loading one compiles nothing here. Not in :data:`MODEL_IDS`."""

MODEL_IDS: dict[str, int] = {
    "lambert": LAMBERT,
    "ashikhmin_shirley": ASHIKHMIN_SHIRLEY,
    "beard_maxwell": BEARD_MAXWELL,
    "blinn": BLINN,
    "cook_torrance": COOK_TORRANCE,
    "coupled": COUPLED,
    "ggx": GGX,
    "he": HE,
    "lafortune": LAFORTUNE,
    "lewis": LEWIS,
    "minnaert": MINNAERT,
    "oren_nayar": OREN_NAYAR,
    "phong": PHONG,
    "poulin_fournier": POULIN_FOURNIER,
    "schlick_d": SCHLICK_D,
    "schlick_s": SCHLICK_S,
    "strauss": STRAUSS,
    "ward": WARD,
    "merl": MERL,
    "merl_nearest": MERL_NEAREST,
    "rgl": RGL,
    "rgl_anisotropic": RGL_ANISOTROPIC,
    "rgl_general": RGL_GENERAL,
    "disney": DISNEY,
}
"""The id of every model the switches know, by model name."""


def model_id(name: str) -> int:
    """The dispatch id of the model called ``name`` (``KeyError`` for a model this module does not know)."""
    try:
        return MODEL_IDS[name]
    except KeyError:
        raise KeyError(f"model '{name}' has no dispatch id: add it to core/dispatch.py") from None


@njit(inline="always", nogil=True, cache=True)
def eval_model(mid, wi, wo, p):
    """``f_r(wi, wo)`` as ``(r, g, b)`` for model ``mid`` with kernel parameters ``p`` (local frame)."""
    if mid == LAMBERT:
        return eval_lambert(wi, wo, p)
    elif mid == ASHIKHMIN_SHIRLEY:
        return eval_ashikhmin_shirley(wi, wo, p)
    elif mid == BEARD_MAXWELL:
        return eval_beard_maxwell(wi, wo, p)
    elif mid == BLINN:
        return eval_blinn(wi, wo, p)
    elif mid == COOK_TORRANCE:
        return eval_cook_torrance(wi, wo, p)
    elif mid == COUPLED:
        return eval_coupled(wi, wo, p)
    elif mid == GGX:
        return eval_ggx(wi, wo, p)
    elif mid == HE:
        return eval_he(wi, wo, p)
    elif mid == LAFORTUNE:
        return eval_lafortune(wi, wo, p)
    elif mid == LEWIS:
        return eval_lewis(wi, wo, p)
    elif mid == MINNAERT:
        return eval_minnaert(wi, wo, p)
    elif mid == OREN_NAYAR:
        return eval_oren_nayar(wi, wo, p)
    elif mid == PHONG:
        return eval_phong(wi, wo, p)
    elif mid == POULIN_FOURNIER:
        return eval_poulin_fournier(wi, wo, p)
    elif mid == SCHLICK_D or mid == SCHLICK_S:
        return eval_schlick(wi, wo, p)
    elif mid == STRAUSS:
        return eval_strauss(wi, wo, p)
    elif mid == WARD:
        return eval_ward(wi, wo, p)
    elif mid == MERL:
        return merl.eval_merl(wi, wo, p)
    elif mid == MERL_NEAREST:
        return merl.eval_merl_nearest(wi, wo, p)
    elif mid == RGL or mid == RGL_ANISOTROPIC or mid == RGL_GENERAL:
        return eval_rgl(wi, wo, p)
    elif mid == DISNEY:
        return eval_disney(wi, wo, p)
    elif mid == FILE_MODEL:
        return eval_file_model(wi, wo, p)
    return 0.0, 0.0, 0.0


@njit(inline="always", nogil=True, cache=True)
def sample_model(mid, wo, p, u1, u2, u3):
    """The model's analytic sample ``(x, y, z, pdf_solid_angle)``; ``pdf = 0`` for a model without one."""
    if mid == LAMBERT:
        return sample_lambert(wo, p, u1, u2, u3)
    elif mid == ASHIKHMIN_SHIRLEY:
        return sample_ashikhmin_shirley(wo, p, u1, u2, u3)
    elif mid == BLINN:
        return sample_blinn(wo, p, u1, u2, u3)
    elif mid == COOK_TORRANCE:
        return sample_cook_torrance(wo, p, u1, u2, u3)
    elif mid == COUPLED:
        return sample_coupled(wo, p, u1, u2, u3)
    elif mid == GGX:
        return sample_ggx(wo, p, u1, u2, u3)
    elif mid == LAFORTUNE:
        return sample_lafortune(wo, p, u1, u2, u3)
    elif mid == LEWIS:
        return sample_lewis(wo, p, u1, u2, u3)
    elif mid == PHONG:
        return sample_phong(wo, p, u1, u2, u3)
    elif mid == SCHLICK_D or mid == SCHLICK_S:
        return sample_schlick(wo, p, u1, u2, u3)
    elif mid == WARD:
        return sample_ward(wo, p, u1, u2, u3)
    elif mid == RGL or mid == RGL_ANISOTROPIC or mid == RGL_GENERAL:
        return sample_rgl(wo, p, u1, u2, u3)
    elif mid == DISNEY:
        return sample_disney(wo, p, u1, u2, u3)
    elif mid == FILE_MODEL:
        return sample_file_model(wo, p, u1, u2, u3)
    return 0.0, 0.0, 1.0, 0.0


@njit(inline="always", nogil=True, cache=True)
def pdf_model(mid, wo, wi, p):
    """The density (per unit solid angle) of :func:`sample_model`; 0 for a model without a sampler."""
    if mid == LAMBERT:
        return pdf_lambert(wo, wi, p)
    elif mid == ASHIKHMIN_SHIRLEY:
        return pdf_ashikhmin_shirley(wo, wi, p)
    elif mid == BLINN:
        return pdf_blinn(wo, wi, p)
    elif mid == COOK_TORRANCE:
        return pdf_cook_torrance(wo, wi, p)
    elif mid == COUPLED:
        return pdf_coupled(wo, wi, p)
    elif mid == GGX:
        return pdf_ggx(wo, wi, p)
    elif mid == LAFORTUNE:
        return pdf_lafortune(wo, wi, p)
    elif mid == LEWIS:
        return pdf_lewis(wo, wi, p)
    elif mid == PHONG:
        return pdf_phong(wo, wi, p)
    elif mid == SCHLICK_D or mid == SCHLICK_S:
        return pdf_schlick(wo, wi, p)
    elif mid == WARD:
        return pdf_ward(wo, wi, p)
    elif mid == RGL or mid == RGL_ANISOTROPIC or mid == RGL_GENERAL:
        return pdf_rgl(wo, wi, p)
    elif mid == DISNEY:
        return pdf_disney(wo, wi, p)
    elif mid == FILE_MODEL:
        return pdf_file_model(wo, wi, p)
    return 0.0
