"""Layout in the real window: docks sized to their content on first open (every name in the scene tree
readable), the window's layout remembered (QSettings), renders filling their panes with zoom and pan synced,
the lit sphere centred and whole.

At the screen sizes of :data:`SCREENS` (the window as large as such a screen leaves it), with the demo scene:
no text of a widget is clipped, the docks need no horizontal scrolling, every text of the plots lies inside its
figure, the colour bar and the lobe inside the 3D view, the lit sphere whole, and the render panes filled."""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest
from PySide6.QtCore import QRectF, Qt
from PySide6.QtGui import QImage, QTextDocument
from PySide6.QtWidgets import QAbstractButton, QAbstractScrollArea, QGroupBox, QLabel, QWidget

from app.views.figure import FigureView, StatusLine
from app.views.images import ImageView
from app.views.sphere import SphereView
from core.brdf import make_brdf
from tests.app.meshes import write_obj

pytestmark = pytest.mark.gui

SCREENS = [(1366, 768), (1600, 1000), (1920, 1080)]
DESKTOP_PX = 70
"""What a desktop takes from a screen's height: a window manager's title bar and a panel."""
SETTLE_S = 120.0
"""How long the window may take to finish the background work an open or a resize starts."""
RENDER_S = 600.0
"""A first render compiles the renderer's kernels for the scene's model (minutes on a loaded machine)."""


def _rgb(widget) -> np.ndarray:
    """The widget as drawn, ``(h, w, 3)`` uint8 (a copy: the image's memory goes with it)."""
    image = widget.grab().toImage().convertToFormat(QImage.Format.Format_RGB888)
    h, w = image.height(), image.width()
    return (
        np.frombuffer(image.constBits(), np.uint8)
        .reshape(h, image.bytesPerLine())[:, : 3 * w]
        .reshape(h, w, 3)
        .copy()
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


# ---- the window at the sizes of common screens ------------------------------------------------------------
def _settle(window, qapp, timeout: float = SETTLE_S) -> None:
    """Process events until the background work (views, tables) is done and the layout has followed it."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        qapp.processEvents()
        if window.jobs_idle():
            break
        time.sleep(0.02)
    for _ in range(3):  # results posted at the end, then the relayouts they ask for
        qapp.processEvents()
        time.sleep(0.02)


@pytest.fixture(params=SCREENS, ids=lambda size: f"{size[0]}x{size[1]}")
def screen_window(request, window, qapp) -> Iterator:
    """The window with the demo scene, as large as a screen of the size given leaves it, its docks sized to
    their content as on a first open; back to its own size afterwards."""
    from app.main_window import demo_scene_path

    width, height = request.param
    window.open_project(demo_scene_path(), confirm=False, remember=False)
    old = window.size()
    window.resize(width, height - DESKTOP_PX)
    qapp.processEvents()
    window.size_docks_to_content()
    _settle(window, qapp)
    assert window.size().toTuple() == (width, height - DESKTOP_PX)
    yield window
    window.show_tab(0)
    window.document.select_item(None)
    window.resize(old)
    qapp.processEvents()
    window.size_docks_to_content()
    qapp.processEvents()


def _each_tab(window, qapp) -> Iterator[str]:
    for i in range(window.tabs.count()):
        window.show_tab(i)
        _settle(window, qapp)
        yield window.tabs.tabText(i)


def _pages(window, qapp) -> Iterator[str]:
    """The material dock's pages in turn: the material editor, then a light's, the camera's and the
    environment's."""
    doc = window.document
    yield "material"
    for kind in ("light", "camera", "environment"):
        doc.select_item(kind)
        _settle(window, qapp)
        yield kind
    doc.select_item(None)
    _settle(window, qapp)


def _text_height(widget: QWidget, text: str, width: int) -> float:
    doc = QTextDocument()
    doc.setDefaultFont(widget.font())
    doc.setDocumentMargin(0)
    doc.setHtml(text)
    doc.setTextWidth(width)
    return doc.size().height()


def clipped_texts(root: QWidget) -> list[str]:
    """The visible widgets under ``root`` whose text does not fit them: a label, a button (check boxes
    included) or a group box narrower than its text, a word-wrapped label or a status line lower than its
    wrapped text, and any of them cut by its parents' edges (a dock scrolled sideways)."""
    found = []
    for w in root.findChildren(QWidget):
        if not w.isVisible() or w.width() <= 0:
            continue
        if isinstance(w, QLabel) and w.text():
            if w.wordWrap():
                if w.heightForWidth(w.width()) > w.height():
                    found.append(
                        f"label {w.text()[:50]!r}: {w.height()} px high, needs {w.heightForWidth(w.width())}"
                    )
            elif w.sizeHint().width() > w.width() or w.sizeHint().height() > w.height():
                found.append(f"label {w.text()[:50]!r}: {w.size().toTuple()}, needs {w.sizeHint().toTuple()}")
        elif isinstance(w, QAbstractButton) and w.text():
            if w.sizeHint().width() > w.width():
                found.append(f"button {w.text()!r}: {w.width()} px wide, needs {w.sizeHint().width()}")
        elif isinstance(w, QGroupBox):
            if w.minimumSizeHint().width() > w.width():
                found.append(f"group {w.title()!r}: {w.width()} px wide, needs {w.minimumSizeHint().width()}")
        elif isinstance(w, StatusLine) and w.text():
            needed = _text_height(w, w.text(), w.width())
            if needed > w.height():
                found.append(f"status {w.text()[:50]!r}: {w.height()} px high, needs {needed:.0f}")
        else:
            continue
        seen = w.visibleRegion().boundingRect()
        if not seen.isEmpty() and seen.width() < w.width():  # cut at the side by a parent
            found.append(
                f"{type(w).__name__} {getattr(w, 'text', w.objectName)()!r}: {seen.width()} of {w.width()} px in view"
            )
    return found


def test_no_text_is_clipped(screen_window, qapp):
    """Every label, button, check box, group box title and status line of every tab and of every page of the
    material dock shows its whole text."""
    window = screen_window
    found = []
    for tab in _each_tab(window, qapp):
        found += [f"{tab} tab: {text}" for text in clipped_texts(window)]
    window.show_tab(0)
    for page in _pages(window, qapp):
        found += [f"{page} page: {text}" for text in clipped_texts(window.material_dock)]
    assert found == []


def test_docks_need_no_horizontal_scrolling(screen_window, qapp):
    window = screen_window
    for page in _pages(window, qapp):
        for dock in (window.tree_dock, window.material_dock):
            for area in dock.findChildren(QAbstractScrollArea):
                if area.isVisible():
                    bar = area.horizontalScrollBar()
                    assert not bar.isVisible() and bar.maximum() == 0, (page, dock.windowTitle(), type(area))


def test_plot_texts_lie_inside_their_figures(screen_window, qapp):
    """Titles (wrapped to the figure), tick labels, legends and texts of every plot of every tab, the error
    plot with curves in it too."""
    window = screen_window
    found = []
    curves = {
        name: [
            {"spp": 2**k, "seconds": 0.1 * 2**k, "rmse": 0.5 / 2**k, "relmse": 2.0 / 2**k} for k in range(8)
        ]
        for name in ("uniform", "adaptive_exact")
    }
    for tab in _each_tab(window, qapp):
        if window.tabs.currentWidget() is window.render_panel:
            window.render_view.error_plot.show_curves(curves)
        for view in window.findChildren(FigureView):
            if not view.isVisible():
                continue
            fig = view.figure
            view.canvas.draw()
            renderer = view.canvas.get_renderer()
            box = fig.bbox
            for artist in [*fig.axes, *fig.texts, *fig.legends]:
                if not artist.get_visible():
                    continue
                bb = (
                    artist.get_tightbbox(renderer)
                    if hasattr(artist, "get_tightbbox")
                    else artist.get_window_extent(renderer)
                )
                if bb is None:
                    continue
                if bb.x0 < box.x0 - 1 or bb.y0 < box.y0 - 1 or bb.x1 > box.x1 + 1 or bb.y1 > box.y1 + 1:
                    title = artist.get_title() if hasattr(artist, "get_title") else ""
                    found.append(f"{tab}: {type(view).__name__} {title!r} {bb.bounds} outside {box.bounds}")
    window.render_view.error_plot.show_curves(window.render_view.curves)
    assert found == []


def _lit_pixels_bbox(rgb: np.ndarray, background: int) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` of the pixels differing from a grey ``background`` (inclusive)."""
    differs = np.abs(rgb.astype(int) - background).max(axis=2) > 24
    ys, xs = np.nonzero(differs)
    return int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max())


def test_colour_bar_lobe_and_lit_sphere_lie_inside_their_views(screen_window, qapp):
    """The colour bar (title and labels) inside the 3D view; the lobe (a Lambertian floor's: a sphere) whole and
    beside the bar, its hemisphere centred in the room left of the bar; the lit sphere centred and whole."""
    window = screen_window
    window.show_tab(0)
    _settle(window, qapp)
    lobe = window.lobe_view
    plotter = lobe.plotter
    w, h = plotter.ren_win.GetSize()
    # the colour bar alone, rendered: its pixels keep off the view's edges
    props = plotter.renderer.GetViewProps()
    hidden = [props.GetItemAsObject(i) for i in range(props.GetNumberOfItems())]
    hidden = [p for p in hidden if p is not lobe.scalar_bar and p.GetVisibility()]
    for prop in hidden:
        prop.VisibilityOff()
    plotter.hide_axes()
    try:
        plotter.render()
        image = plotter.screenshot(None, return_img=True)
    finally:
        for prop in hidden:
            prop.VisibilityOn()
        plotter.show_axes()
        plotter.render()
    assert image.shape[:2] == (h, w)
    x0, y0, x1, y1 = _lit_pixels_bbox(image[:, :, :3], 255)
    assert x0 >= 1 and y0 >= 1 and x1 <= w - 2 and y1 <= h - 2, ((x0, y0, x1, y1), (w, h))
    # the lobe whole and left of the bar (normalized device coordinates, -1..1 across the view)
    bar_left = 2.0 * x0 / w - 1.0
    lx0, ly0, lx1, ly1 = lobe.projected_bounds(np.asarray(lobe.mesh.points))
    assert -1.0 < lx0 and lx1 < bar_left and -1.0 < ly0 and ly1 < 1.0, (lx0, ly0, lx1, ly1, bar_left)
    hx0, hy0, hx1, hy1 = lobe.projected_bounds(lobe.fit_points)
    assert (hx0 + hx1) / 2 == pytest.approx((-1.0 + bar_left) / 2, abs=0.05)
    assert (hy0 + hy1) / 2 == pytest.approx(0.0, abs=0.05)
    # the lit sphere: the disk of the widget's smaller side, centred
    sphere = window.sphere_view
    sphere.show_material(make_brdf("lambert", {"kd": 0.8}), (0.0, 0.0, 1.0))  # lit head-on: a full disk
    qapp.processEvents()
    x0, y0, x1, y1 = _lit_pixels_bbox(_rgb(sphere), 30)
    side = min(sphere.width(), sphere.height())
    assert (x1 - x0) == pytest.approx(side, abs=6) and (y1 - y0) == pytest.approx(side, abs=6)
    assert (x0 + x1) / 2 == pytest.approx((sphere.width() - 1) / 2, abs=2.0)
    assert (y0 + y1) / 2 == pytest.approx((sphere.height() - 1) / 2, abs=2.0)
    window.schedule("brdf")  # the sphere as the document has it again


@pytest.fixture(scope="module")
def rendered(window, qapp, tmp_path_factory):
    """The render panel after a small render of two strategies (a grey cube: quick to prepare)."""
    window.new_project()
    window.document.add_material("lambert", name="grey", params={"kd": 0.5})
    window.import_mesh(write_obj(tmp_path_factory.mktemp("render") / "cube.obj", {"a": (0, 0, 0)}))
    panel = window.render_view
    panel.width_box.setValue(64)
    panel.height_box.setValue(48)
    panel.spp.setValue(1)
    panel.mode.setCurrentIndex(panel.mode.findData("spp"))
    panel.strategy_a.setCurrentText("uniform")
    panel.strategy_b.setCurrentText("cosine")
    window.start_render()
    end = time.monotonic() + RENDER_S
    while panel.running and time.monotonic() < end:
        qapp.processEvents()
        time.sleep(0.02)
    assert not panel.running and set(panel.frames) == {"uniform", "cosine"}, panel.status_text
    return panel


def _shown(view: ImageView) -> QRectF:
    """Where the image is in the pane's viewport."""
    return view.mapFromScene(view.sceneRect()).boundingRect()


def test_render_panes_are_filled_follow_each_other_and_show_1_to_1(rendered, screen_window, qapp, qtbot):
    """Each image fills its pane (it touches two opposite sides, its aspect kept), the counters under them are
    whole; zoom and pan in one pane are the other's; key 1 shows the image 1:1 in both, F (or 0) fits both."""
    window, panel = screen_window, rendered
    window.show_tab(window.tabs.indexOf(window.render_panel))
    _settle(window, qapp)
    a, b = panel.view_a, panel.view_b
    for view in (a, b):
        assert view.fitted
        r, port = _shown(view), view.viewport().rect()
        assert abs(r.width() - port.width()) <= 2 or abs(r.height() - port.height()) <= 2, (r, port)
        assert r.width() / r.height() == pytest.approx(64 / 48, rel=0.02)
    assert clipped_texts(panel) == []  # the counters ("... RMSE: no reference") included
    assert "RMSE: no reference" in panel.counter_a.text()

    a.zoom(8.0)  # zoomed in past the pane: both panes follow, and pan together
    assert not a.fitted and not b.fitted
    assert b.transform().m11() == pytest.approx(a.transform().m11())
    a.horizontalScrollBar().setValue(a.horizontalScrollBar().maximum() // 3)
    a.verticalScrollBar().setValue(a.verticalScrollBar().maximum() // 2)
    assert a.horizontalScrollBar().value() > 0
    assert b.horizontalScrollBar().value() == a.horizontalScrollBar().value()
    assert b.verticalScrollBar().value() == a.verticalScrollBar().value()

    qtbot.keyClick(a, Qt.Key.Key_1)  # one image pixel on one screen pixel, in both panes
    for view in (a, b):
        assert _shown(view).width() == pytest.approx(64 / view.devicePixelRatioF(), abs=1)
    qtbot.keyClick(b, Qt.Key.Key_F)  # fitted again, both
    assert a.fitted and b.fitted
    assert _shown(a).width() > 64
    qtbot.keyClick(a, Qt.Key.Key_1)
    qtbot.keyClick(a, Qt.Key.Key_0)
    assert a.fitted and b.fitted
