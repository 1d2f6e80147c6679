"""The render panel's reference image and what it measures, without Qt.

*Make reference* renders the current scene for a long time in chunks of :data:`CHUNK_SPP` samples per pixel,
each chunk with its own seed; the stored reference is the mean of the chunks weighted by their samples, so
rendering can stop after any chunk and resume later (another session, even) where it stopped. It is stored
beside the project (``<project>.reference.exr`` with ``<project>.reference.json``; an unsaved project's, or
a bundled scene's, in the config folder) under a key of the scene: its geometry, materials, lights, camera and path length, and the
image size. A reference whose key is not the current scene's is out of date and is not used.

:func:`equal_time_verdict` puts the comparison of two error curves in words.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from core.io import atomic_write_text
from core.scene import Scene, scene_to_dict

CHUNK_SPP = 64
"""Samples per pixel of one chunk (what is lost at most when the reference render is stopped)."""
TARGET_SPP = 4096
"""When the reference is done."""
SAMPLER = "adaptive_warp"
"""The reference's sampling strategy (any unbiased one converges to the same image; the renderer's default
has the lowest error at equal time on the demo scene, docs/renderer.md)."""


def scene_key(scene: Scene, width: int, height: int) -> str:
    """What a reference is of: the scene as rendered (not how: sampler, budget and seed are left out), the
    image size, and the content in use of its model files (a file saved anew is another scene)."""
    from app.model_library import model_texts

    data = scene_to_dict(scene)
    render = data.pop("render")
    data["render"] = {"max_depth": render["max_depth"], "rr_depth": render["rr_depth"]}
    data["size"] = [int(width), int(height)]
    texts = model_texts(scene)
    if texts:  # (absent otherwise: the keys of scenes of built-in models stay as they were)
        data["model_files"] = {p: hashlib.sha256(t.encode("utf-8")).hexdigest() for p, t in texts.items()}
    text = json.dumps(data, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def location(project: Path | None) -> Path:
    """The stem of a project's reference files: beside the project; in the config folder for an unsaved
    project or one of the bundled scenes (the package's files are not the user's to write)."""
    from importlib.resources import files

    bundled = Path(str(files("resources"))).resolve()
    if project is not None and not Path(project).resolve().is_relative_to(bundled):
        return Path(project).with_suffix("")
    from app.settings import config_dir

    folder = config_dir() / "references"
    folder.mkdir(parents=True, exist_ok=True)
    return folder / (Path(project).stem if project is not None else "untitled")


@dataclass
class Reference:
    key: str
    image: np.ndarray
    """``(height, width, 3)`` float32: the mean of the chunks."""
    spp: int
    seconds: float
    chunks: int

    @property
    def done(self) -> bool:
        return self.spp >= TARGET_SPP


class ReferenceStore:
    """The reference files of one project stem (``<stem>.reference.exr`` / ``.json``)."""

    def __init__(self, stem: Path):
        self.exr = stem.with_name(stem.name + ".reference.exr")
        self.meta = stem.with_name(stem.name + ".reference.json")

    def load(self, key: str) -> Reference | None:
        """The stored reference of ``key``, or ``None`` (none stored, another scene's, or unreadable)."""
        from renderer.image_io import read_exr

        try:
            meta = json.loads(self.meta.read_text(encoding="utf-8"))
            if meta.get("key") != key:
                return None
            image = read_exr(self.exr)
        except (OSError, ValueError, KeyError):
            return None
        except Exception:  # noqa: BLE001  (a damaged EXR: start again rather than fail)
            return None
        return Reference(key, image, int(meta["spp"]), float(meta["seconds"]), int(meta["chunks"]))

    def add(
        self, previous: Reference | None, key: str, image: np.ndarray, spp: int, seconds: float
    ) -> Reference:
        """Merge a chunk into ``previous`` (``None``: the first chunk) and write both files, each atomically:
        the image, then the metadata naming its total (a crash between the two costs one chunk's weight)."""
        from renderer.image_io import write_exr

        if previous is None or previous.key != key:
            ref = Reference(key, image.astype(np.float32), spp, seconds, 1)
        else:
            total = previous.spp + spp
            mean = (previous.image * previous.spp + image * spp) / total
            ref = Reference(
                key, mean.astype(np.float32), total, previous.seconds + seconds, previous.chunks + 1
            )
        write_exr(self.exr, ref.image, {"reference_key": key, "spp": ref.spp})
        atomic_write_text(self.meta, json.dumps(
            {"key": key, "spp": ref.spp, "seconds": ref.seconds, "chunks": ref.chunks, "sampler": SAMPLER}, indent=1
        ))  # fmt: skip
        return ref


# ---- the comparison in words --------------------------------------------------------------------------------


def time_to_reach(curve: list[dict[str, Any]], target: float, metric: str = "rmse") -> float | None:
    """The render time at which ``curve`` (records with ``seconds`` and ``metric``) first reaches ``target``,
    interpolated log-log between the two records around it; ``None`` if it never does."""
    points = [(r["seconds"], r[metric]) for r in curve if math.isfinite(r[metric]) and r["seconds"] > 0]
    for i, (t, e) in enumerate(points):
        if e <= target:
            if i == 0 or e == target:
                return t
            t0, e0 = points[i - 1]
            if e0 <= 0 or e <= 0 or e0 == e:
                return t
            f = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0)))
    return None


def _fraction(x: float) -> str:
    return f"1/{1 / x:.3g}" if x < 1 else f"{x:.3g}x"


def equal_time_verdict(curves: dict[str, list[dict[str, Any]]], metric: str = "rmse") -> str:
    """One sentence comparing two strategies' error curves: which reaches the other's final error, and in
    what fraction of the time (``"adaptive reaches uniform's final RMSE in 1/7 of the time"``); empty when
    there is nothing to compare yet."""
    names = [n for n, c in curves.items() if any(math.isfinite(r[metric]) for r in c)]
    if len(names) != 2:
        return ""
    a, b = names
    final = {n: [r for r in curves[n] if math.isfinite(r[metric])][-1] for n in names}
    label = "RMSE" if metric == "rmse" else "relMSE"
    # the strategy with the lower final error at (about) the same time is the better one
    better, worse = (a, b) if final[a][metric] <= final[b][metric] else (b, a)
    t = time_to_reach(curves[better], final[worse][metric], metric)
    if t is None or final[worse]["seconds"] <= 0:
        return f"{better} ends with the lower {label} ({final[better][metric]:.3g} vs {final[worse][metric]:.3g})"
    ratio = t / final[worse]["seconds"]
    if 0.9 <= ratio <= 1.1:
        return f"{better} and {worse} reach the same {label} in about the same time"
    return f"{better} reaches {worse}'s final {label} in {_fraction(ratio)} of the time"
