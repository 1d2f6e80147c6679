"""Layout in the real window: docks sized to their content on first open (every name in the scene tree
readable), the window's layout remembered (QSettings), renders filling their panes with zoom and pan synced,
the lit sphere centred and whole."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QRectF, Qt

from app.views.images import ImageView
from app.views.sphere import SphereView
from core.model import make_brdf

pytestmark = pytest.mark.gui


def _rgb(widget) -> np.ndarray:
    image = widget.grab().toImage().convertToFormat(widget.grab().toImage().Format.Format_RGB888)
    h, w = image.height(), image.width()
    return (
        np.frombuffer(image.constBits(), np.uint8)
        .reshape(h, image.bytesPerLine())[:, : 3 * w]
        .reshape(h, w, 3)
    )


def test_scene_tree_dock_shows_every_name_whole(window, qapp):
    from app.main_window import demo_scene_path

    window.open_project(demo_scene_path(), confirm=False, remember=False)
    window.size_docks_to_content()
    qapp.processEvents()
    tree = window.scene_tree
    metrics = tree.fontMetrics()
    for root in tree.roots.values():
        for i in range(root.childCount()):
            item = root.child(i)
            needed = metrics.horizontalAdvance(item.text(0)) + 2 * tree.indentation()
            # objects' names in the first column; the other rows span both
            room = tree.viewport().width() if item.isFirstColumnSpanned() else tree.columnWidth(0)
            assert room >= needed, item.text(0)  # no "polishe..."
    assert tree.columnWidth(0) <= tree.viewport().width()  # the names' column whole in view
    assert window.tree_dock.width() <= 0.3 * window.width() + 10  # and the dock takes no more than it needs


def test_layout_is_remembered(window, qapp):
    """Where the docks are and whether they show (dock widths depend on the screen: Xvfb's is small)."""
    right = Qt.DockWidgetArea.RightDockWidgetArea
    window.addDockWidget(right, window.tree_dock)  # the user moved the scene tree to the right ...
    window.material_dock.hide()  # ... and closed the material dock
    qapp.processEvents()
    window.save_layout()
    window.reset_layout()
    qapp.processEvents()
    assert window.dockWidgetArea(window.tree_dock) == Qt.DockWidgetArea.LeftDockWidgetArea
    assert window.material_dock.isVisible()
    assert window.restore_layout()
    qapp.processEvents()
    assert window.dockWidgetArea(window.tree_dock) == right and not window.material_dock.isVisible()
    window.reset_layout()  # as it was, for the tests that follow
    qapp.processEvents()
    assert window.material_dock.isVisible()


def test_render_images_fill_their_panes_and_follow_each_other(qtbot):
    a, b = ImageView(), ImageView()
    for v in (a, b):
        qtbot.addWidget(v)
        v.resize(400, 300)
        v.show()
    a.link(b)
    image = np.zeros((24, 32, 3), np.uint8)
    for v in (a, b):
        v.set_image(image)

    def shown(v: ImageView) -> QRectF:
        return v.mapFromScene(v.sceneRect()).boundingRect()

    for v in (a, b):  # 32x24 in a 400x300 pane: scaled up until it touches two sides
        r, port = shown(v), v.viewport().rect()
        assert abs(r.width() - port.width()) <= 3 or abs(r.height() - port.height()) <= 3
    a.resize(600, 300)
    qtbot.wait(50)
    r = shown(a)
    assert abs(r.height() - a.viewport().height()) <= 3  # refitted to the new pane
    a.zoom(2.0)  # the user zooms: no longer fitted, and the other view follows
    assert not a.fitted and not b.fitted
    assert b.transform().m11() == pytest.approx(a.transform().m11())
    a.fit()
    assert a.fitted and b.fitted


@pytest.mark.parametrize("size", [(300, 180), (180, 300), (257, 256)])
def test_lit_sphere_is_centred_and_whole(qtbot, size):
    view = SphereView()
    qtbot.addWidget(view)
    view.resize(*size)
    view.show()
    qtbot.waitExposed(view)
    view.show_material(make_brdf("lambert", {"kd": 0.8}), (0.0, 0.0, 1.0))  # lit head-on: a full disk
    view.light = (0.0, 0.0, 1.0)
    rgb = _rgb(view).astype(int)
    lit = rgb.sum(axis=2) > 3 * 40  # the disk, lit head-on (the background is ~30 grey)
    w, h = view.width(), view.height()
    xs = np.nonzero(lit[h // 2])[0]  # the disk's extent along the middle row, and the middle column
    ys = np.nonzero(lit[:, w // 2])[0]
    side = min(w, h)
    assert (xs.min() + xs.max()) / 2 == pytest.approx((w - 1) / 2, abs=2.0)  # centred
    assert (ys.min() + ys.max()) / 2 == pytest.approx((h - 1) / 2, abs=2.0)
    # whole: as wide and as tall as the widget's smaller side (a clipped disk would be shorter on one axis)
    assert xs.max() - xs.min() == pytest.approx(side, abs=6) and ys.max() - ys.min() == pytest.approx(
        side, abs=6
    )


@pytest.mark.parametrize("width", [1400, 1200])
def test_material_choosers_are_readable_in_a_narrow_window(window, qapp, width):
    """At the default width (1400) and at 1200 px: every chooser lies whole inside the tree (no horizontal
    scrolling), is at least :attr:`MaterialChooser.MIN_CHARS` characters wide, draws its name whole or elided
    at its end into its text field, and opens a list as wide as the longest name."""
    from app.main_window import demo_scene_path

    window.open_project(demo_scene_path(), confirm=False, remember=False)
    old = window.size()
    window.resize(width, 900)
    qapp.processEvents()
    window.size_docks_to_content()
    qapp.processEvents()
    tree = window.scene_tree
    fm = tree.fontMetrics()
    try:
        assert window.width() == width and tree.horizontalScrollBar().maximum() == 0
        port = tree.viewport().rect()
        whole = 0
        for obj, combo in tree.combos.items():
            geometry = combo.geometry()  # in the viewport's coordinates
            assert port.contains(geometry), (obj, geometry, port)  # not cut by the tree's edge
            assert geometry.left() >= tree.columnWidth(0) - 1  # beside the object's name
            text, field = combo.shown_text(), combo.text_rect()
            assert fm.horizontalAdvance(text) <= field.width()  # drawn inside the text field
            name = combo.currentText()
            if text == name:
                whole += 1
            else:  # elided at its end: the name's start is there to read
                assert text.endswith("\u2026") and name.startswith(text[:-1])
                assert len(text) - 1 >= min(len(name), 10), text
            assert combo.view().minimumWidth() >= fm.horizontalAdvance(name)
            assert combo.toolTip() == name
        assert (
            whole >= len(tree.combos) - 1
        )  # only the longest name ("red plastic (measured, ...)") may be elided
    finally:
        window.resize(old)
        qapp.processEvents()
        window.size_docks_to_content()
