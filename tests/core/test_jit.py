"""The kernels compiled without numba's reference counting (core.jit): what the option allows and refuses,
and that the hot loops keep it (losing it costs 15-20 % of a render pass and of a table build, silently)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from numba import njit
from numba.core.caching import NullCache
from numba.core.errors import NumbaError

from core.jit import KERNEL_OPTIONS, kernel

_UNCACHED = {**KERNEL_OPTIONS, "cache": False}


def test_kernel_options() -> None:
    @kernel
    def add(a, b):  # pragma: no cover - compiled
        return a + b

    assert add.targetoptions["_nrt"] is False
    assert add.targetoptions["nogil"] is True
    assert not isinstance(add._cache, NullCache)  # cached on disk
    assert add(2, 3) == 5


def test_a_kernel_reads_writes_and_views_the_arrays_it_is_given() -> None:
    @njit(inline="always")
    def row_sum(m, i):  # inlined with its array argument, as the stages' helpers are
        s = 0.0
        for j in range(m.shape[1]):
            if m[i, j] > 0.0:
                s += m[i, j]
        return s

    @njit(**_UNCACHED)
    def fill(m, out):
        for i in range(m.shape[0]):
            r = m[i]  # a view: no allocation
            out[i] = row_sum(m, i) + r[0]
        return out

    m = np.arange(12.0).reshape(4, 3) - 4.0
    out = np.zeros(4)
    res = fill(m, out)
    assert res is out
    expected = np.where(m > 0, m, 0).sum(axis=1) + m[:, 0]
    np.testing.assert_array_equal(out, expected)


def test_a_kernel_that_allocates_does_not_compile() -> None:
    @njit(**_UNCACHED)
    def scratch(n):
        return np.zeros(n)

    with pytest.raises(NumbaError):
        scratch(3)


HOT_KERNELS = [
    (f"renderer.stages.{module}", name)
    for module, name in (
        ("camera", "camera_stage"),
        ("hits", "hit_stage"),
        ("surface", "surface_stage"),
        ("bsdf", "bsdf_stage"),
        ("continuation", "continue_stage"),
        ("continuation", "shadow_stage"),
    )  # fmt: skip
] + [
    ("core.sampling.adaptive.draw", "sample_rows"),
    ("core.sampling.adaptive.draw", "pdf_rows"),
    ("core.sampling.adaptive.target", "g_dir"),
    ("core.sampling.adaptive.tree.nodes", "_child_stencil"),
    ("core.merl", "eval_merl"),
    ("core.models.ggx", "eval_ggx"),
    ("core.models.ward", "sample_ward"),
    ("core.kernels", "_eval_serial"),
]


@pytest.mark.parametrize(("module", "name"), HOT_KERNELS)
def test_the_hot_loops_hold_no_reference_counts(module: str, name: str) -> None:
    fn = getattr(importlib.import_module(module), name)
    assert fn.targetoptions.get("_nrt") is False, f"{module}.{name} lost core.jit.kernel"
