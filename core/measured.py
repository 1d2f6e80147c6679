"""Measured BRDF files, by suffix: the one place that knows every format (as trimesh's exchange keeps a dict of
loaders). MERL ``.binary`` (:mod:`core.merl`) and RGL ``.bsdf`` (:mod:`core.rgl.material`); each reader gives a
:class:`core.brdf.BRDF` whose kernels the dispatch reaches like an analytic model's, and each writer exports
any BRDF into its format.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from core.brdf import BRDF, Model
from core.errors import FileFormatError


class FileBRDF(BRDF):
    """A BRDF backed by a table read from a measured file (the base of every format's BRDF): the table, and
    ``path``, where it came from (``None`` for an in-memory table)."""

    def __init__(self, model: Model, params: np.ndarray, table: Any, path: str | None = None):
        super().__init__(model, {}, params=params)
        self.table = table
        self.path = path

    def key(self) -> str:
        """The model and the file with its size and modification time (so that a cache keyed by it misses
        after the file changes); an in-memory table is keyed by its identity."""
        if self.path is None:
            return f"{self.model.name}(<memory:{id(self.table):x}>)"
        try:
            st = os.stat(self.path)
            stamp = f"{st.st_size}:{st.st_mtime_ns}"
        except OSError:
            stamp = "?"
        return f"{self.model.name}({os.path.abspath(self.path)}@{stamp})"

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.path!r})"


class MeasuredFormat(NamedTuple):
    """A file format of measured BRDFs."""

    label: str
    load: Callable[[str], BRDF]
    write: Callable[[str, BRDF], object]


def _merl_load(path: str) -> BRDF:
    from core.merl import measured_brdf

    return measured_brdf(path)


def _merl_write(path: str, brdf: BRDF) -> None:
    from core.merl import write_merl

    write_merl(path, brdf)


def _rgl_load(path: str) -> BRDF:
    from core.rgl.material import rgl_brdf

    return rgl_brdf(path)


def _rgl_write(path: str, brdf: BRDF) -> object:
    from core.rgl.material import write_bsdf

    return write_bsdf(path, brdf)


FORMATS: dict[str, MeasuredFormat] = {
    ".binary": MeasuredFormat("MERL", _merl_load, _merl_write),
    ".bsdf": MeasuredFormat("RGL", _rgl_load, _rgl_write),
}
"""Every measured format by its file suffix (lower case)."""

SUFFIXES = tuple(FORMATS)


def format_of(path: str | os.PathLike[str]) -> MeasuredFormat:
    """The format of a measured file by its suffix (``FileFormatError`` naming the known ones)."""
    suffix = Path(path).suffix.lower()
    try:
        return FORMATS[suffix]
    except KeyError:
        known = ", ".join(f"{s} ({f.label})" for s, f in FORMATS.items())
        raise FileFormatError(f"'{path}' is not a measured BRDF file: expected one of {known}") from None


def is_measured_file(path: str | os.PathLike[str]) -> bool:
    return Path(path).suffix.lower() in FORMATS


def load_measured(path: str | os.PathLike[str]) -> BRDF:
    """A BRDF from a measured file of any known format (errors as the format's reader)."""
    return format_of(path).load(str(path))


def write_measured(path: str | os.PathLike[str], brdf: BRDF) -> None:
    """Export ``brdf`` to the format its suffix names, atomically."""
    format_of(path).write(str(path), brdf)


def measured_label(path: str | os.PathLike[str]) -> str:
    """A short name of a measured file for tables: ``merl:NAME`` or ``rgl:NAME``."""
    return f"{format_of(path).label.lower()}:{Path(path).stem}"
