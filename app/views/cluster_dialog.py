"""Where *Make reference* and long renders run: this machine, a local Dask cluster of N worker processes, or
a Dask scheduler's address (:class:`app.settings.ClusterSetting`, saved in the config folder)."""

from __future__ import annotations

from PySide6.QtWidgets import (
    QButtonGroup,
    QDialog,
    QDialogButtonBox,
    QGridLayout,
    QLabel,
    QLineEdit,
    QRadioButton,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)

from app.settings import ClusterSetting
from core.errors import BrdfStudioError


class ClusterDialog(QDialog):
    """Edits a :class:`ClusterSetting`; :meth:`setting` is the one chosen (after ``exec()`` returns
    ``Accepted``). An address of the wrong form keeps the dialog open and says what is expected."""

    def __init__(self, setting: ClusterSetting, parent: QWidget | None = None):
        super().__init__(parent)
        self.setWindowTitle("Render cluster")
        self.here = QRadioButton("This machine")
        self.local = QRadioButton("A local Dask cluster of")
        self.remote = QRadioButton("The Dask scheduler at")
        self.group = QButtonGroup(self)
        for b in (self.here, self.local, self.remote):
            self.group.addButton(b)
        self.workers = QSpinBox()
        self.workers.setRange(1, 256)
        self.workers.setValue(setting.workers)
        self.workers.setSuffix(" workers")
        self.address = QLineEdit(setting.address)
        self.address.setPlaceholderText("tcp://HOST:8786")
        {"local": self.local, "address": self.remote}.get(setting.kind, self.here).setChecked(True)
        self.problem = QLabel("")
        self.problem.setWordWrap(True)
        grid = QGridLayout()
        grid.addWidget(self.here, 0, 0)
        grid.addWidget(self.local, 1, 0)
        grid.addWidget(self.workers, 1, 1)
        grid.addWidget(self.remote, 2, 0)
        grid.addWidget(self.address, 2, 1)
        buttons = QDialogButtonBox(
            QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel
        )
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addWidget(QLabel("Make reference, and renders of many samples per pixel, run on:"))
        layout.addLayout(grid)
        layout.addWidget(self.problem)
        layout.addWidget(buttons)

    def setting(self) -> ClusterSetting:
        """The setting chosen (raises :class:`BrdfStudioError` for an address of the wrong form)."""
        from renderer.distributed import check_address

        if self.local.isChecked():
            return ClusterSetting("local", self.workers.value(), self.address.text().strip())
        if self.remote.isChecked():
            return ClusterSetting("address", self.workers.value(), check_address(self.address.text()))
        return ClusterSetting("none", self.workers.value(), self.address.text().strip())

    def accept(self) -> None:
        try:
            self.setting()
        except BrdfStudioError as exc:
            self.problem.setText(str(exc))
            return
        super().accept()
