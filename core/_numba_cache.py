"""Where numba keeps compiled functions on disk: a folder per version of the source tree.

numba checks a cached function against the modification time of *its own* file only. A model's ``eval``
cached in ``core/models/__pycache__`` is therefore reused after an edit of a helper it calls in another file
(``core/models/_fresnel.py``, ``core/geometry.py``): the process silently runs the old code. Seen on
2026-11-22: after a faster conductor Fresnel, GGX's ``eval`` still ran the old one (191 ns a call against
105 ns once its cache was cleared).

So every ``cache=True`` function of the distribution is cached under a folder named by a hash of all its
Python sources (``core``, ``renderer``: the packages with compiled code) and of the numba and Python
versions: any edit starts a new folder, and a stale compile can never be loaded. The folder lives in
``$BRDF_STUDIO_NUMBA_CACHE`` (default ``~/.cache/brdf-studio/numba``); the four most recently used versions
are kept. If the folder cannot be written, numba's default (next to the sources) is left in place.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from functools import lru_cache
from pathlib import Path

PACKAGES = ("core", "renderer")
KEEP = 4

_configured: Path | None = None


@lru_cache(maxsize=1)
def source_hash() -> str:
    """:func:`tree_hash` of this installation, read once per process. Also the key of whatever else is derived
    from the code: the generated kernel modules (:mod:`core.specialize`) and the adaptive sampler's stored
    trees (:mod:`core.quadtree_table`: a model's ``eval`` or a helper it calls changes them)."""
    return tree_hash(Path(__file__).resolve().parent.parent)


def tree_hash(root: Path) -> str:
    """Hash of every ``.py`` file of the distribution's packages under ``root`` (the folder holding ``core``)
    and of the numba and Python versions."""
    import numba

    h = hashlib.sha256()
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            h.update(str(path.relative_to(root)).encode())
            h.update(path.read_bytes())
    h.update(numba.__version__.encode())
    h.update(sys.version.encode())
    return h.hexdigest()[:20]


def configure() -> Path | None:
    """Point numba's cache at this source version's folder (once per process); returns it, or ``None`` when
    it cannot be written."""
    global _configured
    if _configured is not None:
        return _configured
    import numba

    env = os.environ.get("BRDF_STUDIO_NUMBA_CACHE")
    base = Path(env) if env else Path.home() / ".cache" / "brdf-studio" / "numba"
    folder = base / source_hash()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)  # marks it as recently used, for the pruning below
    except OSError:
        return None
    numba.config.CACHE_DIR = str(folder)
    _configured = folder
    _prune(base, folder)
    return folder


def _prune(base: Path, current: Path) -> None:
    """Remove all but the ``KEEP`` most recently used version folders (never the current one)."""
    try:
        others = [p for p in base.iterdir() if p.is_dir() and p != current]
        others.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in others[KEEP - 1 :]:
        shutil.rmtree(old, ignore_errors=True)
