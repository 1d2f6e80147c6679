"""Recent files and crash-recovery autosaves (plain files in the config folder)."""

from __future__ import annotations

import json
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


def test_autosave_whose_pid_was_reused_by_another_process_is_orphaned():
    """After a crash (or a reboot) the dead session's pid can belong to another process: the start time
    stored in the autosave tells them apart, so the edits are still offered."""
    other = os.getppid()  # a live process that is not this one
    assert settings.process_start(other) is not None  # Linux: /proc
    path = settings.write_autosave({"materials": []}, None)
    payload = settings.read_autosave(path)
    assert payload["session"] == settings.process_start(os.getpid())
    reused = settings.autosave_path(pid=other)
    payload["session"] = payload["session"].rsplit(":", 1)[0] + ":1"  # started at another time
    reused.write_text(json.dumps(payload))
    assert reused in settings.orphaned_autosaves()
    payload["session"] = settings.process_start(other)  # written by that very process: it is alive
    reused.write_text(json.dumps(payload))
    assert reused not in settings.orphaned_autosaves()
    reused.unlink()
    settings.clear_autosave()


def test_an_autosave_set_aside_is_kept_and_never_offered_again():
    dead = settings.autosave_path(pid=2**22 + 999)
    dead.write_text("{ truncated")
    assert dead in settings.orphaned_autosaves()
    kept = settings.set_aside(dead)
    assert kept.read_text() == "{ truncated" and not dead.exists()
    assert kept not in settings.orphaned_autosaves() and dead not in settings.orphaned_autosaves()
