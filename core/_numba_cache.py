"""Where numba keeps compiled functions on disk, and when a stored compile is stale.

numba checks a cached function against *its own* file only (a hash of its bytes). A model's ``eval`` cached
after an edit of a helper it calls in another file (``core/models/_fresnel.py``, ``core/geometry.py``) would
therefore be reused: the process would silently run the old code (GGX's cached ``eval`` would keep an edited
conductor Fresnel's old version). Keying the whole cache folder by a hash of every source file instead would
recompile everything after any edit (minutes on two cores).

Here each function's stored compile is stamped with a hash of its *import closure*: its own file and every
file of ``core`` and ``renderer`` that file imports, directly or through others (read from the import
statements a module runs when imported: jitted code cannot import inside a function). An edit invalidates exactly the compiles that can have seen it: editing
the adaptive sampler's ``draw.py`` leaves every model's kernels, the renderer's and the sampler's own
construction cached; editing ``_fresnel.py`` recompiles the models that import it and everything built on
them. The folder is ``$BRDF_STUDIO_NUMBA_CACHE`` (default ``~/.cache/brdf-studio/numba``); a stale entry is
overwritten in place by numba. A ``$BRDF_STUDIO_NUMBA_CACHE`` that names a file or a place that cannot be
written is refused by the command line before any command runs (:func:`check_environment`); a program that
imports the packages itself gets the default folder then, never the packages' own ``__pycache__``. Only when
no folder can be written is numba's default (next to the sources) left in place.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import sys
from functools import cache
from pathlib import Path

PACKAGES = ("core", "renderer")
ROOT = Path(__file__).resolve().parent.parent
"""The folder holding the packages."""

_configured: Path | None = None
ENV_VAR = "BRDF_STUDIO_NUMBA_CACHE"


def check_environment() -> None:
    """``$BRDF_STUDIO_NUMBA_CACHE``, when set, names a folder that can be written
    (:class:`~core.errors.OutputError` naming the variable otherwise)."""
    from core.cache import folder_problem

    env = os.environ.get(ENV_VAR)
    problem = folder_problem(env) if env else None
    if problem is not None:
        from core.errors import OutputError

        raise OutputError(f"{ENV_VAR}='{env}' {problem}; set it to a folder that can be written, or unset it")


def module_file(name: str, root: Path = ROOT) -> Path | None:
    """The source file of module ``name`` (``core.models.ggx``) under ``root``, or ``None``."""
    parts = name.split(".")
    if parts[0] not in PACKAGES:
        return None
    base = root.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _module_name(path: Path, root: Path) -> str:
    rel = path.relative_to(root).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


_IMPORT = re.compile(r"^(?:from\s+(\.*)([\w.]*)\s+import\s+(\(?[^#\n]*)|import\s+([^#\n]+))", re.MULTILINE)


@cache
def _imported_files_cached(path: Path, root: Path) -> frozenset[Path]:
    return frozenset(_imported_files(path, root))


def imported_files(path: Path, root: Path = ROOT) -> set[Path]:
    """The files of ``core``/``renderer`` that the source at ``path`` imports when it is imported (one
    step; the modules named, not their packages' ``__init__``, which only re-export). Each file is read
    once per process."""
    return set(_imported_files_cached(path, root))


def _imported_files(path: Path, root: Path = ROOT) -> set[Path]:
    """The import statements that start a line (the module's own, run when it is imported; the ones inside
    functions are indented, and jitted code cannot import): read with a regular expression, a hundred times
    faster than parsing the module (~25 ms a file), which every process stamping its compiles would pay."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return set()
    package = _module_name(path, root)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    out: set[Path] = set()

    def add(name: str) -> None:
        f = module_file(name, root)
        if f is not None:
            out.add(f)

    for m in _IMPORT.finditer(text):
        dots, module, names, plain = m.groups()
        if plain is not None:
            for item in plain.split(","):
                add(item.split(" as ")[0].strip())
            continue
        if dots:
            base = package.split(".")
            base = base[: len(base) - len(dots) + 1] if len(dots) > 1 else base
            mod = ".".join(base + ([module] if module else []))
        else:
            mod = module
        add(mod)
        if names.startswith("("):  # a parenthesized list may run over several lines
            end = text.find(")", m.start(3))
            names = text[m.start(3) + 1 : end if end >= 0 else len(text)]
        for item in names.replace("\n", ",").split(","):
            name = item.split(" as ")[0].strip().strip("()")
            if name.isidentifier():
                add(f"{mod}.{name}")  # "from core import merl" imports the module core.merl
    out.discard(path)
    return out


def import_closure(path: Path, root: Path = ROOT) -> list[Path]:
    """``path`` and every file of the packages it imports, transitively, sorted."""
    seen = {path}
    todo = [path]
    while todo:
        for f in imported_files(todo.pop(), root):
            if f not in seen:
                seen.add(f)
                todo.append(f)
    return sorted(seen)


@cache
def _file_hash(path: Path) -> bytes:
    return hashlib.sha256(path.read_bytes()).digest()


@cache
def closure_hash(path: str) -> bytes:
    """Hash of the import closure of the source file ``path`` and of the numba, NumPy and Python versions
    (read once per process: the sources of a running process do not change; each file is read and hashed
    once).
    A module's data file of the same name with the suffix ``.npz`` (``_he_series.npz``) counts as part of the
    module: its values are frozen into the compiled kernels that read them at import."""
    import numba
    import numpy

    h = hashlib.sha256()
    for f in import_closure(Path(path).resolve()):
        h.update(str(f.relative_to(ROOT)).encode() if f.is_relative_to(ROOT) else str(f).encode())
        h.update(_file_hash(f))
        data = f.with_suffix(".npz")
        if data.is_file():  # a module's data file (its tables, frozen into its kernels) is part of it
            h.update(_file_hash(data))
    h.update(numba.__version__.encode())
    h.update(numpy.__version__.encode())
    h.update(sys.version.encode())
    return h.digest()


def _inside(py_file: str) -> bool:
    try:
        rel = Path(py_file).resolve().relative_to(ROOT)
    except ValueError:
        return False
    return rel.parts[0] in PACKAGES


def relative_folder(py_file: str) -> Path:
    """The cache folder of the functions of ``py_file`` inside numba's cache folder: its folder's path
    under the packages' root (``core/sampling/adaptive``), the same for every copy of the sources."""
    return Path(py_file).resolve().parent.relative_to(ROOT)


def _install_locator() -> None:
    """Put a locator in front of numba's own: the user-provided folder, stamped by the import closure."""
    from numba.core import caching

    class ClosureLocator(caching.UserProvidedCacheLocator):
        """numba's locator for ``numba.config.CACHE_DIR``, whose source stamp is the import closure's hash
        instead of the function's own file's, and whose folder is named by the source's place in the
        packages (``core/models``) rather than by a hash of its absolute path: a compile stored by one copy
        of the sources serves every copy with the same bytes (another clone, an installed wheel)."""

        def __init__(self, py_func, py_file):  # type: ignore[no-untyped-def]
            super().__init__(py_func, py_file)
            self._cache_path = str(Path(caching.config.CACHE_DIR) / relative_folder(py_file))

        def get_source_stamp(self):  # type: ignore[no-untyped-def]
            return closure_hash(str(self._py_file))

        @classmethod
        def from_function(cls, py_func, py_file):  # type: ignore[no-untyped-def]
            if not _inside(py_file):
                return None
            return super().from_function(py_func, py_file)

    classes = caching.CacheImpl._locator_classes
    if not any(c.__name__ == "ClosureLocator" for c in classes):
        classes.insert(0, ClosureLocator)


def configure() -> Path | None:
    """Point numba's cache at our folder and stamp our functions by their import closure (once per
    process); returns the folder, or ``None`` when it cannot be written."""
    global _configured
    if _configured is not None:
        return _configured
    import numba

    from core.cache import folder_problem

    env = os.environ.get(ENV_VAR)
    candidates = ([Path(env)] if env else []) + [Path.home() / ".cache" / "brdf-studio" / "numba"]
    folder = next((f for f in candidates if folder_problem(f) is None), None)
    if folder is None:
        return None
    numba.config.CACHE_DIR = str(folder)
    _install_locator()
    seed(folder)
    _configured = folder
    return folder


PREBUILT = Path(__file__).resolve().parent / "_kernels"
"""Kernels compiled when the wheel was built (:mod:`core._wheel_kernels`; absent from a source checkout): a
numba cache folder laid out as :func:`relative_folder` lays out the user's, and its ``BUILD_ID``."""


def seed(folder: Path, prebuilt: Path = PREBUILT) -> int:
    """Copy the kernels compiled with the wheel (``prebuilt``) into the cache ``folder``, once per build
    (a ``.seeded-BUILD_ID`` file marks it done); returns the files copied. They are this installation's
    own sources' compiles, so they replace what the folder holds for the same functions. Each file is
    written under a temporary name and renamed, so a process loading meanwhile reads a whole file; numba
    checks every entry's stamp and machine when it loads it, and compiles what does not match (a wheel
    built on another CPU). A folder that cannot be written is left as it is."""
    try:
        build = (prebuilt / "BUILD_ID").read_text(encoding="utf-8").strip()
    except OSError:
        return 0
    marker = folder / f".seeded-{build}"
    if not build or marker.exists() or prebuilt.resolve() == folder.resolve():
        return 0
    copied = 0
    for src in prebuilt.rglob("*.nb[ic]"):
        dst = folder / src.relative_to(prebuilt)
        tmp = dst.with_name(f"{dst.name}.seed-{os.getpid()}")
        try:
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, tmp)
            os.replace(tmp, dst)
        except OSError:
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)
            return copied  # not marked: the next process tries again
        copied += 1
    with contextlib.suppress(OSError):
        marker.touch()
    return copied
