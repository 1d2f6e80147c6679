"""The adaptive sampler on its disk: the tree serving ``wo`` with its leaves coloured by density and outlined,
the selected mode's samples on top, and a ratio map comparing a strategy's pdf with the ideal ``f cos / I``
on the same disk."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import Circle
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QComboBox, QDoubleSpinBox, QHBoxLayout, QLabel, QSpinBox, QVBoxLayout, QWidget

from app.sampling_data import (
    RATIO_CMAP,
    RATIO_RANGE,
    SAMPLING_PROJECTIONS,
    TREE_RASTER,
    SamplingSnapshot,
    table_origin,
)
from app.views.figure import FigureView
from core.sampling import sampler_names

DISK_RADIUS = {
    "orthographic": "|X| = sin theta_i",
    "equal_area": "|X| = sqrt(1 - cos theta_i)",
    "half_vector": "|X| = sqrt(1 - cos theta_h)",
    "rim": "|X| = sqrt(1 - sqrt(cos theta_i))",
}
MODE_TIPS = {
    "exact": "exact: rejection against the leaves' bounds; pdf exactly f cos / I (the seed's sampler)",
    "warp": "warp: rejection-free, one evaluation of f per sample; pdf approximates f cos / I",
}


class SamplingView(QWidget):
    """Draws a :class:`app.sampling_data.SamplingSnapshot`. Emits ``options_changed`` when the user changes the
    mode, ``n_max``, the compared strategy or the sample count."""

    options_changed = Signal()

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.mode = QComboBox()
        self.mode.addItems(list(MODE_TIPS))
        self.mode.setToolTip("The adaptive mode whose samples (and proposal density) are shown:\n" + "\n".join(
            MODE_TIPS.values()
        ))  # fmt: skip
        self.n_max = QDoubleSpinBox()
        self.n_max.setRange(1.05, 16.0)
        self.n_max.setSingleStep(0.1)
        self.n_max.setValue(2.0)
        self.n_max.setKeyboardTracking(False)
        self.n_max.setToolTip(
            "n_max: the exact mode's envelope allows at most n_max trials per sample on average"
        )
        self.strategy = QComboBox()
        self.strategy.setToolTip("The strategy whose pdf the ratio map compares with f cos / I")
        self.refresh_strategies()
        self.n_samples = QSpinBox()
        self.n_samples.setRange(100, 200_000)
        self.n_samples.setSingleStep(1000)
        self.n_samples.setValue(2000)
        self.n_samples.setKeyboardTracking(False)
        controls = QHBoxLayout()
        for label, w in (
            ("mode", self.mode),
            ("n_max", self.n_max),
            ("ratio map of", self.strategy),
            ("samples", self.n_samples),
        ):
            controls.addWidget(QLabel(label))
            controls.addWidget(w)
        controls.addStretch(1)
        self.stats = QLabel("")
        self.stats.setWordWrap(True)
        # room for the usual five or six lines whatever they say: a label that grew or shrank with its text
        # would resize the figure, and a resized figure is drawn in full instead of blitted
        self.stats.setMinimumHeight(7 * self.stats.fontMetrics().lineSpacing())
        self.stats.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.figure_view = FigureView(size=(8.0, 4.2), status_lines=1)  # (its facts are in self.stats)
        fig = self.figure_view.figure
        fig.clear()
        self.ax_tree, self.ax_ratio = fig.subplots(1, 2)
        fig.subplots_adjust(left=0.06, right=0.89, bottom=0.07, top=0.97, wspace=0.2)
        # The panes' titles are Qt labels over the figure, not matplotlib texts: a title changes with most
        # edits (the node serving wo, the layout after a parameter edit), and matplotlib draws a two-line text
        # in ~10 ms on the GUI thread (plus a copy of the saved background); a label costs a fraction of a ms.
        # Exports put them back into the figure (:meth:`export`).
        self.tree_caption = QLabel("")
        self.ratio_caption = QLabel("")
        captions = QHBoxLayout()
        for caption in (self.tree_caption, self.ratio_caption):
            caption.setAlignment(Qt.AlignmentFlag.AlignCenter)
            caption.setMinimumHeight(2 * caption.fontMetrics().lineSpacing())
            captions.addWidget(caption, 1)
        layout = QVBoxLayout(self)
        layout.addLayout(controls)
        layout.addLayout(captions)
        layout.addWidget(self.figure_view, 1)
        layout.addWidget(self.stats)
        layout.addStretch(0)
        self.snapshot: SamplingSnapshot | None = None
        self.mode.activated.connect(lambda _: self.options_changed.emit())
        self.n_max.valueChanged.connect(lambda _: self.options_changed.emit())
        self.strategy.activated.connect(lambda _: self.options_changed.emit())
        self.n_samples.valueChanged.connect(lambda _: self.options_changed.emit())
        self.show_message("computing ...")

    ASPECT = 0.5
    """The figure's height over its width: two square panes side by side, their titles right above them."""

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt name)
        # A figure taller than its two square panes would only hold blank space between them and their titles
        # (labels above the figure): the figure keeps the panes' height and the rest goes below the facts.
        super().resizeEvent(event)
        cap = max(
            160, int(self.ASPECT * self.figure_view.width()) + self.figure_view.status.sizeHint().height()
        )
        if self.figure_view.maximumHeight() != cap:
            self.figure_view.setMaximumHeight(cap)

    def refresh_strategies(self) -> None:
        current = self.strategy.currentText() or "adaptive_exact"
        self.strategy.clear()
        names = sampler_names()
        self.strategy.addItems(names)
        self.strategy.setCurrentText(current if current in names else "adaptive_exact")

    def options(self) -> dict:
        return {
            "mode": self.mode.currentText(),
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
        self._tree_img = ax.imshow(
            np.zeros((TREE_RASTER, TREE_RASTER, 4), dtype=np.uint8),
            extent=(-1, 1, -1, 1),
            origin="lower",
            interpolation="nearest",
        )
        self.leaf_edges = LineCollection(
            [], colors="0.75", linewidths=0.3, alpha=0.7
        )  # seen on dark and on white
        ax.add_collection(self.leaf_edges)
        self._samples = ax.scatter([], [], s=1.5, c="cyan", alpha=0.7, linewidths=0)
        self._tree_rim = ax.add_patch(Circle((0, 0), 1.0, fill=False, color="gray", lw=1))
        (self._wo_mark,) = ax.plot([], [], marker="x", color="red", ms=8, ls="none")
        self._tree_msg = ax.text(0, 0, "", ha="center", va="center", fontsize=8, wrap=True)
        ax = self.ax_ratio
        ax.set_aspect("equal")
        ax.set_xlim(-1.02, 1.02)
        ax.set_ylim(-1.02, 1.02)
        self._ratio_img = ax.imshow(
            np.full((2, 2), np.nan),
            extent=(-1, 1, -1, 1),
            origin="lower",
            cmap=RATIO_CMAP,
            vmin=-RATIO_RANGE,
            vmax=RATIO_RANGE,
            interpolation="nearest",
        )
        self._colorbar = self.figure_view.figure.colorbar(self._ratio_img, ax=ax, fraction=0.046, pad=0.04)
        self._colorbar.set_label("log2(pdf / (f cos / I))")
        self._ratio_rim = ax.add_patch(Circle((0, 0), 1.0, fill=False, color="gray", lw=1))
        self._ratio_msg = ax.text(0, 0, "", ha="center", va="center", fontsize=8, wrap=True)
        for a in (self.ax_tree, self.ax_ratio):  # few tick labels: text is most of a redraw's cost
            a.set_xticks([-1, 0, 1])
            a.set_yticks([-1, 0, 1])
        self._colorbar.set_ticks([-2, -1, 0, 1, 2])
        # What a new snapshot changes is blitted over the saved rest of the figure (axes, ticks, colour bar): a
        # full draw of this figure costs ~40 ms, the blit a fraction of it. The rim circles are redrawn so that
        # they stay on top; the messages are drawn only while they say something (text is slow to draw).
        self.figure_view.set_animated(
            [self._tree_img, self.leaf_edges, self._samples, self._tree_rim, self._wo_mark, self._tree_msg,
             self._ratio_img, self._ratio_rim, self._ratio_msg]
        )  # fmt: skip
        self._artists = True

    def show_message(self, text: str) -> None:
        if not getattr(self, "_artists", False):
            self._make_artists()
        self.stats.setText(text)
        self._set_message(self._tree_msg, text)
        self._set_message(self._ratio_msg, "")
        self._tree_img.set_visible(False)
        self.leaf_edges.set_segments([])
        self._samples.set_offsets(np.zeros((0, 2)))
        self._wo_mark.set_data([], [])
        self._ratio_img.set_visible(False)
        self.figure_view.update_artists()

    @staticmethod
    def _set_message(artist, text: str) -> None:
        artist.set_text(text)
        artist.set_visible(bool(text))

    def show_snapshot(self, snap: SamplingSnapshot) -> None:
        if not getattr(self, "_artists", False):
            self._make_artists()
        self.snapshot = snap
        tree = snap.tree
        rgba, (lo, hi) = snap.leaf_rgba, snap.density_range
        self._tree_img.set_data(rgba)
        self._tree_img.set_visible(True)
        self.leaf_edges.set_segments([snap.edges])
        self._samples.set_offsets(snap.samples)
        if snap.wo_disk is None:
            self._wo_mark.set_data([], [])
        else:
            self._wo_mark.set_data([snap.wo_disk[0]], [snap.wo_disk[1]])
        self._set_message(self._tree_msg, "")
        th_lo, th_hi, ph_lo, ph_hi = tree.cell_deg
        cell = f"node theta {tree.node_deg[0]:.1f} deg (cell {th_lo:.1f}-{th_hi:.1f})"
        if ph_hi - ph_lo < 360.0:
            cell += f", phi {tree.node_deg[1]:.0f} deg (cell {ph_lo:.0f}-{ph_hi:.0f})"
        titles = (
            f"{SAMPLING_PROJECTIONS[tree.projection]}\n{cell}",
            f"ratio map of {snap.ratio_sampler} vs f cos / I\n(white = 1; the same disk)",
        )

        table = snap.table
        built = table_origin(table, "ms")
        if table.get("interim"):
            built += (
                " (a first fit: the rejection-free mode's coarse table, shown while the exact mode's table is"
                " built)"
            )
        elif not table.get("complete", True):
            built += " (the coarse table: the full one is being built)"
        proposal = "density of trials K_L q / V" if snap.mode == "exact" else "rejection-free density q"
        lines = [
            f"Tree {tree.tree + 1} of {table['trees']}: {len(tree.boxes)} leaves, coloured by the {snap.mode} "
            f"mode's {proposal} per unit square area (log, {lo:.3g} .. {hi:.3g}; blank below). Table: "
            f"{table['leaves']} leaves, {table['memory_bytes'] / 1024:.1f} KiB, {built}.",
        ]
        if table.get("interim"):
            lines.append("Exact mode at wo: its table is being built.")
        elif snap.cosine_fallback:
            lines.append(
                "Beyond the table's last node: the exact mode draws the cosine density here "
                "(the warp mode still uses this tree)."
            )
        else:
            lines.append(
                f"Exact mode at wo: I(wo) = {tree.normalizer:.4g}, acceptance per trial 1/V = "
                f"{tree.acceptance:.3f} (>= 1/n_max = {1 / snap.n_max:.3f})."
            )
        trials = f", {snap.mean_trials:.2f} trials per sample" if snap.mode == "exact" else ""
        lines.append(f"Samples ({snap.mode} mode): {len(snap.samples)} shown{trials}.")

        name = snap.ratio_sampler
        if snap.ratio is not None:
            ratio = snap.ratio
            self._ratio_img.set_data(snap.ratio_rgba)
            self._ratio_img.set_visible(True)
            self._set_message(self._ratio_msg, "")
            finite = ratio[np.isfinite(ratio) & (ratio > 0)]
            spread = (
                f"{np.percentile(finite, 5):.3g} .. {np.percentile(finite, 95):.3g}" if finite.size else "-"
            )
            lines.append(
                f"Ratio map of '{name}': pdf / (f cos / I) spans {spread} (5-95 %); "
                f"relative std of the weight f cos / pdf = {snap.weight_rel_std:.3g}."
            )
        else:
            self._ratio_img.set_visible(False)
            self._set_message(self._ratio_msg, snap.ratio_error)
            lines.append(f"Ratio map: {snap.ratio_error}")
        if tree.follow:
            frame = "turned so that wo lies at phi = 0" + (" (red x)" if snap.wo_disk is not None else "")
        else:
            frame = "the local frame"
        flips = [axis for axis, sign in zip("xy", tree.mirror, strict=True) if sign < 0]
        if flips:
            frame += f", mirrored ({' and '.join(f'{a} -> -{a}' for a in flips)}) into wo's first quadrant"
        where = "; a point is h, and wi = 2 (wo.h) h - wo" if tree.projection == "half_vector" else ""
        lines.append(
            f"Disk: {SAMPLING_PROJECTIONS[tree.projection]} ({DISK_RADIUS[tree.projection]}{where}); frame {frame}."
        )
        self.stats.setText("<br>".join(lines))
        self.tree_caption.setText(titles[0])
        self.ratio_caption.setText(titles[1])
        self.figure_view.update_artists()

    def export(self, path):
        """The figure with the panes' titles in it (on screen they are labels over the figure)."""
        fig = self.figure_view.figure
        top = fig.subplotpars.top
        self.ax_tree.set_title(self.tree_caption.text(), fontsize=9)
        self.ax_ratio.set_title(self.ratio_caption.text(), fontsize=9)
        fig.subplots_adjust(top=0.86)
        try:
            return self.figure_view.export(path)
        finally:
            self.ax_tree.set_title("")
            self.ax_ratio.set_title("")
            fig.subplots_adjust(top=top)
            self.figure_view.redraw()
