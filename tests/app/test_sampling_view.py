"""The sampler view in the real window: the quadtree follows parameter, direction and n_max edits.

Lambert only: cheap trees, and I(wo) = kd whatever the disk projection.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.capabilities import quadtree_available

pytestmark = [
    pytest.mark.gui,
    pytest.mark.skipif(not quadtree_available(), reason="core/quadtree.py is not in this build yet"),
]

COMPILE_TIMEOUT_MS = 240_000


def _wait_snapshot(window, qtbot, predicate, timeout=COMPILE_TIMEOUT_MS):
    window.refresh_now()
    qtbot.waitUntil(
        lambda: (
            window.jobs_idle("sampling")
            and window.sampling_view.snapshot is not None
            and predicate(window.sampling_view.snapshot)
        ),
        timeout=timeout,
    )
    return window.sampling_view.snapshot


def test_tree_follows_parameter_direction_and_n_max(window, qtbot):
    doc = window.document
    if "lam" not in doc.material_names():
        doc.add_material("lambert", name="lam", params={"kd": 0.5})
    doc.select_material("lam")
    doc.set_direction(30.0, 0.0)
    window.tabs.setCurrentWidget(window.sampling_panel)
    snap = _wait_snapshot(window, qtbot, lambda s: s["tree"] is not None and s["theta_deg"] == 30.0)
    tree = snap["tree"]
    assert tree["bin_deg"][0] <= 30.0 <= tree["bin_deg"][1]
    # Lambert: I(wo) = int f cos dw = kd, whatever the disk projection.
    assert tree["integral"] == pytest.approx(0.5, rel=1e-6)
    assert 1.0 / snap["n_max"] <= snap["acceptance"] <= 1.0
    ratio = snap["ratio"]
    if snap["ratio_sampler"] == "adaptive":
        assert np.nanmax(np.abs(np.log2(ratio))) < 1e-6
    drawn_leaves = len(window.sampling_view.leaf_edges.get_segments())
    assert drawn_leaves == int(np.sum(tree["leaves"][:, 3] > tree["leaves"][:, 1]))

    # a parameter edit: the bounds scale with kd
    doc.set_param("kd", 0.25)
    new = _wait_snapshot(window, qtbot, lambda s: s["tree"]["integral"] < 0.4)
    assert new["tree"]["integral"] == pytest.approx(0.25, rel=1e-6)
    assert np.allclose(new["tree"]["leaves"][:, 0], 0.5 * tree["leaves"][:, 0], rtol=1e-9)

    # another direction: another bin
    doc.set_direction(60.0, 0.0)
    far = _wait_snapshot(window, qtbot, lambda s: s["theta_deg"] == 60.0)
    assert far["tree"]["bin_deg"][0] <= 60.0 <= far["tree"]["bin_deg"][1]

    # a smaller n_max refines the tree
    window.sampling_view.n_max.setValue(1.2)
    fine = _wait_snapshot(window, qtbot, lambda s: s["n_max"] == pytest.approx(1.2))
    assert len(fine["tree"]["leaves"]) > len(far["tree"]["leaves"])
    assert fine["acceptance"] >= 1.0 / 1.2 - 1e-9
    window.sampling_view.n_max.setValue(2.0)
    window.tabs.setCurrentIndex(0)


def test_ratio_map_of_the_cosine_sampler_is_one_for_lambert(window, qtbot):
    doc = window.document
    if "lam" not in doc.material_names():
        doc.add_material("lambert", name="lam", params={"kd": 0.5})
    doc.select_material("lam")
    window.tabs.setCurrentWidget(window.sampling_panel)
    view = window.sampling_view
    view.strategy.setCurrentText("uniform")
    view.strategy.activated.emit(view.strategy.currentIndex())
    snap = _wait_snapshot(window, qtbot, lambda s: s["ratio_sampler"] == "uniform")
    # uniform pdf 1/(2 pi) against the ideal cos/pi: the ratio is 1 / (2 cos theta), 1/2 at the centre
    from app.capabilities import from_disk

    r = snap["ratio"]
    n = r.shape[0]
    for i, j in ((n // 2, n // 2), (n // 2, n // 8), (n // 5, n // 3)):
        x, y = (np.array([j, i]) + 0.5) / n * 2.0 - 1.0
        wi = from_disk(np.array([x]), np.array([y]), snap["projection"])[0]
        # (the ideal uses the tree's quadrature normalizer I, exact to ~1e-8)
        assert r[i, j] == pytest.approx(0.5 / wi[2], rel=1e-6)
    view.strategy.setCurrentText("cosine")
    view.strategy.activated.emit(view.strategy.currentIndex())
    snap = _wait_snapshot(window, qtbot, lambda s: s["ratio_sampler"] == "cosine")
    assert np.nanmax(np.abs(snap["ratio"] - 1.0)) < 1e-6
    assert snap["weight_rel_std"] < 1e-9
    window.tabs.setCurrentIndex(0)
