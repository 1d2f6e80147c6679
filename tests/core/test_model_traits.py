"""Physical checks for every registered model, chosen by its declared traits.

Dense directions include grazing angles up to and at 90 degrees. Tolerances: reciprocity to 1e-6 relative,
isotropy and mirror symmetry to 1e-6 relative (plus 1e-12 absolute for values that are zero up to rounding).
"""

from __future__ import annotations

import numpy as np
import pytest

from core.brdf import all_models
from core.errors import ParameterError
from tests.conftest import all_pairs, direction_grid

MODELS = all_models()
IDS = [m.name for m in MODELS]
KNOWN_UNITS = {"", "rad", "µm", "nm", "radii"}  # "" for dimensionless parameters
RECIPROCAL = [m for m in MODELS if m.reciprocal]
ISOTROPIC = [m for m in MODELS if m.isotropic]
MIRROR = [m for m in MODELS if m.mirror_symmetric]


def _random_params(model, rng, count=3):
    """Parameter settings drawn inside each parameter's bounds (log-uniform where declared)."""
    out = []
    for _ in range(count):
        values = {}
        for p in model.params:
            if p.kind == "bool":
                values[p.name] = float(rng.integers(0, 2))
                continue
            lo, hi = p.lo, p.hi
            if p.log and lo > 0:
                draw = lambda: float(np.exp(rng.uniform(np.log(lo), np.log(hi))))  # noqa: B023
            else:
                draw = lambda: float(rng.uniform(lo, hi))  # noqa: B023
            values[p.name] = (draw(), draw(), draw()) if p.kind == "color" else draw()
        out.append(values)
    return out


def _settings(model, rng):
    return [model.defaults(), *_random_params(model, rng)]


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_finite_and_non_negative_everywhere(model, rng):
    wo, wi = all_pairs(direction_grid())
    for values in _settings(model, rng):
        f = model.bind(values).eval(wo, wi)
        assert np.all(np.isfinite(f)), f"{model.name} {values}: non-finite values"
        assert np.all(f >= 0.0), f"{model.name} {values}: negative values, min {f.min()}"


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_zero_below_the_horizon(model):
    w = direction_grid()
    below = w * np.array([1.0, 1.0, -1.0])
    below = below[below[:, 2] < 0]
    brdf = model.bind()
    wo, wi = all_pairs(w)
    assert np.all(brdf.eval(np.repeat(below, len(w), axis=0), np.tile(w, (len(below), 1))) == 0.0)
    assert np.all(brdf.eval(np.tile(w, (len(below), 1)), np.repeat(below, len(w), axis=0)) == 0.0)


def _assert_invariant(model, rng, transforms, atol: float) -> None:
    """``f`` is unchanged, at the defaults and random parameters, by each ``transform(wo, wi) -> (wo, wi)``."""
    wo, wi = all_pairs(direction_grid())
    for values in _settings(model, rng):
        brdf = model.bind(values)
        a = brdf.eval(wo, wi)
        for k, transform in enumerate(transforms):
            b = brdf.eval(*transform(wo, wi))
            np.testing.assert_allclose(a, b, rtol=1e-6, atol=atol, err_msg=f"{model.name} {values} #{k}")


def _rotation(angle: float):
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return lambda wo, wi: (wo @ rot.T, wi @ rot.T)


def _mirror(sign):
    return lambda wo, wi: (wo * sign, wi * sign)


@pytest.mark.parametrize("model", RECIPROCAL, ids=[m.name for m in RECIPROCAL])
def test_reciprocal(model, rng):
    _assert_invariant(model, rng, [lambda wo, wi: (wi, wo)], atol=1e-12)


@pytest.mark.parametrize("model", ISOTROPIC, ids=[m.name for m in ISOTROPIC])
def test_isotropic_under_rotation_about_the_normal(model, rng):
    _assert_invariant(model, rng, [_rotation(angle) for angle in (0.3, 2.0, -1.1)], atol=1e-9)


def test_every_anisotropic_model_declares_its_mirror_symmetry():
    """The adaptive sampler keeps a quarter of the trees for these (the test below checks the claim)."""
    assert {m.name for m in MODELS if not m.isotropic} == {m.name for m in MIRROR}


@pytest.mark.parametrize("model", MIRROR, ids=[m.name for m in MIRROR])
def test_mirror_symmetric_in_both_tangent_axes(model, rng):
    _assert_invariant(model, rng, [_mirror((-1.0, 1.0, 1.0)), _mirror((1.0, -1.0, 1.0))], atol=1e-12)


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_parameter_validation_names_the_parameter(model):
    for p in model.params:
        if p.kind == "bool":
            with pytest.raises(ParameterError, match=p.name):
                model.bind({p.name: "maybe"})
            continue
        for bad in (float("nan"), float("inf"), p.lo - 1.0 - abs(p.lo), p.hi + 1.0 + abs(p.hi)):
            with pytest.raises(
                ParameterError, match=rf"'{p.name}'.*\[{p.lo:g}, {p.hi:g}\]|'{p.name}'.*finite"
            ):
                model.bind({p.name: bad})
    with pytest.raises(ParameterError, match="no parameter 'not_a_parameter'"):
        model.bind({"not_a_parameter": 1.0})


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_declaration_is_complete(model):
    assert model.citation and model.label and model.doc
    for p in model.params:
        assert p.lo <= (min(p.default) if isinstance(p.default, tuple) else p.default) <= p.hi
        # The desktop app builds its property editor from these: a human label, a unit it can print.
        assert p.label.strip(), f"{p.name}: no label"
        assert p.unit in KNOWN_UNITS, f"{p.name}: unit {p.unit!r} is not one of {sorted(KNOWN_UNITS)}"
        assert not (p.log and p.lo <= 0.0), f"{p.name}: a log-scale parameter needs a positive lower bound"
    assert (model.sample is None) == (model.pdf is None)
