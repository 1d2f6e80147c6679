"""On-disk cache of precomputed sampling tables ("model only what a scene needs", and only once).

Entries live in ``$BRDF_STUDIO_CACHE`` or else ``~/.cache/brdf-studio``, one folder per table key and one
``.npz`` file per entry (e.g. per incident-angle bin). A key is the SHA-256 of everything the table depends
on: model name, the kernel parameter vector's bytes (so a measured BRDF's table data is covered too), the
sampler options and the code version. Each file carries a checksum of its arrays; a file that is truncated,
unreadable or whose checksum does not match is deleted and reported as missing, so the caller rebuilds it.
The cache is an optimization: a folder that cannot be written is skipped silently.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import zipfile
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from core.errors import OutputError
from core.io import atomic_write_bytes

ENV_VAR = "BRDF_STUDIO_CACHE"
_CHECKSUM = "__checksum__"


def default_folder() -> Path:
    env = os.environ.get(ENV_VAR)
    if env:
        return Path(env)
    return Path.home() / ".cache" / "brdf-studio"


def table_key(parts: Iterable[object]) -> str:
    """A stable hex key from strings, numbers and numpy arrays (arrays hashed by dtype, shape and bytes)."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            a = np.ascontiguousarray(part)
            h.update(f"array:{a.dtype.str}:{a.shape}:".encode())
            h.update(a.tobytes())
        else:
            h.update(f"{type(part).__name__}:{part!r};".encode())
    return h.hexdigest()


def _checksum(arrays: Mapping[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}:{a.dtype.str}:{a.shape}:".encode())
        h.update(a.tobytes())
    return h.hexdigest()


class TableCache:
    """A folder of checksummed ``.npz`` entries grouped by table key."""

    def __init__(self, folder: str | os.PathLike[str] | None = None):
        self.folder = Path(folder) if folder is not None else default_folder()
        self.hits = 0
        self.misses = 0
        self.rejected = 0
        """Entries found stale or corrupt (and deleted)."""

    def path(self, key: str, name: str) -> Path:
        return self.folder / key[:32] / f"{name}.npz"

    def names(self, key: str) -> list[str]:
        """The names of the entries stored under ``key`` (not checked: :meth:`load` checks each)."""
        folder = self.folder / key[:32]
        try:
            return sorted(p.stem for p in folder.glob("*.npz"))
        except OSError:
            return []

    def load(self, key: str, name: str) -> dict[str, np.ndarray] | None:
        path = self.path(key, name)
        if not path.is_file():
            self.misses += 1
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: np.array(data[k]) for k in data.files}
            stored = str(arrays.pop(_CHECKSUM))
            if stored != _checksum(arrays):
                raise ValueError("checksum mismatch")
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
            self.rejected += 1
            self.misses += 1
            with contextlib.suppress(OSError):
                path.unlink()
            return None
        self.hits += 1
        return arrays

    def save(self, key: str, name: str, arrays: Mapping[str, np.ndarray]) -> bool:
        """Store an entry atomically; False (and nothing written) when the folder is not writable."""
        path = self.path(key, name)
        payload = {k: np.asarray(v) for k, v in arrays.items()}
        payload[_CHECKSUM] = np.asarray(_checksum(payload))
        buf = io.BytesIO()
        np.savez(buf, **payload)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(path, buf.getvalue(), durable=False)  # checksummed: a torn entry is rebuilt
        except (OSError, OutputError):  # a cache that cannot be written is not an error
            return False
        return True
