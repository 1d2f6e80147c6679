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
from core.sampler import sampler_names

RASTER = 256


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

    def show_message(self, text: str) -> None:
        self.stats.setText(text)
        for ax in (self.ax_tree, self.ax_ratio):
            ax.clear()
            ax.set_axis_off()
        self.ax_tree.text(
            0.5, 0.5, text, ha="center", va="center", wrap=True, transform=self.ax_tree.transAxes
        )
        self.figure_view.redraw()

    def show_snapshot(self, snap: dict) -> None:
        self.snapshot = snap
        ax = self.ax_tree
        ax.clear()
        ax.set_aspect("equal")
        ax.set_xlim(-1.02, 1.02)
        ax.set_ylim(-1.02, 1.02)
        tree = snap.get("tree")
        lines = []
        if tree is not None:
            leaves = tree["leaves"]
            v = tree["total_mass"]
            density = leaf_raster(leaves, RASTER) / v if v > 0 else np.zeros((RASTER, RASTER))
            positive = density[density > 0]
            if positive.size:
                norm = LogNorm(vmin=max(positive.min(), positive.max() * 1e-6), vmax=positive.max())
                masked = np.ma.masked_less_equal(density, 0.0)
                ax.imshow(masked, extent=(-1, 1, -1, 1), origin="lower", cmap="magma", norm=norm)
            segs = []
            for _m, x0, y0, x1, y1 in leaves:
                if x1 > x0:
                    segs.append([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)])
            ax.add_collection(LineCollection(segs, colors="white", linewidths=0.3, alpha=0.5))
            lo, hi = tree["bin_deg"]
            lines.append(
                f"Tree for theta_o in [{lo:.2f}, {hi:.2f}] deg: {len(leaves)} leaves, "
                f"{tree['nbytes'] / 1024:.1f} KiB, built in {tree['build_seconds'] * 1000:.0f} ms; "
                f"V = {v:.4g}, I(wo) = {tree['integral']:.4g}; "
                f"expected acceptance per trial I/V = {snap['acceptance']:.3f} (>= 1/n_max = {1 / snap['n_max']:.3f})"
            )
        else:
            ax.text(0, 0, snap.get("tree_error", ""), ha="center", va="center", wrap=True, fontsize=8)
            lines.append(f"Tree: {snap.get('tree_error', '')}")
        samples = snap.get("samples")
        if samples is not None:
            ax.scatter(samples[:, 0], samples[:, 1], s=1.5, c="cyan", alpha=0.7, linewidths=0)
            info = snap.get("sampler_info", {})
            extra = ", ".join(
                f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                for k, v in info.items()
                if "accept" in k or "trial" in k or "violation" in k
            )
            lines.append(f"Adaptive samples: {len(samples)}" + (f" ({extra})" if extra else ""))
        else:
            lines.append(f"Samples: {snap.get('samples_error', '')}")
        ax.add_patch(Circle((0, 0), 1.0, fill=False, color="gray", lw=1))
        wx, wy = snap["wo_disk"]
        ax.plot([wx], [wy], marker="x", color="red", ms=8)
        ax.set_title("leaves: trial density M/V on the disk (log); samples", fontsize=9)
        if tree is not None and snap.get("projection", "orthographic") != "orthographic":
            wx, wy = to_disk(
                np.array([[wx, wy, np.sqrt(max(0.0, 1 - wx * wx - wy * wy))]]), snap["projection"]
            )[0]
            ax.lines[-1].set_data([wx], [wy])

        ax = self.ax_ratio
        ax.clear()
        ax.set_aspect("equal")
        ratio = snap.get("ratio")
        name = snap.get("ratio_sampler", "")
        if ratio is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                log_ratio = np.log2(ratio)
            log_ratio = np.where(np.isinf(log_ratio), np.sign(log_ratio) * 4.0, log_ratio)
            im = ax.imshow(log_ratio, extent=(-1, 1, -1, 1), origin="lower", cmap="coolwarm", vmin=-2, vmax=2)
            if not hasattr(self, "_colorbar"):
                self._colorbar = self.figure_view.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
                self._colorbar.set_label("log2(pdf / (f cos / I))")
            else:
                self._colorbar.update_normal(im)
            ax.add_patch(Circle((0, 0), 1.0, fill=False, color="gray", lw=1))
            finite = ratio[np.isfinite(ratio) & (ratio > 0)]
            spread = (
                f"{np.percentile(finite, 5):.3g} .. {np.percentile(finite, 95):.3g}" if finite.size else "-"
            )
            lines.append(
                f"Ratio map of '{name}': pdf / (f cos / I) spans {spread} (5-95 %); "
                f"relative std of the weight f cos / pdf = {snap['weight_rel_std']:.3g}"
            )
        else:
            ax.text(0, 0, snap.get("ratio_error", ""), ha="center", va="center", wrap=True, fontsize=8)
            lines.append(f"Ratio map: {snap.get('ratio_error', '')}")
        ax.set_xlim(-1.02, 1.02)
        ax.set_ylim(-1.02, 1.02)
        ax.set_title(f"ratio map: {name} vs ideal (white = 1)", fontsize=9)
        frame = "rotated so that wo has phi = 0" if snap.get("frame_rotated") else "local frame"
        projection = snap.get("projection", "orthographic")
        meaning = "(x, y) = (wi.x, wi.y)" if projection == "orthographic" else "radius = theta_i / 90 deg"
        lines.append(f"Disk: {projection} projection, {meaning}; {frame}.")
        self.stats.setText("<br>".join(lines))
        self.figure_view.redraw()

    def export(self, path):
        return self.figure_view.export(path)
