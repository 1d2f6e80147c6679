"""numba's disk cache is keyed by the whole source tree (core/_numba_cache.py): an edit anywhere in the
compiled packages must lead to a new cache folder, never to a stale compile."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numba

from core import _numba_cache as nc


def _tree(root: Path) -> None:
    (root / "core" / "models").mkdir(parents=True)
    (root / "renderer").mkdir()
    (root / "core" / "models" / "_helper.py").write_text("def h(x):\n    return x\n")
    (root / "core" / "models" / "model.py").write_text("from core.models._helper import h\n")
    (root / "renderer" / "kernels.py").write_text("K = 1\n")


def test_numba_caches_in_the_folder_of_this_source_version():
    folder = nc.configure()
    assert folder is not None
    assert Path(numba.config.CACHE_DIR) == folder
    assert folder.name == nc.source_hash()


def test_an_edit_to_a_helper_in_another_file_changes_the_key(tmp_path):
    _tree(tmp_path)
    before = nc.tree_hash(tmp_path)
    assert nc.tree_hash(tmp_path) == before  # deterministic
    (tmp_path / "core" / "models" / "_helper.py").write_text("def h(x):\n    return 2 * x\n")
    edited = nc.tree_hash(tmp_path)
    assert edited != before
    (tmp_path / "renderer" / "kernels.py").write_text("K = 2\n")
    assert nc.tree_hash(tmp_path) not in (before, edited)
    (tmp_path / "renderer" / "new.py").write_text("")
    assert nc.tree_hash(tmp_path) != edited


def test_old_versions_are_pruned_but_the_current_one_kept(tmp_path):
    now = time.time()
    for k in range(7):
        d = tmp_path / f"v{k}"
        d.mkdir()
        os.utime(d, (now - 100 * k, now - 100 * k))
    current = tmp_path / "v6"  # the oldest by time, but in use
    nc._prune(tmp_path, current)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == ["v0", "v1", "v2", "v6"]
    assert len(left) == nc.KEEP


def test_stored_trees_are_keyed_by_every_core_source(monkeypatch):
    """The adaptive sampler's disk cache key follows the whole source hash (a model's ``eval`` or its
    Fresnel helper changes the trees), not only the quadtree files."""
    import core.quadtree_table as qt
    from core.model import make_brdf
    from core.quadtree import BuildOptions

    brdf = make_brdf("ggx")
    key = qt.QuadtreeTable(brdf.model, brdf.params, BuildOptions()).key
    monkeypatch.setattr(qt, "source_hash", lambda: "an edit of core/models/_fresnel.py")
    assert qt.QuadtreeTable(brdf.model, brdf.params, BuildOptions()).key != key
