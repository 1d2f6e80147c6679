"""Bundled demo materials: ``materials.json`` lists them (an analytic model with parameters, or a synthetic
MERL table shipped beside it). Plain data only; ``core`` builds BRDFs from it."""

from __future__ import annotations

import json
from importlib import resources as _resources
from pathlib import Path
from typing import Any


def material_path(filename: str) -> Path:
    """Path of a file shipped in this folder (e.g. a ``.binary`` MERL table)."""
    return Path(str(_resources.files(__name__).joinpath(filename)))


def demo_materials() -> list[dict[str, Any]]:
    """The demo materials, each ``{"name", "model", "params"}`` or ``{"name", "measured": path}`` (absolute)."""
    data = json.loads(_resources.files(__name__).joinpath("materials.json").read_text("utf-8"))
    out = []
    for entry in data["materials"]:
        entry = dict(entry)
        if "measured" in entry:
            entry["measured"] = str(material_path(entry["measured"]))
        out.append(entry)
    return out
