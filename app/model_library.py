"""The model files the app has opened (File > Import model, a drop, a project's materials): for each, the
version in use and what is wrong with the file as it is now.

The version in use is the last text of the file that compiled, pinned in this process
(:func:`core.model_files.pin_text`): while the file holds a broken edit, every lookup of its path (the
document's checks, the views, a render's scene) keeps that version, and the file's problem
(``path:line: message``) is shown beside it. When the file is saved,
:class:`app.model_watcher.ModelFileWatcher` reads it (:meth:`ModelLibrary.new_text`) and compiles it in a
worker thread (:func:`compile_version`); a text that compiles becomes the version in use
(:meth:`ModelLibrary.adopt`) and :attr:`ModelLibrary.reloaded` fires. The app's render and sampler processes are sent
the texts in use (:func:`model_texts`), so they never load a file's later, broken or not yet reloaded text.

A ``.py`` file runs code when it loads: :meth:`ModelLibrary.allowed` asks the user before the app loads one
that a project names, once per content (the answer is kept in :mod:`app.settings`); a file the user imports
is theirs, and so is every later version of a file the app already runs (its reloads).

Plain Python, no Qt.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from app import settings
from app.evented import Event
from core.brdf import Model, ParamValue
from core.errors import BrdfStudioError
from core.model_files import (
    ModelFileError,
    is_model_file,
    load_model_file,
    pin_text,
    pinned_text,
    read_text,
)
from core.scene import Scene

FALLBACK_MODEL = "lambert"
"""The built-in model a material takes when its model file is not loaded (declined, missing, broken)."""


@dataclass
class ModelFile:
    """One model file the app has opened."""

    path: str
    """Its absolute path."""
    model: Model
    """The version in use: the last text of the file that compiled."""
    problem: str = ""
    """Why the file as it is now is not in use (``path:line: message``); empty when it is."""

    @property
    def notices(self) -> tuple[str, ...]:
        """What the version in use computes that a BRDF should not (NaN, infinite, negative values)."""
        source = self.model.source
        return source.findings if source is not None else ()


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _is_python(path: str | os.PathLike[str]) -> bool:
    return Path(path).suffix.lower() == ".py"


def fit_params(model: Model, values: Mapping[str, Any]) -> dict[str, ParamValue]:
    """``values`` for ``model``, complete: each value the model's parameter of that name accepts, its default
    for the others (a file's new version may rename, drop or narrow parameters)."""
    out = model.defaults()
    for p in model.params:
        if p.name in values:
            try:
                out[p.name] = p.validate(model.name, values[p.name])
            except BrdfStudioError:
                pass
    return out


def compile_version(path: str, text: str) -> Model:
    """The model of the text ``text`` of the file ``path`` (``BrdfStudioError`` naming the file and line).
    Safe in a worker thread: it holds numba's compiler lock, which every compilation in the process takes
    (a shader is compiled by LLVM too, whose shared state is not safe to use from two threads at once)."""
    from numba.core.compiler_lock import global_compiler_lock

    with global_compiler_lock:
        try:
            return load_model_file(path, text)
        except BrdfStudioError:
            raise
        except Exception as exc:  # a bug of the translator must not take the app down: the file's problem
            raise ModelFileError(
                f"{path}: cannot load the model file ({type(exc).__name__}: {exc})"
            ) from None


def model_texts(scene: Scene) -> dict[str, str]:
    """The texts in use of the model files ``scene``'s materials name (what another process must load)."""
    out = {}
    for mat in scene.materials:
        if mat.model is not None and is_model_file(mat.model):
            text = pinned_text(mat.model)
            if text is not None:
                out[mat.model] = text
    return out


class ModelLibrary:
    """The model files the app has opened, by absolute path. ``changed(path)`` fires when a file is opened
    or its problem appears or goes; ``reloaded(path)`` when a new version of it is in use."""

    def __init__(self) -> None:
        self.files: dict[str, ModelFile] = {}
        self.changed = Event()
        self.reloaded = Event()

    def get(self, path: str | os.PathLike[str]) -> ModelFile | None:
        return self.files.get(os.path.abspath(os.fspath(path)))

    def models(self) -> list[Model]:
        """The version in use of every file, in the order they were opened."""
        return [f.model for f in self.files.values()]

    def open(self, path: str | os.PathLike[str]) -> Model:
        """Load the file as it is now and make it the version in use (``ModelFileError`` naming the file
        and line; nothing changes then). Opening a ``.py`` file is running it: the answer is kept."""
        full = os.path.abspath(os.fspath(path))
        text = read_text(full)
        model = compile_version(full, text)
        if _is_python(full):
            settings.remember_model_file_answer(full, _digest(text), True)
        pin_text(full, text)
        entry = self.files.get(full)
        self.files[full] = ModelFile(full, model)
        self.changed.emit(full)
        if entry is not None and entry.model is not model:
            self.reloaded.emit(full)
        return model

    def reload(self, path: str | os.PathLike[str]) -> bool:
        """Read an opened file again and compile it here: a new text that compiles becomes the version in use
        (True); a text that does not (or a file that cannot be read) is the file's problem, and the version
        in use stays (False). The app compiles in a worker thread instead: :meth:`new_text`, then
        :func:`compile_version` there, then :meth:`adopt` or :meth:`refuse`."""
        full = os.path.abspath(os.fspath(path))
        text = self.new_text(full)
        if text is None:
            return False
        try:
            model = compile_version(full, text)
        except BrdfStudioError as exc:
            self.refuse(full, str(exc))
            return False
        return self.adopt(full, model)

    def new_text(self, path: str) -> str | None:
        """The text of the opened file ``path`` when it is not the version in use (None: the same text, the
        problem cleared; or the file cannot be read, which is its problem now)."""
        entry = self.files[path]
        try:
            text = read_text(path)
        except BrdfStudioError as exc:
            self._set_problem(entry, str(exc))
            return None
        if entry.model.source is not None and text == entry.model.source.text:
            self._set_problem(entry, "")  # back to the version in use (an edit undone)
            return None
        return text

    def adopt(self, path: str, model: Model) -> bool:
        """Make ``model`` (a version of the opened file ``path`` that compiled) the version in use."""
        entry = self.files.get(path)
        if entry is None or model.source is None or model.source.path != path:
            return False
        if _is_python(path):  # the user's own edit of a file the app runs
            settings.remember_model_file_answer(path, model.source.digest, True)
        pin_text(path, model.source.text)
        entry.model, entry.problem = model, ""
        self.changed.emit(path)
        self.reloaded.emit(path)
        return True

    def refuse(self, path: str, problem: str) -> None:
        """The file's current text does not compile: ``problem`` (``path:line: message``) is shown, the
        version in use stays."""
        entry = self.files.get(path)
        if entry is not None:
            self._set_problem(entry, problem if problem.startswith(path) else f"{path}: {problem}")

    def _set_problem(self, entry: ModelFile, problem: str) -> None:
        if problem != entry.problem:
            entry.problem = problem
            self.changed.emit(entry.path)

    def allowed(self, path: str | os.PathLike[str], ask: Callable[[str], bool]) -> bool:
        """Whether the app may load the model file ``path`` that a project names: always for a ``.brdf``
        (translated, never run) and for a file already open; for a ``.py``, the answer kept for its
        content, else ``ask(path)``'s (then kept). A file that cannot be read is allowed: loading it
        reports why."""
        full = os.path.abspath(os.fspath(path))
        if not _is_python(full) or full in self.files:
            return True
        try:
            digest = _digest(read_text(full))
        except BrdfStudioError:
            return True
        answer = settings.model_file_answer(full, digest)
        if answer is None:
            answer = bool(ask(full))
            settings.remember_model_file_answer(full, digest, answer)
        return answer
