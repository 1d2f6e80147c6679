"""The Explore tab: the current material's 3D lobe with the incident-direction editor, its polar slice, its
albedo curve and the lit sphere."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QGridLayout, QSplitter, QVBoxLayout, QWidget

from app.document import Document
from app.views.albedo import AlbedoView
from app.views.direction import DirectionEditor
from app.views.lobe import LobeView
from app.views.polar import PolarView
from app.views.sphere import SphereView


class ExplorePanel(QSplitter):
    def __init__(self, document: Document, parent: QWidget | None = None):
        super().__init__(Qt.Orientation.Horizontal, parent)
        self.lobe_view = LobeView()
        self.polar_view = PolarView()
        self.albedo_view = AlbedoView()
        self.sphere_view = SphereView()
        self.direction_editor = DirectionEditor(document)
        self.sphere_view.light_dragged.connect(lambda x, y, z: document.set_preview_light((x, y, z)))
        left = QWidget()
        lv = QVBoxLayout(left)
        lv.setContentsMargins(0, 0, 0, 0)
        lv.addWidget(self.lobe_view, 1)
        lv.addWidget(self.direction_editor)
        right = QWidget()
        grid = QGridLayout(right)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.addWidget(self.polar_view, 0, 0)
        grid.addWidget(self.albedo_view, 1, 0)
        grid.addWidget(self.sphere_view, 2, 0)
        self.addWidget(left)
        self.addWidget(right)
        self.setSizes([700, 360])
        self.setStretchFactor(0, 2)  # the lobe takes two thirds of any extra width, the plots one
        self.setStretchFactor(1, 1)
