"""The real desktop app (:func:`app.application.run_app`, what ``brdf-studio open`` runs), driven from outside
by ``tests/app/test_autosave_crash.py``, which kills it.

    python -m tests.app.autosave_app edit PROJECT REPORT
        opens PROJECT, edits it (a parameter and a new material, through the document as the editors do),
        writes REPORT (the pid and the edit) and keeps running, autosaving, until it is killed;
    python -m tests.app.autosave_app restore PROJECT REPORT
        launches on PROJECT as a user would (``restore="ask"``; the question is answered yes), writes REPORT
        (whether it was asked, the document it shows, its own autosave) and saves the project, then quits.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

EDIT = {"material": "ggx", "param": "alpha", "value": 0.4321, "added": "unsaved-work"}


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
        _write(report, {"pid": os.getpid(), "revision": doc.revision, "dirty": doc.dirty})

    def check_and_save(window) -> None:
        doc = window.document
        own = settings.autosave_path()
        _write(report, {
            "pid": os.getpid(),
            "asked": asked,
            "path": str(doc.path) if doc.path else None,
            "dirty": doc.dirty,
            "document": doc.to_dict(),
            "errors": window.errors,
            "own_autosave": settings.read_autosave(own)["document"] if own.exists() else None,
            "autosaves": sorted(p.name for p in settings.config_dir().glob("autosave-*.json")),
        })  # fmt: skip
        window.save_project()  # the user saves the restored work
        window.close()

    def shown(window) -> None:
        window.ask_unsaved = lambda: "discard"
        if phase == "edit":
            QTimer.singleShot(0, lambda: edit(window))
        else:
            window.ask_restore = lambda when: asked.append(when) or True
            QTimer.singleShot(0, lambda: check_and_save(window))

    return run_app(project, restore="ask", shown=shown)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])))
