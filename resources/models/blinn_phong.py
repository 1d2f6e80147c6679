"""Normalized Blinn-Phong over a Lambertian base: an example of a Python model file.

    f_r = kd / pi + ks (n + 8) / (8 pi) (n.h)^n

Open it wherever a model name goes: ``brdf-studio eval --model resources/models/blinn_phong.py --wi 30,0
--wo 30,180``, a scene material's ``"model"``, File > Import model... in the app, or
``make_brdf("blinn_phong.py")``. The format is described in docs/model-files.md.
"""

import math

from numba import njit

from core.brdf import Param, Traits, param_offsets, param_row_size

LABEL = "Blinn-Phong (example model file)"
CITATION = "J. F. Blinn, Models of Light Reflection for Computer Synthesized Pictures, SIGGRAPH 1977."
TRAITS = Traits.ISOTROPIC | Traits.RECIPROCAL | Traits.MIRROR_SYMMETRIC

PARAMS = (
    Param("kd", (0.3, 0.2, 0.1), 0.0, 1.0, kind="color", label="Diffuse albedo"),
    Param("ks", 0.5, 0.0, 1.0, label="Specular weight"),
    Param("n", 60.0, 1.0, 10000.0, log=True, label="Exponent"),
)
KD, KS, N = param_offsets(PARAMS, "kd", "ks", "n")
LOBE = param_row_size(PARAMS)
"""The probability of sampling the specular lobe, appended by ``derive``."""


def derive(p):
    """The kernel row: the parameters, then the specular lobe's sampling probability."""
    diffuse = (p[KD] + p[KD + 1] + p[KD + 2]) / 3.0
    total = diffuse + p[KS]
    lobe = p[KS] / total if total > 0.0 else 0.0
    return [*p, lobe]


@njit(nogil=True, cache=True)
def _half(wo, wi):
    x, y, z = wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]
    norm = math.sqrt(x * x + y * y + z * z)
    if norm == 0.0:
        return 0.0, 0.0, 1.0
    return x / norm, y / norm, z / norm


@njit(nogil=True, cache=True)
def eval(wi, wo, p):
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    h = _half(wo, wi)
    spec = p[KS] * (p[N] + 8.0) / (8.0 * math.pi) * max(h[2], 0.0) ** p[N]
    return p[KD] / math.pi + spec, p[KD + 1] / math.pi + spec, p[KD + 2] / math.pi + spec


@njit(nogil=True, cache=True)
def pdf(wo, wi, p):
    cosine = max(wi[2], 0.0) / math.pi
    # wo reflected about h and about -h is the same wi: the half vector's density counts the one of the two
    # that lies above the horizon, |h.z|
    h = _half(wo, wi)
    woh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]
    lobe = 0.0
    if woh > 0.0:
        lobe = (p[N] + 1.0) / (2.0 * math.pi) * abs(h[2]) ** p[N] / (4.0 * woh)
    return p[LOBE] * lobe + (1.0 - p[LOBE]) * cosine


@njit(nogil=True, cache=True)
def sample(wo, p, u1, u2, u3):
    phi = 2.0 * math.pi * u2
    if u3 < p[LOBE]:
        # half vector with density (n + 1) / (2 pi) cos^n, then wo reflected about it
        cos_h = u1 ** (1.0 / (p[N] + 1.0))
        sin_h = math.sqrt(max(0.0, 1.0 - cos_h * cos_h))
        hx, hy, hz = sin_h * math.cos(phi), sin_h * math.sin(phi), cos_h
        d = 2.0 * (wo[0] * hx + wo[1] * hy + wo[2] * hz)
        wi = (d * hx - wo[0], d * hy - wo[1], d * hz - wo[2])
    else:
        r = math.sqrt(u1)
        wi = (r * math.cos(phi), r * math.sin(phi), math.sqrt(max(0.0, 1.0 - u1)))
    return wi[0], wi[1], wi[2], pdf(wo, wi, p)
