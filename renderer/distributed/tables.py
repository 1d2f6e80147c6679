"""Sampler tables built once, on the client, and sent to the workers through their table caches.

A strategy with tables in the table cache (:mod:`core.cache`; the adaptive modes) has each material's table
built, or loaded, by the client (:func:`build_tables`); the cache's files of those tables travel to every
worker as bytes and are written into the worker's own table cache (:func:`install_tables`) before it prepares
the scene, where the sampler then finds them. Every worker thus draws from the very table the client built,
and no worker builds one. A strategy whose tables stay in memory (the tabulated CDFs, the factored sampler)
builds them on each worker, once: the worker keeps the prepared render for every later block
(:mod:`renderer.distributed.worker`). So does a worker whose table cache cannot be written.
"""

from __future__ import annotations

import contextlib
import hashlib
from pathlib import Path
from typing import Any

from core.cache import TableCache
from core.errors import BrdfStudioError
from core.io import atomic_write_bytes
from core.scene import Scene
from renderer.world import StepCallback, bind_sampler, load_brdf


def used_materials(scene: Scene) -> list[int]:
    """Indices of the materials the scene's meshes use (a material no mesh names needs no table)."""
    names = {m.material for m in scene.meshes} | {v for m in scene.meshes for v in m.group_materials.values()}
    return [i for i, m in enumerate(scene.materials) if m.name in names]


def _cache_files(sampler: Any) -> dict[str, bytes]:
    """The table-cache files of ``sampler``'s table (paths relative to the cache folder); none for a
    strategy without a cache (its ``cache`` and ``key``)."""
    cache, key = getattr(sampler, "cache", None), getattr(sampler, "key", None)
    if not isinstance(cache, TableCache) or not isinstance(key, str):
        return {}
    out = {}
    for name in cache.names(key):
        path = cache.path(key, name)
        with contextlib.suppress(OSError):
            out[str(path.relative_to(cache.folder))] = path.read_bytes()
    return out


def build_tables(
    scene: Scene,
    sampler: str,
    options: dict[str, Any],
    material_samplers: dict[str, str] | None = None,
    on_step: StepCallback | None = None,
) -> tuple[dict[str, bytes], dict[str, dict[str, Any]]]:
    """Each used material's sampler made here, its table built or loaded (reported through ``on_step``).
    Returns the table-cache files to send (relative path -> bytes) and, per material, what its sampler
    reports (``info()``: model, strategy, memory, build time, a note when the strategy fell back)."""
    files: dict[str, bytes] = {}
    report: dict[str, dict[str, Any]] = {}
    used = used_materials(scene)
    overrides = material_samplers or {}
    for k, i in enumerate(used):
        mat = scene.materials[i]
        if on_step:
            on_step(f"tables for '{mat.name}'", k, len(used))
        brdf = load_brdf(scene, i, mat)
        if mat.name in overrides:
            made, name, note = bind_sampler(brdf, overrides[mat.name], {})
        else:
            made, name, note = bind_sampler(brdf, sampler, options)
        made.preload()
        files.update(_cache_files(made))
        info = dict(made.info())
        info.update(model=brdf.name, sampler=name)
        if note:
            info["note"] = note
        report[mat.name] = info
    if on_step:
        on_step("tables ready", len(used), len(used))
    return files, report


_INSTALLED: set[tuple[Path, str]] = set()
"""Table files (path, digest) this process wrote or found in its cache."""


def install_tables(files: dict[str, bytes], folder: Path | None = None) -> int:
    """Write the client's table-cache files into this machine's table cache (``folder``, default the
    cache's own) where they are not there already; returns how many were written. A cache that cannot be
    written is skipped (the worker then builds those tables itself)."""
    cache = TableCache(folder)
    written = 0
    for rel, raw in files.items():
        digest = hashlib.sha256(raw).hexdigest()
        target = cache.folder / rel
        if (target, digest) in _INSTALLED:
            continue
        try:
            same = target.is_file() and hashlib.sha256(target.read_bytes()).hexdigest() == digest
            if not same:
                target.parent.mkdir(parents=True, exist_ok=True)
                atomic_write_bytes(target, raw, durable=False)  # checksummed entries: a torn one is rebuilt
                written += 1
        except (OSError, BrdfStudioError):
            continue
        _INSTALLED.add((target, digest))
    return written
