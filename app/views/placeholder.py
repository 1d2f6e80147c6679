"""A panel whose library part is not in this build yet: it says so plainly."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget


class UnavailablePanel(QWidget):
    def __init__(self, title: str, reason: str, parent: QWidget | None = None):
        super().__init__(parent)
        self.label = QLabel(f"<h3>{title}</h3><p>Not available yet: {reason}</p>")
        self.label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.label.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.addWidget(self.label)
