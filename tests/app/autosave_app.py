"""The real desktop app (:func:`app.application.run_app`, what ``brdf-studio open`` runs), driven from outside
by ``tests/app/test_autosave_crash.py``, which kills it.

    python -m tests.app.autosave_app edit PROJECT REPORT
        opens PROJECT, edits it (a parameter and a new material, through the document as the editors do),
        writes REPORT (the pid and the edit) and keeps running, autosaving, until it is killed;
    python -m tests.app.autosave_app restore PROJECT REPORT
        launches on PROJECT as a user would (``restore="ask"``; the question is answered yes), saves the
        project and writes REPORT (whether it was asked, the document it showed, its own autosave before the
        save, the autosaves left after it), then keeps running until it is killed;
    python -m tests.app.autosave_app hold PROJECT REPORT
        opens PROJECT, edits it as ``edit`` does but stops the autosave timers, so that the edit is held in
        memory only, writes REPORT and keeps running until a signal ends it (``tests/app/test_app_signals.py``:
        the autosave the signal leaves behind is the signal handling's own);
    python -m tests.app.autosave_app saves PROJECT REPORT
        opens PROJECT and saves it over and over, each time with another value of the edited parameter
        (:func:`saved_value`), until it is killed; REPORT (the pid) is written after the first save.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

EDIT = {"material": "ggx", "param": "alpha", "value": 0.4321, "added": "unsaved-work"}


def saved_value(i: int) -> float:
    """The parameter's value in the ``i``-th save of the ``saves`` phase."""
    return round(0.1 + 0.001 * (i % 800), 6)


def _write(path: Path, data: dict) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data))
    os.replace(tmp, path)


def main(phase: str, project: Path, report: Path) -> int:
    from PySide6.QtCore import QTimer

    from app import settings
    from app.application import run_app

    asked: list[str] = []

    def edit(window) -> None:
        doc = window.document
        doc.set_param(EDIT["param"], EDIT["value"], material=EDIT["material"])
        doc.add_material("lambert", name=EDIT["added"], params={"kd": 0.25})
        if phase == "hold":
            window.files.autosave_soon.stop()
            window.autosave_timer.stop()
        _write(report, {"pid": os.getpid(), "revision": doc.revision, "dirty": doc.dirty})

    def check_and_save(window) -> None:
        doc = window.document
        own = settings.autosave_path()
        seen = {
            "pid": os.getpid(),
            "asked": asked,
            "path": str(doc.path) if doc.path else None,
            "dirty": doc.dirty,
            "document": doc.to_dict(),
            "errors": list(window.errors),
            "own_autosave": settings.read_autosave(own)["document"] if own.exists() else None,
            "autosaves": sorted(p.name for p in settings.config_dir().glob("autosave-*.json")),
        }
        saved = window.save_project()  # the user saves the restored work
        seen["saved"] = saved and not doc.dirty
        seen["autosaves_after_save"] = sorted(p.name for p in settings.config_dir().glob("autosave-*.json"))
        _write(report, seen)

    saves = [0]

    def save_again(window) -> None:
        window.document.set_param(EDIT["param"], saved_value(saves[0]), material=EDIT["material"])
        assert window.save_project()
        saves[0] += 1
        if saves[0] == 1:
            _write(report, {"pid": os.getpid()})

    def shown(window) -> None:
        window.ask_unsaved = lambda: "discard"
        if phase == "saves":
            timer = QTimer(window)
            timer.timeout.connect(lambda: save_again(window))
            timer.start(0)
        elif phase in ("edit", "hold"):
            QTimer.singleShot(0, lambda: edit(window))
        else:
            window.ask_restore = lambda when: asked.append(when) or True
            QTimer.singleShot(0, lambda: check_and_save(window))

    return run_app(project, restore="ask", shown=shown)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])))
