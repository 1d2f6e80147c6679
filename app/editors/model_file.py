"""The panel of a material whose model comes from a file: which file, what is wrong with it now (the error
with its line, while the last version that compiled stays in use), and the notices of the version in use."""

from __future__ import annotations

import html

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from app.model_library import ModelFile

ERROR_COLOUR = "#c62828"
NOTICE_COLOUR = "#b26a00"


class ModelFilePanel(QWidget):
    """Shows one :class:`app.model_library.ModelFile` (:meth:`show_file`)."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.file_label = QLabel()
        self.file_label.setWordWrap(True)
        self.file_label.setStyleSheet("color: #555; font-size: 9pt")
        self.problem = QLabel()
        self.problem.setWordWrap(True)
        self.problem.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.problem.setStyleSheet(f"color: {ERROR_COLOUR}")
        self.notices = QLabel()
        self.notices.setWordWrap(True)
        self.notices.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.notices.setStyleSheet(f"color: {NOTICE_COLOUR}")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        for label in (self.file_label, self.problem, self.notices):
            layout.addWidget(label)
        self.shown_path: str | None = None

    def show_file(self, entry: ModelFile | None, path: str) -> None:
        """Show the file ``path`` (``entry``: the library's record of it, None when the app does not watch it)."""
        self.shown_path = path
        watched = (
            "saving it reloads the model" if entry is not None else "not watched: import it to reload it"
        )
        self.file_label.setText(f"From {path} ({watched})")
        problem = entry.problem if entry is not None else ""
        self.problem.setText(
            f"<b>Error:</b> {html.escape(problem)}<br>The last version that loaded stays in use."
            if problem
            else ""
        )
        self.problem.setVisible(bool(problem))
        notices = entry.notices if entry is not None else ()
        self.notices.setText("<br>".join(f"<b>Warning:</b> {html.escape(n)}" for n in notices))
        self.notices.setVisible(bool(notices))

    def problem_text(self) -> str:
        """The error shown, as plain text ("" when none)."""
        return self.problem.text() if self.problem.isVisibleTo(self) else ""

    def notice_text(self) -> str:
        return self.notices.text() if self.notices.isVisibleTo(self) else ""
