"""Recent files and crash-recovery autosaves (plain files in the config folder)."""

from __future__ import annotations

import os

from app import settings


def test_recent_files_newest_first_and_existing_only(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text("{}")
    b.write_text("{}")
    settings.add_recent(a)
    settings.add_recent(b)
    settings.add_recent(a)
    recent = settings.recent_files()
    assert recent[:2] == [a.resolve(), b.resolve()]
    b.unlink()
    assert b.resolve() not in settings.recent_files()


def test_autosave_of_a_dead_session_is_orphaned(tmp_path):
    path = settings.write_autosave({"materials": []}, None)
    assert path.exists() and path not in settings.orphaned_autosaves()  # this process is alive
    dead = settings.autosave_path(pid=2**22 + 12345)  # above Linux's default pid_max: never alive
    os.replace(path, dead)
    assert dead in settings.orphaned_autosaves()
    assert settings.read_autosave(dead)["document"] == {"materials": []}
    dead.unlink()
