"""*Make reference* in the background: chunks of the reference render sent to a render process of its own,
merged into the stored reference as each one ends (:mod:`app.reference`), until :data:`app.reference.TARGET_SPP`.

The runner pauses while the render panel's comparison renders (both would share the CPU, and an equal-time
comparison must not), and resumes after it; stopping loses at most the chunk in progress. A change of the
scene stops it: the chunks rendered so far stay stored under the old scene's key and are used again if the
scene comes back to it (undo).

With a cluster set (:func:`app.settings.cluster_setting`: a local Dask cluster or a scheduler's address), the
chunks render there (:mod:`renderer.distributed`) and the status line shows the cluster's workers and tasks.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QObject, Signal

from app import reference as ref_files
from app.model_library import model_texts
from app.reference import SAMPLER, Reference, ReferenceStore, location, scene_key
from app.render_process import RenderServer
from app.settings import cluster_setting
from core.scene import Scene, scene_to_dict

CLUSTER_CHUNK_SPP = 512
"""Samples per pixel of a chunk rendered on a Dask cluster (:class:`app.settings.ClusterSetting`): a chunk,
with its own seed, is a render every worker prepares anew (geometry, tables read), so chunks are longer there
than here (:data:`app.reference.CHUNK_SPP`)."""
SEED_BASE = 1_000_003
"""Chunk ``k`` renders with seed ``SEED_BASE + k`` (never the comparison's seed 0: a reference that shares
the comparison's random numbers would flatter it)."""


class ReferenceRunner(QObject):
    """Signals: ``progressed(Reference)`` after every chunk, ``status(str)`` for the panel's status line."""

    progressed = Signal(object)
    status = Signal(str)

    def __init__(self, parent: QObject | None = None):
        super().__init__(parent)
        self.server = RenderServer(parent=self)
        self.server.events_received.connect(self._on_events)
        self.reference: Reference | None = None
        self.store: ReferenceStore | None = None
        self.scene: Scene | None = None
        self.size = (0, 0)
        self.job: int | None = None
        self.paused = False
        self.wanted = False
        """Make reference was asked and the target is not reached yet."""

    @property
    def running(self) -> bool:
        return self.job is not None

    def find(self, scene: Scene, width: int, height: int, project: Path | None) -> Reference | None:
        """The stored reference of this scene and size, if any (made earlier, in this session or another)."""
        store = ReferenceStore(location(project))
        return store.load(scene_key(scene, width, height))

    def start(self, scene: Scene, width: int, height: int, project: Path | None) -> None:
        """Make (or resume making) the reference of ``scene`` at this size."""
        self.stop()
        self.scene, self.size = scene, (width, height)
        self.store = ReferenceStore(location(project))
        key = scene_key(scene, width, height)
        self.reference = self.store.load(key)
        self.wanted = True
        if self.reference is not None and self.reference.done:
            self.wanted = False
            self.status.emit(f"Reference ready: {self.reference.spp} spp (stored {self.store.exr.name}).")
            self.progressed.emit(self.reference)
            return
        self._next_chunk()

    def _next_chunk(self) -> None:
        if self.scene is None or self.paused or not self.wanted:
            return
        chunk = self.reference.chunks if self.reference is not None else 0
        width, height = self.size
        cluster = cluster_setting().for_job()  # where it runs: read at each chunk, so a change applies next
        budget = ref_files.CHUNK_SPP if cluster is None else CLUSTER_CHUNK_SPP
        self.job = self.server.submit({
            "scene": scene_to_dict(self.scene), "base_dir": str(self.scene.base_dir), "source": self.scene.source,
            "model_texts": model_texts(self.scene), "strategies": [SAMPLER], "mode": "spp", "budget": budget, "width": width, "height": height,
            "seed": SEED_BASE + chunk, "reference": None, "cluster": cluster,
        })  # fmt: skip
        done = self.reference.spp if self.reference is not None else 0
        self.status.emit(f"Making the reference: {done} of {ref_files.TARGET_SPP} spp ...")

    def _on_events(self, events: list[dict]) -> None:
        for event in events:
            if event.get("job") != self.job or self.job is None:
                if event["kind"] == "crashed" and self.job is not None:
                    self.job = None
                    self.status.emit(f"Reference stopped: {event['text']}")
                continue
            kind = event["kind"]
            if kind == "frame":
                self._last_frame = event
                if "cluster" in event:  # rendered on a cluster: its state with the progress
                    done = (self.reference.spp if self.reference is not None else 0) + event["spp"]
                    self.status.emit(
                        f"Making the reference: {done} of {ref_files.TARGET_SPP} spp on {event['cluster']} ..."
                    )
            elif kind == "status" and event["text"].startswith(("Connecting", "Rendering on")):
                self.status.emit(event["text"])
            elif kind == "done":
                self.job = None
                frame = self._last_frame
                assert self.store is not None and self.scene is not None
                key = scene_key(self.scene, *self.size)
                self.reference = self.store.add(
                    self.reference, key, frame["image"], frame["spp"], frame["seconds"]
                )
                self.progressed.emit(self.reference)
                if self.reference.done:
                    self.wanted = False
                    self.status.emit(
                        f"Reference done: {self.reference.spp} spp in {self.reference.seconds:.0f} s."
                    )
                else:
                    self._next_chunk()
            elif kind in ("error", "cancelled"):
                self.job = None
                if kind == "error":
                    self.wanted = False
                    self.status.emit(f"Reference failed: {event['text']}")

    def pause(self) -> None:
        """Stop the chunk in progress (it is lost) until :meth:`resume`."""
        self.paused = True
        if self.job is not None:
            self.server.cancel(self.job)
            self.job = None

    def resume(self) -> None:
        self.paused = False
        if self.wanted and self.job is None:
            self._next_chunk()

    def stop(self, reason: str = "") -> None:
        """Stop making the reference (what is stored stays)."""
        was = self.wanted
        self.wanted = False
        if self.job is not None:
            self.server.cancel(self.job)
            self.job = None
        if was and reason:
            self.status.emit(reason)

    def shutdown(self) -> None:
        self.stop()
        self.server.stop()
