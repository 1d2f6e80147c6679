"""The sampler view in the real window: the tree follows parameter, direction, n_max and mode edits.

Lambert and Phong: cheap tables; Lambert's I(wo) = kd whatever the disk.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.sampling_data import SAMPLING_PROJECTIONS

pytestmark = [pytest.mark.gui]

COMPILE_TIMEOUT_MS = 240_000


def _wait_snapshot(window, qtbot, predicate, timeout=COMPILE_TIMEOUT_MS):
    window.refresh_now()
    qtbot.waitUntil(
        lambda: (
            window.jobs_idle("sampling")
            and window.sampling_view.snapshot is not None
            and window.sampling_view.snapshot.table.get(
                "complete", True
            )  # not a coarse table's first picture
            and predicate(window.sampling_view.snapshot)
        ),
        timeout=timeout,
    )
    return window.sampling_view.snapshot


def _drawn_outlines(view) -> int:
    """Leaves outlined: the outlines are one polyline, each leaf's closed and followed by a NaN break."""
    (path,) = view.leaf_edges.get_paths()
    return int(np.sum(np.isnan(path.vertices[:, 0])))


def _use(window, model: str, name: str, params: dict) -> None:
    doc = window.document
    if name not in doc.material_names():
        doc.add_material(model, name=name, params=params)
    doc.select_material(name)


def test_tree_follows_parameter_and_direction(window, qtbot, tmp_path):
    _use(window, "lambert", "lam", {"kd": 0.5})
    window.document.set_param("kd", 0.5)
    window.document.set_direction(30.0, 0.0)
    window.tabs.setCurrentWidget(window.sampling_panel)
    view = window.sampling_view
    snap = _wait_snapshot(window, qtbot, lambda s: s.theta_deg == 30.0 and s.tree.normalizer > 0.4)
    tree = snap.tree
    assert tree.cell_deg[0] <= 30.0 <= tree.cell_deg[1]
    # Lambert: I(wo) = int f cos dw = kd, whatever the disk projection.
    assert tree.normalizer == pytest.approx(0.5, rel=1e-6)
    assert 1.0 / snap.n_max <= snap.acceptance <= 1.0
    if snap.ratio_sampler == "adaptive_exact":
        assert np.nanmax(np.abs(np.log2(snap.ratio))) < 1e-6
    # what is drawn: every leaf outlined, the samples, the title naming the disk and the node
    assert _drawn_outlines(view) == len(tree.boxes)
    assert len(view._samples.get_offsets()) == len(snap.samples) > 0
    title = view.tree_caption.text()
    assert SAMPLING_PROJECTIONS[tree.projection] in title and f"{tree.node_deg[0]:.1f}" in title
    assert view._tree_img.get_visible() and view._tree_img.get_array().shape[:2] == (192, 192)

    # a parameter edit: I scales with kd; the tree (of the normalized lobe) is the same
    window.document.set_param("kd", 0.25)
    new = _wait_snapshot(window, qtbot, lambda s: s.tree.normalizer < 0.4)
    assert new.tree.normalizer == pytest.approx(0.25, rel=1e-6)
    np.testing.assert_array_equal(new.tree.boxes, tree.boxes)
    np.testing.assert_allclose(new.tree.density, tree.density, rtol=1e-6)

    # another direction: the tree of another node, whose cell holds it; the new title is shown with no full
    # draw of the figure
    full = view.figure_view.full_draws
    window.document.set_direction(60.0, 0.0)
    far = _wait_snapshot(window, qtbot, lambda s: s.theta_deg == 60.0)
    assert far.tree.cell_deg[0] <= 60.0 <= far.tree.cell_deg[1]
    assert far.tree.tree != tree.tree
    assert f"{far.tree.node_deg[0]:.1f}" in view.tree_caption.text()
    assert view.figure_view.full_draws == full
    # an export puts the panes' titles (labels on screen) into the figure, and takes them out again
    seen = []
    export = view.figure_view.export
    view.figure_view.export = lambda path: (seen.append(view.ax_tree.get_title()), export(path))[1]
    try:
        assert view.export(tmp_path / "tree.png").stat().st_size > 0
    finally:
        view.figure_view.export = export
    assert seen == [view.tree_caption.text()] and view.ax_tree.get_title() == ""
    # the titles sit right above their panes: the figure is no taller than its two square panes need
    fig = view.figure_view
    assert fig.height() <= view.ASPECT * fig.width() + fig.status.sizeHint().height() + 1
    assert 0 <= fig.y() - (view.tree_caption.y() + view.tree_caption.height()) <= 12
    window.tabs.setCurrentIndex(0)


def test_view_follows_n_max_and_mode(window, qtbot):
    """A new n_max makes (or loads) the table of that n_max, and the view shows it; the mode selector
    switches the samples to the rejection-free mode (one trial each) and the colours to its density."""
    _use(window, "phong", "ph", {"n": 40.0})
    window.document.set_direction(35.0, 0.0)
    window.tabs.setCurrentWidget(window.sampling_panel)
    view = window.sampling_view
    view.n_max.setValue(2.0)
    snap = _wait_snapshot(
        window, qtbot, lambda s: s.theta_deg == 35.0 and s.n_max == 2.0 and s.mode == "exact"
    )
    assert snap.table["options"]["n_max"] == 2.0
    assert "1/n_max = 0.500" in view.stats.text()
    before = np.asarray(view._tree_img.get_array()).copy()

    view.n_max.setValue(1.2)
    fine = _wait_snapshot(window, qtbot, lambda s: s.n_max == pytest.approx(1.2))
    assert fine.table["options"]["n_max"] == pytest.approx(1.2)
    assert fine.acceptance >= 1.0 / 1.2
    assert "1/n_max = 0.833" in view.stats.text()
    assert view.snapshot is fine

    view.mode.setCurrentText("warp")
    view.mode.activated.emit(view.mode.currentIndex())
    warp = _wait_snapshot(window, qtbot, lambda s: s.mode == "warp")
    assert warp.mean_trials == 1.0
    assert not np.array_equal(warp.samples, fine.samples)
    assert np.array_equal(view._samples.get_offsets(), warp.samples)
    # the colours: the rejection-free density q instead of the exact mode's density of trials
    assert not np.array_equal(np.asarray(view._tree_img.get_array()), before)
    assert "warp mode" in view.stats.text()
    view.mode.setCurrentText("exact")
    view.mode.activated.emit(view.mode.currentIndex())
    view.n_max.setValue(2.0)
    _wait_snapshot(window, qtbot, lambda s: s.mode == "exact" and s.n_max == 2.0)
    window.tabs.setCurrentIndex(0)


def test_ratio_map_of_the_cosine_sampler_is_one_for_lambert(window, qtbot):
    from app.sampling_data import adaptive_sampler
    from core.sampling.adaptive.inspect import from_tree_disk

    _use(window, "lambert", "lam", {"kd": 0.5})
    window.tabs.setCurrentWidget(window.sampling_panel)
    view = window.sampling_view
    view.strategy.setCurrentText("uniform")
    view.strategy.activated.emit(view.strategy.currentIndex())
    snap = _wait_snapshot(window, qtbot, lambda s: s.ratio_sampler == "uniform")
    assert "uniform" in view.ratio_caption.text()
    # uniform pdf 1/(2 pi) against the ideal cos/pi: the ratio is 1 / (2 cos theta), 1/2 at the centre
    t, p = np.radians(snap.theta_deg), np.radians(snap.phi_deg)
    wo = np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])
    sampler = adaptive_sampler(window.document.brdf())
    r = snap.ratio
    n = r.shape[0]
    for i, j in ((n // 2, n // 2), (n // 2, n // 8), (n // 5, n // 3)):
        xy = (np.array([[j, i]]) + 0.5) / n * 2.0 - 1.0
        wi = from_tree_disk(sampler, wo, xy)[0]
        # (the ideal uses the table's normalizer I, exact to ~1e-8)
        assert r[i, j] == pytest.approx(0.5 / wi[2], rel=1e-6)
    view.strategy.setCurrentText("cosine")
    view.strategy.activated.emit(view.strategy.currentIndex())
    snap = _wait_snapshot(window, qtbot, lambda s: s.ratio_sampler == "cosine")
    assert np.nanmax(np.abs(snap.ratio - 1.0)) < 1e-6
    assert snap.weight_rel_std < 1e-9
    view.strategy.setCurrentText("adaptive_exact")
    view.strategy.activated.emit(view.strategy.currentIndex())
    window.tabs.setCurrentIndex(0)


def test_outlines_of_deep_leaves_are_their_ancestors_and_still_tile_the_square():
    """Leaves deeper than OUTLINE_LEVEL are outlined as their ancestor at that level: what is outlined is
    still a tiling of the square (areas sum to 1, no overlaps), with nothing deeper than that level; one
    polyline holds every outline, each closed and followed by a break."""
    from app.sampling_data import OUTLINE_LEVEL, leaf_edges, outline_boxes
    from core.sampling.adaptive.inspect import TreeView

    rng = np.random.default_rng(2)
    boxes = [(0.0, 0.0, 1.0, 1.0)]
    lobe = np.array([0.3, 0.7])
    for k in range(400):  # every other split at the "lobe" (down to level 10), the others anywhere
        if k % 2:
            i = int(rng.integers(len(boxes)))
        else:
            i = next(
                n for n, (a0, b0, a1, b1) in enumerate(boxes) if a0 <= lobe[0] < a1 and b0 <= lobe[1] < b1
            )
            if boxes[i][2] - boxes[i][0] <= 2.0**-10:
                lobe = rng.random(2)
                continue
        a0, b0, a1, b1 = boxes.pop(i)
        h = 0.5 * (a1 - a0)
        boxes += [
            (a0, b0, a0 + h, b0 + h),
            (a0 + h, b0, a1, b0 + h),
            (a0, b0 + h, a0 + h, b1),
            (a0 + h, b0 + h, a1, b1),
        ]
    boxes = np.array(boxes)
    assert (boxes[:, 2] - boxes[:, 0]).min() < 2.0**-OUTLINE_LEVEL  # the case is deep enough
    out = outline_boxes(boxes)
    side = out[:, 2] - out[:, 0]
    assert side.min() == 2.0**-OUTLINE_LEVEL and len(out) < len(boxes)
    assert np.sum(side * side) == pytest.approx(1.0, abs=1e-12)
    w = np.minimum(out[:, None, 2], out[None, :, 2]) - np.maximum(out[:, None, 0], out[None, :, 0])
    h = np.minimum(out[:, None, 3], out[None, :, 3]) - np.maximum(out[:, None, 1], out[None, :, 1])
    overlap = np.maximum(w, 0.0) * np.maximum(h, 0.0)
    np.fill_diagonal(overlap, 0.0)
    assert not overlap.any()
    view = TreeView("equal_area", True, 0, (0.0, 0.0), (0.0, 1.0, 0.0, 360.0), boxes, np.ones(len(boxes)),
                    np.ones(len(boxes)), 1.0, 1.0, (1.0, 1.0))  # fmt: skip
    line = leaf_edges(view)
    assert int(np.sum(np.isnan(line[:, 0]))) == len(out)
    assert np.all(np.hypot(line[:, 0], line[:, 1])[~np.isnan(line[:, 0])] <= 1.0 + 1e-12)


def test_a_new_material_shows_a_first_fit_at_once_then_the_full_table(window, qtbot):
    """A parameter value never seen before, exact mode: the sampler view shows the rejection-free mode's
    coarse tree at once (the fastest tree of the new value: no bounds, no normalizer) and says so, then the
    exact mode's full table when its background build is done; the same first picture is not drawn again
    while the app waits for it."""
    import shutil

    from app.sampling_data import adaptive_sampler
    from core.brdf import make_brdf
    from core.cache import TableCache

    params = {"alpha": 0.0737}
    # a table stored by an earlier run (the app's cache is the user's) would be loaded whole: remove it
    key = adaptive_sampler(make_brdf("ggx", params), "exact", view_n_max := 2.0).key
    shutil.rmtree(TableCache().folder / key[:32], ignore_errors=True)
    window.sampling_view.n_max.setValue(view_n_max)
    window.sampling_view.mode.setCurrentText("exact")  # (its table's key: the warp mode's has no bounds)
    _use(window, "ggx", "ggx-fresh", params)
    window.document.set_direction(40.0, 0.0)
    window.tabs.setCurrentWidget(window.sampling_panel)
    view = window.sampling_view
    shown = []
    show = view.show_snapshot

    def show_and_record(snap):
        show(snap)
        shown.append((snap, view.stats.text()))

    view.show_snapshot = show_and_record
    # (the material editor's facts would build the same full table in this process meanwhile, and store it)
    slow = window.redraw.slow_timer
    slow.timeout.disconnect()
    try:
        full = _wait_snapshot(window, qtbot, lambda s: s.theta_deg == 40.0)
    finally:
        del view.show_snapshot
        slow.timeout.connect(window.redraw._start_slow_jobs)
    first = [snap for snap, _ in shown if not snap.table["complete"]]
    assert first, "the first picture of a new material was not a first fit"
    assert "a first fit" in shown[0][1] and "a first fit" not in shown[-1][1]
    assert "its table is being built" in shown[0][1]
    assert len(first) == 1  # a follow-up that still found the table building drew nothing
    assert first[0].table["interim"] and first[0].mode == "warp"
    assert shown[-1][0] is full and full.table["complete"] and full.mode == "exact"
    assert first[0].table["theta_nodes"] < full.table["theta_nodes"]
    assert 1.0 / full.n_max <= full.acceptance <= 1.0
    window.tabs.setCurrentIndex(0)
