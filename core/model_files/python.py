"""Python model files: a module that declares a model as the built-in ones do, loaded while the program runs.

The file (format: ``docs/model-files.md``; an example: ``resources/models/``) is run as a Python module and
declares:

``PARAMS``
    a sequence of :class:`core.brdf.Param`; the kernel row holds them in this order (a color takes three
    slots; :func:`core.brdf.param_offsets` gives each named parameter's offset).
``eval(wi, wo, p) -> (r, g, b)``
    numba-compilable (plain or ``@numba.njit``), in the local frame, as the built-in kernels
    (:mod:`core.brdf`).
``sample(wo, p, u1, u2, u3) -> (x, y, z, pdf)`` and ``pdf(wo, wi, p) -> float``
    optional, both or neither: an analytic sampler and its density per unit solid angle.
``LABEL``, ``CITATION``, ``TRAITS``
    optional: a display name, a reference, and :class:`core.brdf.Traits` (measured when absent).

Each kernel is wrapped in a numba ``cfunc`` with the native signature of :mod:`core.model_files.call`.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import traceback
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numba import carray, cfunc, njit
from numba import types as nt
from numba.core.registry import CPUDispatcher

from core.brdf import Model, Param, Traits
from core.errors import ParameterError
from core.model_files import ModelFileError, ModelSource
from core.model_files.call import (
    EVAL_ADDRESS,
    HEADER,
    PDF_ADDRESS,
    SAMPLE_ADDRESS,
    eval_file_model,
    pdf_file_model,
    sample_file_model,
)
from core.model_files.declarations import python_param_line

_F8 = nt.float64
_ROW = nt.CPointer(nt.float64)
EVAL_SIGNATURE = nt.void(_F8, _F8, _F8, _F8, _F8, _F8, _ROW, nt.int64, _ROW)
SAMPLE_SIGNATURE = nt.void(_F8, _F8, _F8, _ROW, nt.int64, _F8, _F8, _F8, _ROW)
PDF_SIGNATURE = _F8(_F8, _F8, _F8, _F8, _F8, _F8, _ROW, nt.int64)


def _native_eval(fn: Callable[..., Any]) -> Any:
    @cfunc(EVAL_SIGNATURE)
    def native(wix, wiy, wiz, wox, woy, woz, p, n, out):  # pragma: no cover (compiled)
        r, g, b = fn((wix, wiy, wiz), (wox, woy, woz), carray(p, (n,)))
        out[0] = r
        out[1] = g
        out[2] = b

    return native


def _native_sample(fn: Callable[..., Any]) -> Any:
    @cfunc(SAMPLE_SIGNATURE)
    def native(wox, woy, woz, p, n, u1, u2, u3, out):  # pragma: no cover (compiled)
        x, y, z, pdf = fn((wox, woy, woz), carray(p, (n,)), u1, u2, u3)
        out[0] = x
        out[1] = y
        out[2] = z
        out[3] = pdf

    return native


def _native_pdf(fn: Callable[..., Any]) -> Any:
    @cfunc(PDF_SIGNATURE)
    def native(wox, woy, woz, wix, wiy, wiz, p, n):  # pragma: no cover (compiled)
        return fn((wox, woy, woz), (wix, wiy, wiz), carray(p, (n,)))

    return native


def _where(path: str, exc: BaseException) -> str:
    """``path:LINE: Type: message`` at the innermost line of the model file in ``exc``'s traceback."""
    line = None
    if isinstance(exc, SyntaxError) and exc.lineno is not None:
        line = exc.lineno
    for frame in traceback.extract_tb(exc.__traceback__):
        if os.path.abspath(frame.filename) == os.path.abspath(path):
            line = frame.lineno
    message = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    if isinstance(exc, SyntaxError):
        message = exc.msg
    at = f"{path}:{line}" if line else path
    return f"{at}: {type(exc).__name__}: {message}" if message else f"{at}: {type(exc).__name__}"


def _module_path(path: str, text: str, digest: str) -> str:
    """A file holding ``text``: ``path`` itself when it does, else a copy in the temporary folder (a model
    sent from another process), so that numba can read and cache the functions it compiles."""
    try:
        if Path(path).read_bytes() == text.encode("utf-8"):
            return path
    except OSError:
        pass
    folder = Path(tempfile.gettempdir()) / "brdf-studio-models" / digest[:32]
    folder.mkdir(parents=True, exist_ok=True)
    copy = folder / Path(path).name
    if not copy.exists():
        tmp = copy.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, copy)
    return str(copy)


MODULE_PREFIX = "brdf_studio_model_"


def _install_locator() -> None:
    """Where numba caches a model file's own ``@njit(cache=True)`` functions: a folder per module (per text).

    numba keys a cached function by its file's path and stamp, and records its module's name, which it imports
    when it loads the entry. A model's module is named by its text, while the file numba sees is the user's or a
    copy in the temporary folder: entries of one file path written under another name (the same text read from
    another path first) would fail to load. One folder per module name keeps them apart."""
    from numba.core import caching, config

    class ModelFileLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
        def __init__(self, py_func: Any, py_file: str) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            base = config.CACHE_DIR or os.path.join(tempfile.gettempdir(), "brdf-studio-numba")
            self._cache_path = os.path.join(base, "model_files", py_func.__module__)

        def get_cache_path(self) -> str:
            return self._cache_path

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if not str(getattr(py_func, "__module__", "")).startswith(MODULE_PREFIX):
                return None
            return cls(py_func, py_file)

    classes = caching.CacheImpl._locator_classes
    if not any(c.__name__ == "ModelFileLocator" for c in classes):
        classes.insert(0, ModelFileLocator)


def _run(path: str, text: str, digest: str) -> types.ModuleType:
    # named by the text alone, and its cached functions kept in that name's folder (_install_locator)
    name = MODULE_PREFIX + digest[:16]
    _install_locator()
    file = _module_path(path, text, digest)
    module = types.ModuleType(name)
    module.__file__ = file
    sys.modules[name] = module  # numba resolves the functions' globals through their module
    try:
        exec(compile(text, file, "exec"), module.__dict__)  # the user's model file: running it is its purpose
    except Exception as exc:  # any error of the user's code, reported at its line
        del sys.modules[name]
        raise ModelFileError(_where(file, exc).replace(file, path)) from None
    return module


def _jitted(module: types.ModuleType, attr: str, path: str) -> Callable[..., Any] | None:
    fn = getattr(module, attr, None)
    if fn is None:
        return None
    if isinstance(fn, CPUDispatcher):
        fn = fn.py_func
    if not callable(fn):
        raise ModelFileError(f"{path}: '{attr}' must be a function, got {type(fn).__name__}")
    # numpy's error model: a division by zero gives inf or NaN (which the host takes as 0) instead of an
    # exception, which no native caller could receive
    return njit(nogil=True, error_model="numpy")(fn)


def _compiled(make: Callable[[Callable[..., Any]], Any], fn: Callable[..., Any], attr: str, path: str) -> Any:
    try:
        return make(fn)
    except Exception as exc:  # numba's typing and lowering errors: the user's kernel does not compile
        first = next((ln.strip() for ln in str(exc).splitlines() if ln.strip()), type(exc).__name__)
        line = getattr(getattr(fn, "py_func", fn), "__code__", None)
        at = f"{path}:{line.co_firstlineno}" if line is not None else path
        raise ModelFileError(f"{at}: '{attr}' does not compile with numba: {first}") from None


def _params(module: types.ModuleType, path: str) -> tuple[Param, ...]:
    params = getattr(module, "PARAMS", None)
    if params is None:
        raise ModelFileError(f"{path}: no PARAMS: declare the parameters, e.g. PARAMS = (Param('kd', 0.5),)")
    try:
        params = tuple(params)
    except TypeError:
        raise ModelFileError(f"{path}: PARAMS must be a sequence of core.brdf.Param") from None
    for i, p in enumerate(params):
        if not isinstance(p, Param):
            raise ModelFileError(f"{path}: PARAMS[{i}] is a {type(p).__name__}, not a core.brdf.Param")
    return params


def _check_defaults(params: tuple[Param, ...], path: str, text: str) -> None:
    """Each default within its own range, or ``ModelFileError`` at the line of its ``Param(...)``."""
    for p in params:
        try:
            p.validate(Path(path).name, p.default)
        except ParameterError as exc:
            line = python_param_line(text, p.name)
            raise ModelFileError(
                f"{path}:{line}: the default of {exc}" if line else f"{path}: {exc}"
            ) from None


def load(path: str, text: str, digest: str) -> Model:
    """The model a Python model file's text declares (``path`` names it in messages)."""
    from core.model_files.probe import bad_values, measured_traits

    module = _run(path, text, digest)
    params = _params(module, path)
    _check_defaults(params, path, text)
    eval_fn = _jitted(module, "eval", path)
    if eval_fn is None:
        raise ModelFileError(f"{path}: no 'eval(wi, wo, p)' function")
    sample_fn, pdf_fn = _jitted(module, "sample", path), _jitted(module, "pdf", path)
    if (sample_fn is None) != (pdf_fn is None):
        raise ModelFileError(f"{path}: give both 'sample' and 'pdf', or neither")
    keep = [_compiled(_native_eval, eval_fn, "eval", path)]
    header = np.zeros(HEADER)
    header[EVAL_ADDRESS] = float(keep[0].address)
    if sample_fn is not None and pdf_fn is not None:
        keep += [
            _compiled(_native_sample, sample_fn, "sample", path),
            _compiled(_native_pdf, pdf_fn, "pdf", path),
        ]
        header[SAMPLE_ADDRESS] = float(keep[1].address)
        header[PDF_ADDRESS] = float(keep[2].address)
    derive_fn = getattr(module, "derive", None)

    def derive(user: np.ndarray) -> np.ndarray:
        own = np.asarray(derive_fn(user), dtype=np.float64) if derive_fn is not None else user
        return np.concatenate([header, own])

    traits = getattr(module, "TRAITS", None)
    if traits is not None and not isinstance(traits, Traits):
        raise ModelFileError(f"{path}: TRAITS must be core.brdf.Traits flags, got {type(traits).__name__}")
    stem = Path(path).stem
    try:
        model = Model(
            name=path,
            label=str(getattr(module, "LABEL", f"{stem} (.py)")),
            citation=str(getattr(module, "CITATION", f"Python model file {path}")),
            params=params,
            traits=traits if traits is not None else Traits.NONE,
            eval=eval_file_model,
            sample=sample_file_model if sample_fn is not None else None,
            pdf=pdf_file_model if pdf_fn is not None else None,
            derive=derive,
            doc=module.__doc__ or "",
            source=ModelSource(path=path, text=text, digest=digest, keep=(module, keep)),
        )
        model.kernel_params()  # the defaults must validate, and derive must run
    except ModelFileError:
        raise
    except (
        Exception
    ) as exc:  # a bad declaration: duplicate names, a default outside its range, derive raising
        raise ModelFileError(_where(path, exc)) from None
    if traits is None:
        model = dataclasses.replace(model, traits=measured_traits(params, model.kernel_params))
    findings = tuple(bad_values(model.kernel_params(), Path(path).name))
    return dataclasses.replace(model, source=dataclasses.replace(model.source, findings=findings))  # type: ignore[arg-type]
