"""Small file helpers: atomic writes so that a crash or a full disk never leaves a half-written file, and
bounded reads so that an input file is refused before it is allocated when it is a device (``/dev/zero`` never
ends) or larger than its kind of file can be."""

from __future__ import annotations

import contextlib
import csv
import io
import os
import stat
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

from core.errors import FileFormatError, OutputError


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike[str], mode: str = "wb", durable: bool = True) -> Iterator[IO]:
    """Open a temporary file beside ``path``; on success it replaces ``path`` in one step.

    ``durable``: the data reaches the disk before the replacement (``fsync``), so that after a power failure
    ``path`` holds the old content or the new, never an empty file. Caches whose entries carry a checksum
    pass ``False``: a torn entry is detected and rebuilt, and the ``fsync`` (2-20 ms) is saved.
    Raises :class:`OutputError` with a readable message when the folder is missing or not writable.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"cannot write '{target}': folder '{folder}' does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise OutputError(f"cannot write '{target}': {exc.strerror or exc}") from None
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
            fh.flush()
            if durable:
                os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, durable: bool = True) -> None:
    with atomic_write(path, "wb", durable) as fh:
        fh.write(data)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def write_csv_rows(path: str | os.PathLike[str], rows: Sequence[Mapping[str, Any]]) -> None:
    """Rows of dicts (the first row's keys as the header) to a CSV file, atomically: the benchmarks' tables."""
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def _kind_problem(mode: int) -> str | None:
    """Why a file of this ``st_mode`` cannot be an input, or None: a device or socket is not a file (a
    character device such as ``/dev/zero`` or ``/dev/urandom`` would be read forever)."""
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "is a device, not a file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a file"
    return None


def check_input_file(path: Path, where: str) -> None:
    """:class:`FileFormatError` naming ``where`` when ``path`` does not exist or is not a regular file."""
    if not path.exists():
        raise FileFormatError(f"{where} does not exist")
    if not path.is_file():
        raise FileFormatError(f"{where} is not a regular file")


def check_input_size(
    path: str | os.PathLike[str], limit: int, what: str, error: type[FileFormatError] = FileFormatError
) -> int:
    """The size of the input file at ``path`` (for readers that open it themselves); ``error`` naming
    ``what`` and the limit when it is a device, a folder or larger than ``limit`` bytes. ``OSError`` as
    :func:`os.stat` raises it (a missing file: callers say so in their own words)."""
    st = os.stat(path)
    problem = _kind_problem(st.st_mode)
    if problem is None and not stat.S_ISREG(st.st_mode):  # a pipe: the reader would not stop at the limit
        problem = "is not a regular file"
    if problem is not None:
        raise error(f"{what} '{path}' {problem}")
    if st.st_size > limit:
        raise error(_too_large(path, st.st_size, limit, what))
    return st.st_size


def read_bounded(
    path: str | os.PathLike[str], limit: int, what: str, error: type[FileFormatError] = FileFormatError
) -> bytes:
    """The content of the input file at ``path``, of at most ``limit`` bytes: a device, a folder or a larger
    file is ``error`` naming ``what`` before anything is allocated, and at most ``limit + 1`` bytes are ever
    read (a pipe, or a file that grows while it is read). ``OSError`` as :func:`open` raises it."""
    with open(path, "rb") as fh:
        st = os.fstat(fh.fileno())
        problem = _kind_problem(st.st_mode)
        if problem is not None:
            raise error(f"{what} '{path}' {problem}")
        if st.st_size > limit:
            raise error(_too_large(path, st.st_size, limit, what))
        data = fh.read(limit + 1)
    if len(data) > limit:
        raise error(_too_large(path, None, limit, what))
    return data


def _too_large(path: str | os.PathLike[str], size: int | None, limit: int, what: str) -> str:
    from core.budget import format_bytes

    most = f"{format_bytes(limit)} ({limit} bytes)"
    if size is None:  # a pipe, or a file that grew while it was read
        return f"{what} '{path}' is too large: more than {most}, the most that is read"
    return f"{what} '{path}' is too large: {format_bytes(size)} ({size} bytes); at most {most} is read"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
