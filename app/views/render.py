"""The render panel: two strategies side by side on the same scene and budget (equal spp or equal time),
rendered progressively in a separate process (:mod:`app.render_process`, so the GUI never stalls);
synchronized pan and zoom, live counters, RMSE and relMSE against a reference over time with the equal-time
verdict, the reference made in the background (:mod:`app.reference_runner`), cancel and restart, and exports
(EXR, PNG, the labelled composite, error curves)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QDoubleSpinBox,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSpinBox,
    QSplitter,
    QVBoxLayout,
    QWidget,
)

from app.reference import Reference, scene_key
from app.reference_runner import ReferenceRunner
from app.render_process import RenderServer
from app.render_session import check_request
from app.settings import cluster_setting
from app.views.error_plot import ErrorPlot
from app.views.figure import StatusLine
from app.views.images import ImageView
from core.errors import BrdfStudioError, OutputError
from core.sampling import sampler_names
from core.scene import Scene

PLOT_INTERVAL_MS = 500
FRAME_INTERVAL_MS = 250
"""Images, counters and the error plot are drawn together, at most every ``FRAME_INTERVAL_MS`` (the plot at
most every ``PLOT_INTERVAL_MS``): the window is composed through OpenGL (its 3D views), so every repaint of any
widget flushes the whole window, tens of ms in software GL on a loaded machine (measured with
``bench/app_latency.py --stacks``: the GUI thread asleep on the GL's futex). One flush per turn, 4 a second.
A strategy's first image and the last ones are shown at once."""
LONG_RENDER_SPP = 256
"""Renders of at least this many samples per pixel (equal spp) run on the render cluster when one is set
(:class:`app.settings.ClusterSetting`); shorter ones, and equal-time comparisons, run on this machine."""


class RenderPanel(QWidget):
    """Renders what ``scene_provider()`` returns. Emits ``error(str)``."""

    error = Signal(str)

    def __init__(self, scene_provider: Callable[[], Scene], jobs, parent=None):
        super().__init__(parent)
        self.scene_provider = scene_provider
        self.server = RenderServer(parent=self)
        self.server.events_received.connect(self._on_events)
        jobs.on_shutdown(self.server.stop)
        self.reference_runner = ReferenceRunner(self)
        self.reference_runner.progressed.connect(self._reference_progressed)
        self.reference_runner.status.connect(self.set_status)
        jobs.on_shutdown(self.reference_runner.shutdown)
        self.project_provider: Callable[[], Path | None] = lambda: None
        """The project file (reference files are stored beside it)."""
        self.reference_note = ""
        """What the last render's start found about the reference (shown with the status)."""
        self.reference_key: str | None = None
        """The scene key of a reference made in the app (``None``: none, or one loaded from a file)."""
        self.job: int | None = None  # the id of the render in progress
        self._frames_due: dict[str, dict] = {}
        """The newest frame of each strategy not drawn yet (frames of small images come faster than worth
        drawing: the images are drawn at most every ``FRAME_INTERVAL_MS``)."""
        self._frame_timer = QTimer(self)
        self._frame_timer.setSingleShot(True)
        self._frame_timer.setInterval(FRAME_INTERVAL_MS)
        self._frame_timer.timeout.connect(self._show_due_frames)
        self._plot_due = False
        """New errors not plotted yet (plotted with the next images, see ``FRAME_INTERVAL_MS``)."""
        self._plotted_at = 0.0
        self._plot_lines: dict | None = None  # strategy -> its RMSE line; None while the placeholder shows
        self.frames: dict[str, dict] = {}
        self.curves: dict[str, list[dict]] = {}
        self.reference: np.ndarray | None = None
        self.status_text = ""

        names = sampler_names()
        self.strategy_a = QComboBox()
        self.strategy_b = QComboBox()
        self.strategy_a.addItems(names)
        self.strategy_b.addItems(["(none)", *names])
        self.strategy_a.setCurrentText("uniform")
        self.strategy_b.setCurrentText("adaptive_exact" if "adaptive_exact" in names else "cosine")
        self.mode = QComboBox()
        self.mode.addItem("equal spp", "spp")
        self.mode.addItem("equal time", "time")
        self.spp = QSpinBox()
        self.spp.setRange(1, 100_000)
        self.spp.setValue(16)
        self.spp.setSuffix(" spp")
        self.seconds = QDoubleSpinBox()
        self.seconds.setRange(0.1, 36_000)
        self.seconds.setValue(5.0)
        self.seconds.setSuffix(" s")
        self.width_box = QSpinBox()
        self.width_box.setRange(8, 4096)
        self.width_box.setValue(256)
        self.height_box = QSpinBox()
        self.height_box.setRange(8, 4096)
        self.height_box.setValue(192)
        self.start_button = QPushButton("Render")
        self.start_button.setToolTip("Start (or restart) the render (F5)")
        self.reference_button = QPushButton("Make reference")
        self.reference_button.setToolTip(
            "Render a long, high-spp reference of this scene in the background (stored beside the project; "
            "resumes where it stopped); errors against it are measured live (Ctrl+R)"
        )
        self.reference_button.clicked.connect(self.make_reference)
        self.cluster_button = QPushButton("Cluster...")
        self.cluster_button.setToolTip(
            "Where Make reference and renders of many spp run: this machine, a local Dask cluster or a "
            "Dask scheduler's address"
        )
        self.cluster_button.clicked.connect(self.choose_cluster)
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setEnabled(False)
        self.mode.currentIndexChanged.connect(self._mode_changed)
        self.start_button.clicked.connect(self.start)
        self.cancel_button.clicked.connect(self.cancel)

        # Two rows, so that the panel's minimum width leaves the docks room (one row would be ~950 px wide).
        strategies, budget = QHBoxLayout(), QHBoxLayout()
        for row, label, w in (
            (strategies, "A", self.strategy_a), (strategies, "B", self.strategy_b), (budget, "", self.mode),
            (budget, "", self.spp), (budget, "", self.seconds), (budget, "size", self.width_box),
            (budget, "x", self.height_box),
        ):  # fmt: skip
            if label:
                row.addWidget(QLabel(label))
            row.addWidget(w)
        # Render and Cancel beside the strategies, the other buttons beside the budget: two rows of about the
        # same width, neither wider than the Sampling tab's.
        buttons = (self.start_button, self.cancel_button, self.reference_button, self.cluster_button)
        for i, b in enumerate(buttons):
            (strategies if i < 2 else budget).addWidget(b)
        for row in (strategies, budget):
            row.addStretch(1)
        controls = QVBoxLayout()
        controls.addLayout(strategies)
        controls.addLayout(budget)

        self.view_a = ImageView()
        self.view_b = ImageView()
        self.view_a.link(self.view_b)
        # Two lines each (samples and time; speed and error), of a size that does not depend on the text: a
        # new text every frame repaints the line only, instead of a relayout and repaint of the whole window
        # (tens of ms per frame on the GUI thread).
        self.counter_a = StatusLine(2)
        self.counter_b = StatusLine(2)
        images = QWidget()
        grid = QGridLayout(images)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.addWidget(self.view_a, 0, 0)
        grid.addWidget(self.view_b, 0, 1)
        grid.addWidget(self.counter_a, 1, 0)
        grid.addWidget(self.counter_b, 1, 1)
        self.error_plot = ErrorPlot()
        self.status = QLabel("Set up the scene, then Render. Renders use the Scene tab's camera.")
        self.status.setWordWrap(True)
        self.status.setMinimumHeight(2 * self.status.fontMetrics().lineSpacing())  # see ErrorPlot's status
        split = QSplitter()
        split.setOrientation(split.orientation().Vertical)
        split.addWidget(images)
        split.addWidget(self.error_plot)
        split.setSizes([500, 180])
        layout = QVBoxLayout(self)
        layout.addLayout(controls)
        layout.addWidget(split, 1)
        layout.addWidget(self.status)
        self._mode_changed()
        self._plot_errors()

    # ---- control ---------------------------------------------------------------------------------------
    def _mode_changed(self) -> None:
        spp = self.mode.currentData() == "spp"
        self.spp.setVisible(spp)
        self.seconds.setVisible(not spp)

    def strategies(self) -> list[str]:
        names = [self.strategy_a.currentText()]
        b = self.strategy_b.currentText()
        if b and b != "(none)" and b != names[0]:
            names.append(b)
        return names

    @property
    def running(self) -> bool:
        return self.job is not None

    def request(self, scene: Scene) -> dict:
        """The job sent to the render process for ``scene`` with the panel's settings."""
        from app.model_library import model_texts
        from core.scene import scene_to_dict

        mode = self.mode.currentData()
        return {
            "scene": scene_to_dict(scene),
            "model_texts": model_texts(scene),
            "base_dir": str(scene.base_dir),
            "source": scene.source,
            "strategies": self.strategies(),
            "mode": mode,
            "budget": self.spp.value() if mode == "spp" else self.seconds.value(),
            "width": self.width_box.value(),
            "height": self.height_box.value(),
            "seed": 0,
            "reference": self.reference,
            "cluster": cluster_setting().for_job() if self._long(mode) else None,
        }

    def _long(self, mode: str) -> bool:
        """Whether the render set up is long enough for the render cluster (:data:`LONG_RENDER_SPP`)."""
        return mode == "spp" and self.spp.value() >= LONG_RENDER_SPP

    def choose_cluster(self) -> None:
        """Ask where Make reference and long renders run, and keep the answer."""
        from app.settings import set_cluster_setting
        from app.views.cluster_dialog import ClusterDialog

        dialog = ClusterDialog(cluster_setting(), self)
        if dialog.exec() == ClusterDialog.DialogCode.Accepted:
            chosen = dialog.setting()
            set_cluster_setting(chosen)
            self.set_status(
                f"Make reference and renders of {LONG_RENDER_SPP} spp or more run on {chosen.describe()}."
            )

    def start(self) -> None:
        """Start a render (cancelling a running one first: Render while rendering restarts)."""
        self.cancel()
        try:
            scene = self.scene_provider()
            self._check_reference(scene)
            job = self.request(scene)
            check_request(job["mode"], job["budget"], job["width"], job["height"], job["reference"])
        except BrdfStudioError as exc:
            self.error.emit(str(exc))
            return
        self.frames.clear()
        self._frames_due.clear()
        self.curves = {name: [] for name in job["strategies"]}
        # the time axis sized for the whole render from the start when it is known (equal time): no full
        # figure draw half-way because a frame passed the axis' end
        self.error_plot.horizon = float(job["budget"]) if job["mode"] == "time" else None
        self._plot_errors()
        self.start_button.setText("Restart")
        self.cancel_button.setEnabled(True)
        starting = "Starting the render process ..." if self.server.pid is None else "Starting ..."
        self.set_status(f"{self.reference_note} {starting}".strip())
        self.job = self.server.submit(job)
        if self.reference_runner.running:
            self.reference_runner.pause()  # an equal-time comparison must not share the CPU with it

    def cancel(self) -> None:
        """Stop the running render (returns at once; the UI never waits, and draws nothing more of it)."""
        if self.job is not None:
            self.server.cancel(self.job)
            self.set_status("Cancelled.")
            self.job = None
            self.reference_runner.resume()
        self.cancel_button.setEnabled(False)
        self.start_button.setText("Render")

    def set_status(self, text: str) -> None:
        self.status_text = text
        self.status.setText(text)

    def showEvent(self, event) -> None:  # noqa: N802
        super().showEvent(event)
        self.server.ensure_started()  # warm up the render process while the user sets up the render

    def _on_events(self, events: list[dict]) -> None:
        """A batch from the render process: every frame counts in the curves, only the last one of each
        strategy is drawn (frames of small images can come faster than they are worth drawing)."""
        latest: dict[str, dict] = {}
        ended = False
        for event in events:
            kind = event["kind"]
            if kind == "crashed":
                if self.job is not None:
                    ended = True
                    self._failed(event["text"])
                else:
                    self.set_status(event["text"].replace("Render again", "the next render starts"))
                continue
            if event["job"] != self.job or self.job is None:
                continue  # a cancelled render's last events
            if kind == "status":
                self.set_status(event["text"])
            elif kind == "frame":
                name = event["strategy"]
                self.frames[name] = event
                self.curves.setdefault(name, []).append(
                    {k: event[k] for k in ("spp", "seconds", "rmse", "relmse")}
                )
                latest[name] = event
                if "cluster" in event and self.status_text != f"Rendering on {event['cluster']}":
                    self.set_status(f"Rendering on {event['cluster']}")
            elif kind in ("done", "error", "cancelled"):
                ended = True
                if kind == "done":
                    self._finished()
                    self.set_status("Done. " + self._summary())
                elif kind == "error":
                    self._failed(event["text"])
                else:
                    self._finished()
        self._frames_due.update(latest)
        first = any(len(self.curves.get(name, ())) == 1 for name in latest)
        if ended or first:
            self._show_due_frames()  # a strategy's first and last images at once (the user waits for them)
        elif latest and not self._frame_timer.isActive():
            self._frame_timer.start()
        if latest or ended:
            self._plot_soon(immediately=ended)

    def _failed(self, message: str) -> None:
        self._finished()
        self.set_status(f"Render failed: {message}")
        self.error.emit(message)

    def _finished(self) -> None:
        self.job = None
        self.reference_runner.resume()
        self.cancel_button.setEnabled(False)
        self.start_button.setText("Render")

    def _show_due_frames(self) -> None:
        self._frame_timer.stop()
        due, self._frames_due = self._frames_due, {}
        for event in due.values():
            if event["strategy"] in self.curves:  # of the render in progress (not one started since)
                self._show_frame(event)
        if self._plot_due and time.monotonic() - self._plotted_at >= PLOT_INTERVAL_MS / 1e3:
            self._plot_errors()

    def _plot_soon(self, immediately: bool = False) -> None:
        """Redraw the error plot with the next images, at most every ``PLOT_INTERVAL_MS`` while rendering (in
        the same event-loop turn as the images: one window flush for both)."""
        self._plot_due = True
        if immediately:
            self._plot_errors()

    def _show_frame(self, event: dict) -> None:
        from renderer.image_io import tonemap

        name = event["strategy"]
        names = list(self.curves)  # the strategies of the render in progress, in order
        view, counter = (self.view_a, self.counter_a) if name == names[0] else (self.view_b, self.counter_b)
        view.set_image(tonemap(event["image"]))
        rate = event["rays"] / event["seconds"] / 1e6 if event["seconds"] > 0 else 0.0
        err = f"RMSE {event['rmse']:.4g}" if math.isfinite(event["rmse"]) else "RMSE: no reference"
        counter.setText(
            f"<b>{name}</b>: {event['spp']} spp, {event['seconds']:.2f} s<br>{rate:.2f} Mrays/s, {err}"
        )

    def _summary(self) -> str:
        return "; ".join(f"{n}: {f['spp']} spp in {f['seconds']:.2f} s" for n, f in self.frames.items())

    def _plot_errors(self) -> None:
        self._plot_due = False
        self._plotted_at = time.monotonic()
        self.error_plot.show_curves(self.curves)

    # ---- reference and exports --------------------------------------------------------------------------
    def make_reference(self) -> None:
        """Render the current scene's reference in the background (resuming a stored one)."""
        try:
            scene = self.scene_provider()
        except BrdfStudioError as exc:
            self.error.emit(str(exc))
            return
        self.reference_runner.start(
            scene, self.width_box.value(), self.height_box.value(), self.project_provider()
        )

    def _reference_progressed(self, ref: Reference) -> None:
        self.reference, self.reference_key = ref.image, ref.key

    def _check_reference(self, scene: Scene) -> None:
        """Before a render: a reference made in the app for another scene (or size) is not used; one stored
        for this scene and size (made earlier, or before an undo) is."""
        self.reference_note = ""
        if self.reference is not None and self.reference_key is None:
            return  # loaded from a file: the user's choice
        width, height = self.width_box.value(), self.height_box.value()
        key = scene_key(scene, width, height)
        if key == self.reference_key:
            return
        stored = self.reference_runner.find(scene, width, height, self.project_provider())
        if stored is not None:
            self.reference, self.reference_key = stored.image, stored.key
            self.reference_note = f"Using the stored reference of this scene ({stored.spp} spp)."
        elif self.reference is not None:
            self.reference, self.reference_key = None, None
            self.reference_note = (
                "The reference is of another scene or size: errors are not measured (Make reference)."
            )

    def scene_changed(self) -> None:
        """The document's scene changed: a reference being made for the old one stops."""
        if self.reference_runner.wanted:
            self.reference_runner.stop(
                "Reference stopped: the scene changed (what was rendered stays stored)."
            )

    def load_reference(self, path: str | Path) -> None:
        from renderer.image_io import read_exr

        image = read_exr(path)
        self.reference, self.reference_key = image, None
        self.height_box.setValue(image.shape[0])
        self.width_box.setValue(image.shape[1])
        self.set_status(f"Reference {Path(path).name} ({image.shape[1]}x{image.shape[0]}) loaded.")

    def export(self, kind: str, path: str | Path) -> list[Path]:
        """Write ``exr`` / ``png`` (one file per strategy, ``<stem>_<strategy>``), ``composite`` (one PNG)
        or ``errors`` (``<stem>.csv`` and ``<stem>.png``). Returns the files written."""
        from renderer.image_io import composite, write_error_curves, write_exr, write_png

        if not self.frames:
            raise OutputError("nothing to export yet: render first")
        path = Path(path)
        out: list[Path] = []
        if kind in ("exr", "png"):
            for name, frame in self.frames.items():
                target = path.with_name(f"{path.stem}_{name}.{kind}")
                if kind == "exr":
                    write_exr(target, frame["image"], {"strategy": name, "spp": frame["spp"]})
                else:
                    write_png(target, frame["image"])
                out.append(target)
        elif kind == "composite":
            names = list(self.frames)
            labels = [f"{n} {self.frames[n]['spp']} spp {self.frames[n]['seconds']:.1f} s" for n in names]
            target = path.with_suffix(".png")
            write_png(target, composite([self.frames[n]["image"] for n in names], labels))
            out.append(target)
        elif kind == "errors":
            out += list(write_error_curves(path.with_suffix(""), self.curves, title="RMSE vs time"))
        else:
            raise OutputError(f"unknown export kind '{kind}'")
        self.set_status("Exported " + ", ".join(p.name for p in out))
        return out
