"""A table on disk: its cache key (the model's sources, its parameters and the options) and its atomic
storage (:mod:`core.cache`).
"""

from __future__ import annotations

import hashlib
import inspect
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from core.brdf import BRDF
from core.cache import TableCache, table_key
from core.sampling.adaptive.records import TABLE_FORMAT, AdaptiveTable, TableOptions, TableReport

# ------------------------------------------------------------------------------------------ storage
_SOURCES_HASH: dict[str, str] = {}


def source_files(brdf: BRDF) -> list[Path]:
    """The sources that can change a material's table: the model's own file (and, for a model that is a
    package of its own such as ``core/rgl``, the package's other files), the shared model helpers
    (``core/models/_*.py``, ``lobes.py``, ``core/geometry.py``), the dispatch switch and this package with its
    subpackages (the tree's steps). An edit anywhere else (the app, the renderer, another model) keeps the
    stored tables."""
    func = getattr(brdf.model.eval, "py_func", brdf.model.eval)
    own = Path(inspect.getfile(func)).resolve()
    core = Path(__file__).resolve().parents[2]
    files = sorted(f for f in Path(__file__).resolve().parent.rglob("*.py") if "__pycache__" not in f.parts)
    files += sorted((core / "models").glob("_*.py"))
    files += [core / "models" / "lobes.py", core / "geometry.py", core / "dispatch.py", core / "rng.py"]
    if own.parent != core / "models" and own.parent != core:
        # a model that is a package of its own (core/rgl): every file of it can change its values
        files += [f for f in sorted(own.parent.glob("*.py")) if f != own]
    if own not in files:
        files.append(own)
    return files


def sources_hash(brdf: BRDF) -> str:
    """Hash of :func:`source_files` (read once per process and model file)."""
    files = source_files(brdf)
    key = str(files[-1])
    if key not in _SOURCES_HASH:
        h = hashlib.sha256()
        for f in files:
            h.update(f.name.encode())
            h.update(f.read_bytes())
        _SOURCES_HASH[key] = h.hexdigest()[:20]
    return _SOURCES_HASH[key]


def table_cache_key(brdf: BRDF, options: TableOptions) -> str:
    return table_key(
        ["adaptive", TABLE_FORMAT, brdf.model.name, brdf.params, sorted(asdict(options).items()),
         sources_hash(brdf)]
    )  # fmt: skip


def save_table(cache: TableCache, key: str, table: AdaptiveTable, report: TableReport) -> bool:
    arrays: dict[str, Any] = {name: np.asarray(value) for name, value in table._asdict().items()}
    arrays["report"] = np.array([report.seconds, report.evaluations, report.rounds, report.acceptance_min,
                                 report.chi2_max_edge, report.norm_error_max])  # fmt: skip
    return cache.save(key, "table", arrays)


def load_table(cache: TableCache, key: str) -> tuple[AdaptiveTable, TableReport] | None:
    arrays = cache.load(key, "table")
    if arrays is None:
        return None
    try:
        rep = arrays.pop("report")
        fields = {}
        for name in AdaptiveTable._fields:
            value = arrays[name]
            fields[name] = value.item() if value.ndim == 0 else np.ascontiguousarray(value)
        fields["symmetry"] = int(fields["symmetry"])
        fields["flat"] = int(fields["flat"])
        fields["norm_log"] = int(fields["norm_log"])
        fields["exact"] = int(fields["exact"])
        fields["cos_min"] = float(fields["cos_min"])
        table = AdaptiveTable(**fields)
    except (KeyError, ValueError, TypeError):
        return None
    report = TableReport(
        seconds=float(rep[0]), evaluations=int(rep[1]), trees=len(table.root), leaves=len(table.corners),
        rounds=int(rep[2]), acceptance_min=float(rep[3]), chi2_max_edge=float(rep[4]),
        norm_error_max=float(rep[5]), from_cache=True,
    )  # fmt: skip
    return table, report


def memory_bytes(table: AdaptiveTable) -> int:
    return int(sum(v.nbytes for v in table if isinstance(v, np.ndarray)))
