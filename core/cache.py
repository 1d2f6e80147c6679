"""On-disk cache of precomputed sampling tables ("model only what a scene needs", and only once).

Entries live in ``$BRDF_STUDIO_CACHE`` or else ``~/.cache/brdf-studio``, one folder per table key and one
``.npz`` file per entry (e.g. per incident-angle bin). A key is the SHA-256 of everything the table depends
on: model name, the kernel parameter vector's bytes (so a measured BRDF's table data is covered too), the
sampler options and the code version. Each file carries a checksum of its arrays; a file that is truncated,
unreadable or whose checksum does not match is deleted and reported as missing, so the caller rebuilds it.
The cache is an optimization: when the default folder cannot be written, tables are not cached, silently.
A folder the user names (``$BRDF_STUDIO_CACHE``, a scene's ``sampler_options.cache``) must be one that can be
written: :func:`folder_problem` says why it cannot; a file or an unwritable place with one line (the command line
checks the variable before any command runs), rather than running without the cache the user asked for.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import io
import os
import tempfile
import zipfile
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from core.errors import OutputError
from core.io import atomic_write_bytes

ENV_VAR = "BRDF_STUDIO_CACHE"
_CHECKSUM = "__checksum__"


def folder_problem(folder: str | os.PathLike[str], create: bool = True) -> str | None:
    """Why ``folder`` cannot hold cache entries (``"is a file, not a folder"``, ``"cannot be written
    (Permission denied)"``), or None. ``create``: make it if missing (as the cache would); otherwise a
    missing folder is judged by the nearest folder above it that exists (checks that must not create it,
    such as a scene's validation)."""
    p = Path(folder).expanduser()
    try:
        if p.exists() and not p.is_dir():
            return "is a file, not a folder"
        if create:
            p.mkdir(parents=True, exist_ok=True)
        probe_in = p
        while not probe_in.exists():
            probe_in = probe_in.parent
        if not probe_in.is_dir():
            return f"cannot be made: '{probe_in}' is a file"
        fd, probe = tempfile.mkstemp(prefix=".probe-", dir=probe_in)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:  # (/proc says "No such file or directory": no reason is better than that one)
        return "cannot be written" + (
            f" ({exc.strerror})" if exc.strerror and exc.errno != errno.ENOENT else ""
        )
    return None


def check_environment() -> None:
    """``$BRDF_STUDIO_CACHE``, when set, names a folder that can be written (:class:`OutputError`
    otherwise, naming the variable)."""
    env = os.environ.get(ENV_VAR)
    if env:
        problem = folder_problem(env)
        if problem is not None:
            raise OutputError(
                f"{ENV_VAR}='{env}' {problem}; set it to a folder that can be written, or unset it"
            )


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
