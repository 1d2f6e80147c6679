"""Atomic writes: the target is replaced whole or not at all, with ordinary permissions."""

from __future__ import annotations

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
