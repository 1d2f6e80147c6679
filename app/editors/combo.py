"""A combo box that fits the width it is given: it asks for room for a few characters only and shows its
current text elided at its end when the text does not fit, with the whole text in its tooltip and a list as
wide as the longest item."""

from __future__ import annotations

from PySide6.QtCore import QRect, Qt
from PySide6.QtWidgets import QComboBox, QStyle, QStyleOptionComboBox, QStylePainter, QWidget


class ElidedComboBox(QComboBox):
    """Asks for room for ``min_chars`` characters; :meth:`fit_list` widens its list to the longest item."""

    def __init__(self, min_chars: int = 12, parent: QWidget | None = None):
        super().__init__(parent)
        self.min_chars = min_chars
        self.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.setMinimumContentsLength(min_chars)
        self.currentTextChanged.connect(self.setToolTip)

    def fit_list(self) -> None:
        """Open a list as wide as the longest item (call after the items change)."""
        longest = max((self.fontMetrics().horizontalAdvance(self.itemText(i)) for i in range(self.count())),
                      default=0)  # fmt: skip
        self.view().setMinimumWidth(
            longest + 2 * self.style().pixelMetric(QStyle.PixelMetric.PM_ScrollBarExtent)
        )

    def text_rect(self) -> QRect:
        """Where the current text is drawn (the style's edit field)."""
        opt = QStyleOptionComboBox()
        self.initStyleOption(opt)
        return self.style().subControlRect(
            QStyle.ComplexControl.CC_ComboBox, opt, QStyle.SubControl.SC_ComboBoxEditField, self
        )

    def shown_text(self) -> str:
        """The current text as drawn: whole, or elided at its end to the field's width."""
        return self.fontMetrics().elidedText(
            self.currentText(), Qt.TextElideMode.ElideRight, self.text_rect().width()
        )

    def width_for_all(self) -> int:
        """The width that shows the longest item whole."""
        fm = self.fontMetrics()
        chrome = self.sizeHint().width() - fm.horizontalAdvance("x") * self.min_chars
        return chrome + max((fm.horizontalAdvance(self.itemText(i)) for i in range(self.count())), default=0)

    def paintEvent(self, _event) -> None:  # noqa: N802 (Qt name)
        painter = QStylePainter(self)
        opt = QStyleOptionComboBox()
        self.initStyleOption(opt)
        painter.drawComplexControl(QStyle.ComplexControl.CC_ComboBox, opt)
        opt.currentText = self.shown_text()
        painter.drawControl(QStyle.ControlElement.CE_ComboBoxLabel, opt)
        painter.end()  # now, not when Python collects the painter
