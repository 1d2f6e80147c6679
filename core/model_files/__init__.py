"""Models a user brings as files: BRDF Explorer's analytic ``.brdf`` shaders and Python model files.

A path goes wherever a model name goes: :func:`core.brdf.get_model` hands a name that ends in ``.brdf`` or
``.py`` to :func:`load_model_file`, which compiles the file into native functions and returns a
:class:`core.brdf.Model` like a built-in one. Every sampler and the renderer reach it through the same
compiled switch (:mod:`core.dispatch`, the ``FILE_MODEL`` branch; :mod:`core.model_files.call` says how), so
loading a model compiles the model and nothing else.

- ``.brdf`` (:mod:`core.model_files.shader`): the shader is translated by :mod:`core.glsl` into LLVM and
  compiled in milliseconds; the file is never executed as Python.
- ``.py`` (:mod:`core.model_files.python`): the file is run as a Python module and declares ``PARAMS`` and a
  numba-compilable ``eval`` (optionally ``sample`` and ``pdf``); see ``docs/model-files.md``. Running it runs
  its code: the app asks before it loads one a project names.

A loaded model is kept by path and content: loading the same text again returns the same model, and an edited
file (another content digest) is compiled anew, so a cache keyed by :meth:`core.brdf.BRDF.key` misses after
an edit. Traits (isotropic, reciprocal, mirror-symmetric) of a shader are measured at load
(:func:`core.model_files.probe.measured_traits`); the values a shader takes are probed for NaN, infinities and
negatives (:func:`core.model_files.probe.bad_values`), which the host takes as 0 and reports.
"""

from __future__ import annotations

import hashlib
import os
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from core.errors import FileFormatError

if TYPE_CHECKING:
    from core.brdf import Model

SUFFIXES = (".brdf", ".py")
"""File suffixes of model files (lower case)."""

MAX_FILE_BYTES = 4 * 1024 * 1024
"""The largest model file read (a shader or a Python model is a few kilobytes)."""


class ModelFileError(FileFormatError):
    """A model file that cannot be loaded: its message names the file and, where known, the line."""


@dataclass(frozen=True)
class ModelSource:
    """Where a file model comes from: enough to load it again in another process."""

    path: str
    """The file's absolute path when it was loaded."""
    text: str
    """Its text (a model travels by content: a process that cannot read the path still loads it)."""
    digest: str
    """SHA-256 of the text, hex."""
    findings: tuple[str, ...] = ()
    """What the load noticed without refusing the file (values taken as 0, and the like)."""
    keep: Any = field(default=None, compare=False, repr=False)
    """The compiled native functions, kept alive as long as the model."""


def is_model_file(name: str | os.PathLike[str]) -> bool:
    """Whether ``name`` names a model file (by its suffix) rather than a registered model."""
    return Path(str(name)).suffix.lower() in SUFFIXES


def read_text(path: str | os.PathLike[str]) -> str:
    """The text of a model file (``ModelFileError`` for a missing, unreadable, oversized or binary file)."""
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise ModelFileError(f"{path}: no such model file") from None
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read the model file ({exc.strerror})") from None
    if not p.is_file():
        raise ModelFileError(f"{path}: not a regular file")
    if st.st_size > MAX_FILE_BYTES:
        raise ModelFileError(f"{path}: {st.st_size} bytes is too large for a model file")
    try:
        data = p.read_bytes()[: MAX_FILE_BYTES + 1]
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read the model file ({exc.strerror})") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{path}: not a text file (byte {exc.start} is not UTF-8)") from None


_LOADED: dict[tuple[str, str], Model] = {}
_LOCK = threading.Lock()
_PINNED: dict[str, str] = {}


def pin_text(path: str | os.PathLike[str], text: str | None) -> None:
    """Load the model file ``path`` from ``text`` in this process from now on, whatever the file holds
    (``None``: from the file again).

    The desktop app pins the last version of a watched file that compiled: while the file holds a broken
    edit, every lookup of the path (a scene's checks, the renderer, the samplers) keeps that version; the
    app's render and sampler processes are sent the text and pin it too."""
    full = os.path.abspath(os.fspath(path))
    with _LOCK:
        if text is None:
            _PINNED.pop(full, None)
        else:
            _PINNED[full] = text


def pinned_text(path: str | os.PathLike[str]) -> str | None:
    """The text :func:`pin_text` fixed for ``path`` in this process, or ``None``."""
    return _PINNED.get(os.path.abspath(os.fspath(path)))


def load_model_file(path: str | os.PathLike[str], text: str | None = None) -> Model:
    """The model a ``.brdf`` or ``.py`` file declares, compiled (``ModelFileError`` naming the file and line).

    ``text`` is the file's content when it is already known (a model sent from another process); the path
    then only names it. Without it, the text :func:`pin_text` fixed for the path, else the file's."""
    from core.model_files import python, shader

    full = os.path.abspath(os.fspath(path))
    if text is None:
        text = _PINNED.get(full)
    if text is None:
        text = read_text(full)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
    key = (full, digest)
    with _LOCK:
        model = _LOADED.get(key)
        if model is None:
            suffix = Path(full).suffix.lower()
            if suffix == ".brdf":
                model = shader.load(full, text, digest)
            elif suffix == ".py":
                model = python.load(full, text, digest)
            else:
                raise ModelFileError(f"{path}: not a model file: expected one of {', '.join(SUFFIXES)}")
            _LOADED[key] = model
    return model


def loaded_from_source(path: str, text: str) -> Model:
    """:func:`load_model_file` with the text given (how a pickled file model loads again)."""
    return load_model_file(path, text)
