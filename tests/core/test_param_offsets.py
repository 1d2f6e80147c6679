"""Named kernel-row offsets (core.brdf.param_offsets): for every built-in model they tile the parameter part
of its kernel row, the module's kernels take them from the registered declaration, and a wrong name fails
with a message that names the declared parameters."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from core.brdf import Param, all_models, param_offsets, param_row_size
from core.errors import ParameterError

MODELS = all_models()
IDS = [m.name for m in MODELS]


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_offsets_tile_the_parameter_row(model):
    names = [p.name for p in model.params]
    offsets = param_offsets(model.params, *names)
    user = model.user_vector(model.resolve())
    end = param_row_size(model.params)
    assert end == len(user)
    # in declaration order, each parameter starts where the one before it ends: no gap, no overlap
    starts = [0]
    for p in model.params[:-1]:
        starts.append(starts[-1] + p.size)
    assert list(offsets) == starts
    assert starts[-1] + model.params[-1].size == end
    # each offset reads its own parameter's value, and derive appends after the parameters only
    values = model.resolve({p.name: _distinct(p, at) for p, at in zip(model.params, offsets, strict=True)})
    row = model.kernel_params(values)
    for p, at in zip(model.params, offsets, strict=True):
        np.testing.assert_array_equal(row[at : at + p.size], np.atleast_1d(values[p.name]))
    np.testing.assert_array_equal(row[:end], model.user_vector(values))


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_kernel_module_names_the_registered_declaration(model):
    """The module whose kernels read the offsets computes them from a declaration of the registered layout."""
    module = sys.modules[model.eval.py_func.__module__]
    layout = [(p.name, p.size) for p in module.PARAMS]
    assert layout == [(p.name, p.size) for p in model.params]


def test_a_wrong_name_is_an_error_that_lists_the_declared_names():
    params = (Param("kd", (0.5, 0.5, 0.5), kind="color"), Param("ks", 0.5), Param("n", 60.0, 1.0, 1e4))
    assert param_offsets(params, "n", "kd") == (4, 0)
    assert param_row_size(params) == 5
    with pytest.raises(ParameterError, match=r"no parameter 'alpha'; the parameters are: kd, ks, n"):
        param_offsets(params, "kd", "alpha")
    with pytest.raises(ParameterError, match=r"no parameter 'KD'"):
        param_offsets(params, "KD")  # names are case-sensitive
    with pytest.raises(ParameterError, match=r"'ks' is declared twice"):
        param_offsets((*params, Param("ks", 0.1)), "kd")


def _distinct(p: Param, at: int):
    """A value of ``p`` inside its bounds, different in each slot ``at, at + 1, ...`` of the row (a bool: 0 or
    1 by the slot's parity)."""
    if p.kind == "bool":
        return float(at % 2)
    picks = [
        p.lo + (p.hi - p.lo) * (0.05 + 0.9 * ((0.618034 * (slot + 1)) % 1.0)) for slot in range(at, at + 3)
    ]
    return tuple(picks) if p.kind == "color" else picks[0]
