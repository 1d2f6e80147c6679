"""Atomic writes: the target is replaced whole or not at all, with ordinary permissions."""

from __future__ import annotations

import contextlib
import os
import stat

import pytest

from core.errors import OutputError
from core.io import atomic_write, atomic_write_text, write_csv_rows


def test_replaces_whole_file_with_umask_permissions(tmp_path):
    path = tmp_path / "out.txt"
    atomic_write_text(path, "first")
    atomic_write_text(path, "second")
    assert path.read_text() == "second"
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~mask
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_a_failure_midway_keeps_the_old_file(tmp_path):
    path = tmp_path / "keep.txt"
    atomic_write_text(path, "precious")
    with pytest.raises(RuntimeError), atomic_write(path, "w") as fh:
        fh.write("half")
        raise RuntimeError("disk full")
    assert path.read_text() == "precious"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_missing_folder_is_a_clear_error(tmp_path):
    with pytest.raises(OutputError, match="does not exist"):
        atomic_write_text(tmp_path / "nope" / "x.txt", "x")


def test_user_files_are_synced_and_cache_entries_are_not(tmp_path, monkeypatch):
    """A user's file reaches the disk before it replaces the old one (``fsync``); a cache entry, checksummed
    and rebuilt when torn, skips the ``fsync`` and is still replaced whole."""
    import numpy as np

    from core.cache import TableCache
    from core.io import atomic_write_bytes

    synced = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (synced.append(fd), real(fd)))
    atomic_write_bytes(tmp_path / "project.json", b"{}")
    assert len(synced) == 1
    cache = TableCache(tmp_path / "cache")
    assert cache.save("k", "bin0", {"a": np.arange(3.0)})
    assert len(synced) == 1
    np.testing.assert_array_equal(cache.load("k", "bin0")["a"], np.arange(3.0))


def test_csv_rows_are_written_whole_with_the_first_rows_keys_as_header(tmp_path):
    path = tmp_path / "table.csv"
    path.write_text("old contents\n")
    write_csv_rows(path, [{"a": 1, "b": 0.5}, {"a": 2, "b": "x"}])
    assert path.read_text().splitlines() == ["a,b", "1,0.5", "2,x"]
    assert [p.name for p in tmp_path.iterdir()] == ["table.csv"]  # no temporary file left beside it
    write_csv_rows(path, [])
    assert path.read_text() == ""


def test_bounded_reads_refuse_devices_folders_and_large_files_before_reading(tmp_path):
    from core.errors import FileFormatError
    from core.io import check_input_size, read_bounded

    small = tmp_path / "small.json"
    small.write_bytes(b"x" * 100)
    assert read_bounded(small, 100, "scene file") == b"x" * 100
    assert check_input_size(small, 100, "mesh file") == 100
    sparse = tmp_path / "sparse.bsdf"
    with open(sparse, "wb") as fh:
        fh.truncate(1 << 40)  # a terabyte that takes no disk: only its size may be read
    for check in (read_bounded, check_input_size):
        with pytest.raises(
            FileFormatError, match=r"'.*small.json' is too large: 100 B \(100 bytes\); at most 99"
        ):
            check(small, 99, "scene file")
        with pytest.raises(FileFormatError, match=r"is too large: 1 TiB .* at most 1 MiB \(1048576 bytes\)"):
            check(sparse, 1 << 20, "RGL .bsdf file")
        with pytest.raises(FileFormatError, match="scene file '/dev/zero' is a device, not a file"):
            check("/dev/zero", 1 << 20, "scene file")
    with pytest.raises(FileFormatError, match="is a folder, not a file"):
        check_input_size(tmp_path, 1 << 20, "mesh file")
    with pytest.raises(IsADirectoryError):  # as open() says it: the scene's reader words it
        read_bounded(tmp_path, 1 << 20, "scene file")


def test_a_bounded_read_of_an_endless_pipe_stops_at_the_limit(tmp_path):
    import threading

    from core.errors import FileFormatError
    from core.io import check_input_size, read_bounded

    fifo = tmp_path / "endless.json"
    os.mkfifo(fifo)

    def write() -> None:
        with contextlib.suppress(BrokenPipeError), open(fifo, "wb") as fh:
            for _ in range(1000):  # 64 MiB at most, far beyond the limit
                fh.write(b"x" * 65536)

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    with pytest.raises(FileFormatError, match=r"is too large: more than 1 MiB \(1048576 bytes\)"):
        read_bounded(fifo, 1 << 20, "scene file")
    writer.join(10)
    with pytest.raises(FileFormatError, match="is not a regular file"):
        check_input_size(fifo, 1 << 20, "mesh file")  # a reader that opens it by name would not stop
