"""Generated per-kernel modules: same results as the generic drivers, compiled once and loaded from disk by
later processes, a fallback for kernels that cannot be imported, and a usable folder when the configured one
is not writable."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from numba import njit

from core import kernels
from core.geometry import degrees_to_dir
from core.model import make_brdf
from core.specialize import kernel_reference, specialize


def _pairs(n=500, seed=0):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(2, n, 3))
    v[..., 2] = np.abs(v[..., 2])
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    return np.ascontiguousarray(v[0]), np.ascontiguousarray(v[1])


@pytest.mark.parametrize("name", ["cook_torrance", "ward", "lafortune"])
def test_specialized_drivers_match_the_generic_ones(name):
    brdf = make_brdf(name)
    wi, wo = _pairs()
    ref = np.empty_like(wi)
    kernels._eval_serial(brdf.model.eval, wi, wo, brdf.params, ref)
    np.testing.assert_array_equal(kernels.eval_batch(brdf.model, wi, wo, brdf.params), ref)
    np.testing.assert_array_equal(kernels.eval_batch(brdf.model, wi, wo, brdf.params, threads=True), ref)
    u = np.random.default_rng(1).random((200, 3))
    wo_s = np.repeat(degrees_to_dir(40.0, 10.0)[None, :], 200, axis=0)
    wi_ref, pdf_ref = np.empty_like(wo_s), np.empty(200)
    kernels._sample_serial(brdf.model.sample, wo_s, brdf.params, u, wi_ref, pdf_ref)
    wi_s, pdf_s = kernels.sample_batch(brdf.model.sample, wo_s, brdf.params, u)
    np.testing.assert_array_equal(wi_s, wi_ref)
    np.testing.assert_array_equal(pdf_s, pdf_ref)
    np.testing.assert_array_equal(kernels.pdf_batch(brdf.model.pdf, wo_s, wi_s, brdf.params), pdf_ref)


def test_a_later_process_loads_the_compiled_code_from_disk(tmp_path):
    script = textwrap.dedent(
        """
        import numpy as np
        from core import kernels
        from core.model import make_brdf
        from core.specialize import specialize
        brdf = make_brdf("phong")
        wi = np.array([[0.0, 0.0, 1.0]])
        kernels.eval_batch(brdf.model, wi, wi, brdf.params)
        mod = specialize(kernels._EVAL, _eval=brdf.model.eval)
        print(sum(mod.serial.stats.cache_hits.values()), sum(mod.serial.stats.cache_misses.values()))
        """
    )
    env = {**os.environ, "BRDF_STUDIO_KERNEL_CACHE": str(tmp_path)}

    def run():
        out = subprocess.run(
            [sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True
        )
        hits, misses = (int(v) for v in out.stdout.split())
        return hits, misses

    assert run() == (0, 1)  # compiled and stored
    assert run() == (1, 0)  # loaded, not compiled


def test_the_module_depends_on_the_template_and_the_kernel(tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_STUDIO_KERNEL_CACHE", str(tmp_path))
    a = specialize("X = 1", _eval=make_brdf("phong").model.eval)
    b = specialize("X = 2", _eval=make_brdf("phong").model.eval)
    c = specialize("X = 1", _eval=make_brdf("blinn").model.eval)
    assert (a.X, b.X, c.X) == (1, 2, 1)
    assert len({a.__name__, b.__name__, c.__name__}) == 3
    assert specialize("X = 1", _eval=make_brdf("phong").model.eval) is a


@njit
def _module_level_kernel(wi, wo, p):
    return 1.0, 2.0, 3.0


def test_kernels_that_cannot_be_imported_use_the_generic_drivers():
    def factory():
        @njit
        def inner(wi, wo, p):
            return wi[2] * p[0], 0.0, 0.0

        return inner

    closure = factory()
    assert kernel_reference(closure) is None
    assert kernel_reference(_module_level_kernel) == (__name__, "_module_level_kernel")
    assert specialize(kernels._EVAL, _eval=closure) is None

    class Fake:
        eval = closure

    wi, wo = _pairs(10)
    out = kernels.eval_batch(Fake, wi, wo, np.array([2.0]))  # type: ignore[arg-type]
    np.testing.assert_allclose(out[:, 0], 2.0 * wi[:, 2])


def test_an_unwritable_folder_falls_back_to_a_private_one(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("BRDF_STUDIO_KERNEL_CACHE", str(blocked / "kernels"))
    mod = specialize("Y = 5", _eval=make_brdf("lambert").model.eval)
    assert mod is not None and mod.Y == 5
    assert not str(mod.__file__).startswith(str(blocked))
