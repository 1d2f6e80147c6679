"""The adaptive sampler on the unit disk: the quadtree's leaves coloured by density, adaptive samples on top,
the acceptance rate, and a ratio map comparing a strategy's pdf with the ideal ``f cos / I``."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import LogNorm
from matplotlib.patches import Circle
from PySide6.QtCore import Signal
from PySide6.QtWidgets import QComboBox, QDoubleSpinBox, QHBoxLayout, QLabel, QSpinBox, QVBoxLayout, QWidget

from app.capabilities import to_disk
from app.view_data import leaf_raster
from app.views.figure import FigureView
from core.sampling import sampler_names

RASTER = 192


class SamplingView(QWidget):
    """Draws a :func:`app.view_data.sampling_snapshot`. Emits ``options_changed`` when the user changes
    ``n_max``, the compared strategy or the sample count."""

    options_changed = Signal()

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.n_max = QDoubleSpinBox()
        self.n_max.setRange(1.05, 16.0)
        self.n_max.setSingleStep(0.1)
        self.n_max.setValue(2.0)
        self.n_max.setKeyboardTracking(False)
        self.n_max.setToolTip("n_max: refine leaves until V <= n_max * I (the seed's one knob)")
        self.strategy = QComboBox()
        self.strategy.setToolTip("The strategy whose pdf the ratio map compares with f cos / I")
        self.refresh_strategies()
        self.n_samples = QSpinBox()
        self.n_samples.setRange(100, 200_000)
        self.n_samples.setSingleStep(1000)
        self.n_samples.setValue(2000)
        self.n_samples.setKeyboardTracking(False)
        controls = QHBoxLayout()
        for label, w in (("n_max", self.n_max), ("ratio map of", self.strategy), ("samples", self.n_samples)):
            controls.addWidget(QLabel(label))
            controls.addWidget(w)
        controls.addStretch(1)
        self.stats = QLabel("")
        self.stats.setWordWrap(True)
        self.figure_view = FigureView(size=(8.0, 4.0))
        fig = self.figure_view.figure
        fig.clear()
        self.ax_tree, self.ax_ratio = fig.subplots(1, 2)
        fig.subplots_adjust(left=0.06, right=0.93, bottom=0.08, top=0.92, wspace=0.2)
        layout = QVBoxLayout(self)
        layout.addLayout(controls)
        layout.addWidget(self.figure_view, 1)
        layout.addWidget(self.stats)
        self.snapshot: dict | None = None
        self.n_max.valueChanged.connect(lambda _: self.options_changed.emit())
        self.strategy.activated.connect(lambda _: self.options_changed.emit())
        self.n_samples.valueChanged.connect(lambda _: self.options_changed.emit())
        self.show_message("computing ...")

    def refresh_strategies(self) -> None:
        current = self.strategy.currentText() or "adaptive"
        self.strategy.clear()
        names = sampler_names()
        self.strategy.addItems(names)
        self.strategy.setCurrentText(
            current if current in names else ("adaptive" if "adaptive" in names else "cosine")
        )

    def options(self) -> dict:
        return {
            "n_max": float(self.n_max.value()),
            "ratio_sampler": self.strategy.currentText(),
            "n_samples": int(self.n_samples.value()),
        }

    def _make_artists(self) -> None:
        """Create the plot's artists once; redraws only update their data."""
        ax = self.ax_tree
        ax.set_aspect("equal")
        ax.set_xlim(-1.02, 1.02)
        ax.set_ylim(-1.02, 1.02)
        empty = np.ma.masked_all((RASTER, RASTER))
        self._tree_img = ax.imshow(
            empty,
            extent=(-1, 1, -1, 1),
            origin="lower",
            cmap="magma",
            norm=LogNorm(vmin=1e-3, vmax=1.0),
            interpolation="nearest",
        )
        self.leaf_edges = LineCollection([], colors="white", linewidths=0.3, alpha=0.5)
        ax.add_collection(self.leaf_edges)
        self._samples = ax.scatter([], [], s=1.5, c="cyan", alpha=0.7, linewidths=0)
        self._tree_rim = ax.add_patch(Circle((0, 0), 1.0, fill=False, color="gray", lw=1))
        (self._wo_mark,) = ax.plot([], [], marker="x", color="red", ms=8, ls="none")
        self._tree_msg = ax.text(0, 0, "", ha="center", va="center", fontsize=8)
        ax.set_title("leaves: trial density M/V on the disk (log); samples", fontsize=9)
        ax = self.ax_ratio
        ax.set_aspect("equal")
        ax.set_xlim(-1.02, 1.02)
        ax.set_ylim(-1.02, 1.02)
        self._ratio_img = ax.imshow(
            np.full((2, 2), np.nan),
            extent=(-1, 1, -1, 1),
            origin="lower",
            cmap="coolwarm",
            vmin=-2,
            vmax=2,
            interpolation="nearest",
        )
        self._colorbar = self.figure_view.figure.colorbar(self._ratio_img, ax=ax, fraction=0.046, pad=0.04)
        self._colorbar.set_label("log2(pdf / (f cos / I))")
        self._ratio_rim = ax.add_patch(Circle((0, 0), 1.0, fill=False, color="gray", lw=1))
        self._ratio_msg = ax.text(0, 0, "", ha="center", va="center", fontsize=8)
        self._ratio_title = ax.set_title("", fontsize=9)
        for a in (self.ax_tree, self.ax_ratio):  # few tick labels: text is most of a redraw's cost
            a.set_xticks([-1, 0, 1])
            a.set_yticks([-1, 0, 1])
        self._colorbar.set_ticks([-2, -1, 0, 1, 2])
        # What a new snapshot changes is blitted over the saved rest of the figure (axes, ticks, titles,
        # colour bar): a full draw of this figure costs ~40 ms, the blit a fraction of it. The rim circles
        # are redrawn too so that they stay above the images.
        self.figure_view.set_animated(
            [self._tree_img, self.leaf_edges, self._samples, self._tree_rim, self._wo_mark, self._tree_msg,
             self._ratio_img, self._ratio_rim, self._ratio_msg]
        )  # fmt: skip
        self._artists = True

    def show_message(self, text: str) -> None:
        if not getattr(self, "_artists", False):
            self._make_artists()
        self.stats.setText(text)
        self._tree_msg.set_text(text)
        self._tree_img.set_visible(False)
        self.leaf_edges.set_segments([])
        self._samples.set_offsets(np.zeros((0, 2)))
        self._ratio_img.set_visible(False)
        self.figure_view.update_artists()

    def show_snapshot(self, snap: dict) -> None:
        if not getattr(self, "_artists", False):
            self._make_artists()
        self.snapshot = snap
        lines = []
        tree = snap.get("tree")
        projection = snap.get("projection", "orthographic")
        if tree is not None:
            leaves = tree["leaves"]
            v = tree["total_mass"]
            density = leaf_raster(leaves, RASTER) / v if v > 0 else np.zeros((RASTER, RASTER))
            positive = density[density > 0]
            if positive.size:
                # coloured here (log scale, transparent outside the leaves): an RGBA image skips matplotlib's
                # masking and normalization on every redraw
                norm = LogNorm(vmin=max(positive.min(), positive.max() * 1e-6), vmax=positive.max())
                rgba = self._tree_img.get_cmap()(norm(np.maximum(density, norm.vmin)), bytes=True)
                rgba[density <= 0.0, 3] = 0
                self._tree_img.set_data(rgba)
            self._tree_img.set_visible(bool(positive.size))
            keep = leaves[:, 3] > leaves[:, 1]
            x0, y0, x1, y1 = (leaves[keep, k] for k in (1, 2, 3, 4))
            segs = np.stack(
                [np.stack(p, axis=-1) for p in ((x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0))], axis=1
            )
            self.leaf_edges.set_segments(segs)
            self._tree_msg.set_text("")
            lo, hi = tree["bin_deg"]
            lines.append(
                f"Tree for theta_o in [{lo:.2f}, {hi:.2f}] deg: {len(leaves)} leaves, "
                f"{tree['nbytes'] / 1024:.1f} KiB, built in {tree['build_seconds'] * 1000:.0f} ms; "
                f"V = {v:.4g}, I(wo) = {tree['integral']:.4g}; "
                f"expected acceptance per trial I/V = {snap['acceptance']:.3f} (>= 1/n_max = {1 / snap['n_max']:.3f})"
            )
        else:
            self._tree_img.set_visible(False)
            self.leaf_edges.set_segments([])
            self._tree_msg.set_text(snap.get("tree_error", ""))
            lines.append(f"Tree: {snap.get('tree_error', '')}")
        samples = snap.get("samples")
        if samples is not None:
            self._samples.set_offsets(samples)
            info = snap.get("sampler_info", {})
            extra = ", ".join(
                f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                for k, v in info.items()
                if "accept" in k or "trial" in k or "violation" in k
            )
            lines.append(f"Adaptive samples: {len(samples)}" + (f" ({extra})" if extra else ""))
        else:
            self._samples.set_offsets(np.zeros((0, 2)))
            lines.append(f"Samples: {snap.get('samples_error', '')}")
        wx, wy = snap["wo_disk"]
        if projection != "orthographic":
            wx, wy = to_disk(np.array([[wx, wy, np.sqrt(max(0.0, 1 - wx * wx - wy * wy))]]), projection)[0]
        self._wo_mark.set_data([wx], [wy])

        ratio = snap.get("ratio")
        name = snap.get("ratio_sampler", "")
        if ratio is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                log_ratio = np.log2(ratio)
            log_ratio = np.where(np.isinf(log_ratio), np.sign(log_ratio) * 4.0, log_ratio)
            self._ratio_img.set_data(log_ratio)
            self._ratio_img.set_visible(True)
            self._ratio_msg.set_text("")
            finite = ratio[np.isfinite(ratio) & (ratio > 0)]
            spread = (
                f"{np.percentile(finite, 5):.3g} .. {np.percentile(finite, 95):.3g}" if finite.size else "-"
            )
            lines.append(
                f"Ratio map of '{name}': pdf / (f cos / I) spans {spread} (5-95 %); "
                f"relative std of the weight f cos / pdf = {snap['weight_rel_std']:.3g}"
            )
        else:
            self._ratio_img.set_visible(False)
            self._ratio_msg.set_text(snap.get("ratio_error", ""))
            lines.append(f"Ratio map: {snap.get('ratio_error', '')}")
        title = f"ratio map: {name} vs ideal (white = 1)"
        retitled = title != self._ratio_title.get_text()
        self._ratio_title.set_text(title)
        frame = "rotated so that wo has phi = 0" if snap.get("frame_rotated") else "local frame"
        meaning = "(x, y) = (wi.x, wi.y)" if projection == "orthographic" else "radius = theta_i / 90 deg"
        lines.append(f"Disk: {projection} projection, {meaning}; {frame}.")
        self.stats.setText("<br>".join(lines))
        if retitled:  # the title is part of the saved background
            self.figure_view.redraw()
        else:
            self.figure_view.update_artists()

    def export(self, path):
        return self.figure_view.export(path)
