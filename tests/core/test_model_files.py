"""Models loaded from Python files (core.model_files): values, sampler, traits, pickling, bad files.

The example model file (resources/models/blinn_phong.py) is checked against the formula written here in
numpy, its analytic sampler against its own density (the shared checks every built-in sampler passes) and
by chi-square through the adaptive and analytic samplers; the shader path (.brdf) has its own tests in
tests/core/glsl.
"""

from __future__ import annotations

import multiprocessing
import pickle
import queue as queue_module
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from core.brdf import Traits, get_model, make_brdf, param_offsets, param_row_size
from core.chi2 import chi2_test, sampler_functions
from core.dispatch import FILE_MODEL
from core.errors import BrdfStudioError
from core.kernels import eval_batch
from core.model_files import ModelFileError, load_model_file
from core.sampling import make_sampler
from tests.conftest import all_pairs, direction_grid
from tests.core.models._checks import assert_pdf_integrates_to_one, assert_sample_matches_pdf

EXAMPLE = Path(__file__).resolve().parents[2] / "resources" / "models" / "blinn_phong.py"


def _blinn_phong(wo: np.ndarray, wi: np.ndarray, kd, ks: float, n: float) -> np.ndarray:
    h = wo + wi
    h /= np.maximum(np.linalg.norm(h, axis=1), 1e-300)[:, None]
    spec = ks * (n + 8) / (8 * np.pi) * np.maximum(h[:, 2], 0.0) ** n
    f = np.asarray(kd)[None, :] / np.pi + spec[:, None]
    return np.where(((wi[:, 2] > 0) & (wo[:, 2] > 0))[:, None], f, 0.0)


def _write(tmp_path: Path, name: str, body: str) -> Path:
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return path


def test_example_evaluates_to_its_formula():
    brdf = make_brdf(str(EXAMPLE), {"kd": (0.2, 0.4, 0.6), "n": 250.0})
    assert brdf.model.id == FILE_MODEL
    assert [p.name for p in brdf.model.params] == ["kd", "ks", "n"]
    wo, wi = all_pairs(direction_grid())
    expected = _blinn_phong(wo, wi, (0.2, 0.4, 0.6), 0.5, 250.0)
    np.testing.assert_allclose(brdf.eval(wo, wi), expected, rtol=1e-12, atol=0)


def test_example_sampler_draws_its_density():
    brdf = make_brdf(str(EXAMPLE), {"n": 80.0})
    assert brdf.model.sample is not None
    assert_sample_matches_pdf(brdf)
    assert_pdf_integrates_to_one(brdf)


@pytest.mark.parametrize("sampler", ["analytic", "adaptive_exact", "adaptive_warp"])
def test_file_model_samplers_pass_chi2(sampler):
    """Significance 0.01 shared among the 3 cases (Sidak), fixed seeds."""
    brdf = make_brdf(str(EXAMPLE), {"n": 40.0})
    wo = np.array([np.sin(np.radians(50.0)), 0.0, np.cos(np.radians(50.0))])
    sample, pdf = sampler_functions(make_sampler(sampler, brdf), wo)
    result = chi2_test(sample, pdf, n_samples=400_000, seed=11, alpha=0.01, n_tests=3)
    assert result.passed, result


def test_same_text_is_the_same_model_and_an_edit_is_another(tmp_path):
    path = _write(tmp_path, "m.py", EXAMPLE.read_text())
    first = get_model(str(path))
    assert get_model(str(path)) is first
    key = first.bind().key()
    path.write_text(EXAMPLE.read_text().replace('0.5, 0.0, 1.0, label="Specular weight"', "0.25, 0.0, 1.0"))
    second = get_model(str(path))
    assert second is not first
    assert second.defaults()["ks"] == 0.25
    assert second.bind().key() != key


def _eval_in_child(brdf, wo, wi, queue):
    queue.put(brdf.eval(wo, wi))


def _eval_in_spawned_process(brdf, wo, wi):
    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    child = ctx.Process(target=_eval_in_child, args=(brdf, wo, wi, queue))
    child.start()
    deadline = time.monotonic() + 600
    while True:
        try:
            values = queue.get(timeout=2)
            break
        except queue_module.Empty:
            assert child.is_alive(), f"the child process died (exit code {child.exitcode})"
            assert time.monotonic() < deadline, "the child process gave no answer within 600 s"
    child.join(60)
    assert child.exitcode == 0
    return values


def test_a_file_model_travels_by_content(tmp_path):
    """Pickled, the BRDF carries the file's text and binds again in the receiving process (another
    process's function addresses would crash it): a spawned process evaluates it without the file. The same
    text sent from a second path binds too (the example's @njit(cache=True) helpers, cached by numba under
    the first path's load, are found again or compiled afresh, never loaded under a module that is not there)."""
    wo, wi = all_pairs(direction_grid()[::7])
    for folder in ("first", "second"):
        path = _write(tmp_path / folder, "travelling.py", EXAMPLE.read_text())
        brdf = make_brdf(str(path), {"ks": 0.7})
        again = pickle.loads(pickle.dumps(brdf))
        assert again.model is brdf.model and again.values == brdf.values
        expected = brdf.eval(wo, wi)  # (compiled here first: the child loads the kernels from numba's cache)
        path.unlink()
        np.testing.assert_array_equal(_eval_in_spawned_process(brdf, wo, wi), expected)


def test_traits_are_measured_when_not_declared(tmp_path):
    body = """
        import math
        from core.brdf import Param
        PARAMS = (Param("a", 0.3, 0.0, 1.0),)

        def eval(wi, wo, p):
            v = p[0] * (1.0 + 0.5 * wi[0] * wo[0]) / math.pi
            return v, v, v
    """
    model = load_model_file(_write(tmp_path, "aniso.py", body))
    assert Traits.ISOTROPIC not in model.traits
    assert Traits.RECIPROCAL in model.traits
    assert Traits.MIRROR_SYMMETRIC in model.traits


def test_bad_values_are_reported_and_taken_as_zero(tmp_path):
    body = """
        from core.brdf import Param
        PARAMS = (Param("a", 0.5, 0.0, 1.0),)

        def eval(wi, wo, p):
            return wi[0] - 0.5, (wo[2] - 0.5) / 0.0 if wo[2] < 0.5 else 0.1, 0.2
    """
    brdf = make_brdf(str(_write(tmp_path, "bad.py", body)))
    findings = " ".join(brdf.model.source.findings)
    assert "negative" in findings and "bad.py" in findings
    wo = np.array([[0.0, 0.0, 1.0], [0.8, 0.0, 0.6]])
    wi = np.array([[0.0, 0.0, 1.0], [-0.8, 0.0, 0.6]])
    f = eval_batch(brdf.model, wi, wo, brdf.params)
    assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    np.testing.assert_array_equal(f[:, 0], [0.0, 0.0])


def test_zero_below_the_horizon_whatever_the_file_returns(tmp_path):
    body = """
        from core.brdf import Param
        PARAMS = (Param("a", 0.5, 0.0, 1.0),)

        def eval(wi, wo, p):
            return 1.0, 1.0, 1.0
    """
    brdf = make_brdf(str(_write(tmp_path, "flat.py", body)))
    wo = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, -0.8], [1.0, 0.0, 0.0]])
    wi = np.array([[0.0, 0.6, -0.8], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    np.testing.assert_array_equal(brdf.eval(wo, wi), np.zeros((3, 3)))


def test_named_offsets_in_a_model_file():
    brdf = make_brdf(str(EXAMPLE))
    assert param_offsets(brdf.model.params, "kd", "ks", "n") == (0, 3, 4)
    assert param_row_size(brdf.model.params) == 5


def test_a_wrong_offset_name_in_a_model_file_names_its_line(tmp_path):
    body = """
        from core.brdf import Param, param_offsets
        PARAMS = (Param("a", 0.5, 0.0, 1.0),)
        (B,) = param_offsets(PARAMS, "b")

        def eval(wi, wo, p):
            return p[B], p[B], p[B]
    """
    with pytest.raises(ModelFileError, match=r"wrong\.py:4: .*no parameter 'b'; the parameters are: a"):
        load_model_file(_write(tmp_path, "wrong.py", body))


@pytest.mark.parametrize(
    ("body", "line", "words"),
    [
        ("from core.brdf import Param\nPARAMS = (Param('a', 0.5),)\nraise ValueError('boom')\n", 3, "boom"),
        ("def eval(wi, wo, p):\n    return 1.0, 1.0, 1.0\n", None, "no PARAMS"),
        ("from core.brdf import Param\nPARAMS = (Param('a', 0.5),)\n", None, "no 'eval"),
        ("PARAMS = (1,)\ndef eval(wi, wo, p):\n    return 1.0, 1.0, 1.0\n", None, "not a core.brdf.Param"),
        (
            "from core.brdf import Param\nPARAMS = (Param('a', 2.0),)\ndef eval(wi, wo, p):\n    return 1.0, 1.0, 1.0\n",
            None,
            "outside its allowed range",
        ),
        (
            "from core.brdf import Param\nPARAMS = (Param('a', 0.5),)\ndef eval(wi, wo, p):\n    return 1.0, 1.0, 1.0\n"
            "def sample(wo, p, u1, u2, u3):\n    return 0.0, 0.0, 1.0, 1.0\n",
            None,
            "both 'sample' and 'pdf'",
        ),
        (
            "from core.brdf import Param\nPARAMS = (Param('a', 0.5),)\ndef eval(wi, wo, p):\n    return {'no': 1}\n",
            3,
            "does not compile",
        ),
        ("def eval(wi, wo, p)\n    return 1\n", 1, "SyntaxError"),
    ],
)
def test_bad_python_files_name_the_file_and_line(tmp_path, body, line, words):
    path = tmp_path / "broken.py"
    path.write_text(body)
    with pytest.raises(ModelFileError) as info:
        load_model_file(path)
    message = str(info.value)
    assert message.startswith(str(path)), message
    if line is not None:
        assert message.startswith(f"{path}:{line}:"), message
    assert words in message
    assert "\n" not in message
    assert info.value.exit_code == 2


@pytest.mark.parametrize("case", ["missing", "folder", "binary"])
def test_unreadable_model_files(tmp_path, case):
    path = tmp_path / "m.brdf"
    if case == "folder":
        path.mkdir()
    elif case == "binary":
        path.write_bytes(b"\xff\xfe\x00analytic")
    with pytest.raises(BrdfStudioError) as info:
        get_model(str(path))
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_a_shader_model_runs_its_code_specialized_to_each_setting(tmp_path, monkeypatch):
    """A .brdf model's row calls the shader compiled with the row's values as constants: one compile per
    setting (the same setting binds the same code), values equal to the general code's; past
    MAX_SPECIALIZATIONS settings the general code serves."""
    import core.model_files.shader as shader_models
    from core.glsl import compile_brdf, read_brdf_file
    from core.model_files.call import EVAL_ADDRESS, HEADER

    monkeypatch.setattr(shader_models, "SPECIALIZE", True)  # (the app's windows turn it off in their process)
    path = Path(__file__).parent / "glsl" / "fixtures" / "principled.brdf"
    general = compile_brdf(read_brdf_file(path))
    wo, wi = all_pairs(direction_grid()[::3])
    up = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
    addresses = []
    for roughness in (0.3, 0.6, 0.3):
        brdf = make_brdf(str(path), {"roughness": roughness, "anisotropic": 0.5})
        addresses.append(brdf.params[EVAL_ADDRESS])
        expected = general.evaluate(wi[up], wo[up], brdf.params[HEADER:])
        np.testing.assert_array_equal(eval_batch(brdf.model, wi[up], wo[up], brdf.params), expected)
    assert addresses[0] == addresses[2] != addresses[1]
    assert float(general.address) not in addresses

    monkeypatch.setattr(shader_models, "MAX_SPECIALIZATIONS", 0)
    fresh = _write(tmp_path, "capped.brdf", path.read_text())
    brdf = make_brdf(str(fresh), {"roughness": 0.4})
    np.testing.assert_array_equal(
        eval_batch(brdf.model, wi[up], wo[up], brdf.params),
        general.evaluate(wi[up], wo[up], brdf.params[HEADER:]),
    )
    assert brdf.params[EVAL_ADDRESS] == brdf.model.source.keep[0].address

    monkeypatch.setattr(shader_models, "MAX_SPECIALIZATIONS", 256)
    shader_models.set_specialization(False)  # as the app's process binds
    off = make_brdf(str(path), {"roughness": 0.45})
    assert off.params[EVAL_ADDRESS] == off.model.source.keep[0].address


_COMPILES_SCRIPT = """
import json, sys
import numpy as np
from numba.core import event
from core.kernels import eval_batch
from core.brdf import make_brdf
from core.sampling import make_sampler

compiled = []

class Listener(event.Listener):
    def on_start(self, ev):
        compiled.append(ev.data["dispatcher"].py_func.__module__ + "." + ev.data["dispatcher"].py_func.__qualname__)

    def on_end(self, ev):
        pass

brdf = make_brdf(sys.argv[1], {})
wi = np.array([[0.3, 0.1, 0.948]]); wo = np.array([[-0.2, 0.4, 0.894]])
wi /= np.linalg.norm(wi); wo /= np.linalg.norm(wo)
with event.install_listener("numba:compile", Listener()):
    eval_batch(brdf.model, wi, wo, brdf.params)
    for strategy in ("adaptive_exact", "adaptive_warp"):
        sampler = make_sampler(strategy, brdf, cache=False)
        sampler.sample(wo[0], 64, 1)
        sampler.pdf(wo, wi)
    from numba import njit

    njit(lambda x: x + 1)(1)  # a canary: the listener sees a compile
print(json.dumps(compiled))
"""


def test_a_file_model_compiles_none_of_the_built_in_kernels(tmp_path):
    """A .brdf model reaches evaluation and both adaptive samplers (table build, sampling, density) through
    the kernels a built-in model uses: once a built-in model has run them (numba's disk cache filled), a fresh
    process that loads the file compiles no numba function at all."""
    import json
    import subprocess
    import sys

    shader = Path(__file__).parent / "glsl" / "fixtures" / "principled.brdf"
    root = Path(__file__).resolve().parents[2]
    runs = {}
    for model in ("lambert", str(shader)):
        done = subprocess.run(
            [sys.executable, "-c", _COMPILES_SCRIPT, model],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=900,
        )
        assert done.returncode == 0, done.stderr
        runs[model] = json.loads(done.stdout.strip().splitlines()[-1])
    for compiled in runs.values():
        assert compiled and compiled[-1].endswith("<lambda>"), compiled  # the canary
    assert runs[str(shader)] == [runs[str(shader)][-1]], runs[str(shader)]
