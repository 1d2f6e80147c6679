"""numba's stored compiles are stamped by their import closure (core/_numba_cache.py): an edit of a file a
function can see must make it stale, an edit elsewhere must not; stored adaptive tables follow the sources
that can change them."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numba

from core import _numba_cache as nc


def _tree(root: Path) -> None:
    (root / "core" / "models").mkdir(parents=True)
    (root / "renderer").mkdir()
    (root / "core" / "__init__.py").write_text("")
    (root / "core" / "models" / "__init__.py").write_text("import core.models.model\n")
    (root / "core" / "models" / "_helper.py").write_text("def h(x):\n    return x\n")
    (root / "core" / "models" / "model.py").write_text(
        "from core.models._helper import h\n\ndef f():\n    from core.lazy import z  # not a dependency\n"
    )
    (root / "core" / "lazy.py").write_text("z = 1\n")
    (root / "core" / "other.py").write_text("from core import models\nK = 1\n")
    (root / "renderer" / "kernels.py").write_text("from core.models import model\n")


def _closure(root: Path, rel: str) -> list[str]:
    return [str(p.relative_to(root)) for p in nc.import_closure(root / rel, root)]


def test_the_closure_holds_what_a_module_imports_when_imported(tmp_path):
    _tree(tmp_path)
    assert _closure(tmp_path, "core/models/model.py") == ["core/models/_helper.py", "core/models/model.py"]
    # "from package import module" imports the module; a package's own __init__ is not followed
    assert "core/models/__init__.py" in _closure(tmp_path, "core/other.py")
    assert "core/models/model.py" in _closure(tmp_path, "core/other.py")
    assert _closure(tmp_path, "renderer/kernels.py") == [
        "core/models/__init__.py", "core/models/_helper.py", "core/models/model.py", "renderer/kernels.py"
    ]  # fmt: skip


def test_an_edit_reaches_the_functions_that_can_see_it_and_no_others(tmp_path):
    _tree(tmp_path)
    files = ("core/models/model.py", "renderer/kernels.py", "core/lazy.py")

    def stamps() -> dict[str, str]:
        out = {}
        for rel in files:
            h = "".join((tmp_path / p).read_text() for p in _closure(tmp_path, rel))
            out[rel] = h
        return out

    before = stamps()
    (tmp_path / "core" / "models" / "_helper.py").write_text("def h(x):\n    return 2 * x\n")
    after = stamps()
    assert after["core/models/model.py"] != before["core/models/model.py"]
    assert after["renderer/kernels.py"] != before["renderer/kernels.py"]  # through model.py
    assert after["core/lazy.py"] == before["core/lazy.py"]


def test_numba_caches_our_functions_with_the_closure_locator():
    folder = nc.configure()
    assert folder is not None
    assert Path(numba.config.CACHE_DIR) == folder
    from numba.core import caching

    # ours come before numba's own (the model files' locator, which takes only their modules, may lead)
    names = [c.__name__ for c in caching.CacheImpl._locator_classes]
    assert "ClosureLocator" in names and names.index("ClosureLocator") < names.index(
        "UserProvidedCacheLocator"
    )
    stamp = nc.closure_hash(str(nc.ROOT / "core" / "dispatch.py"))
    assert stamp == nc.closure_hash(str(nc.ROOT / "core" / "dispatch.py"))  # read once, stable


def test_stored_tables_are_keyed_by_the_model_file_and_the_sampler_package(monkeypatch):
    from core.brdf import make_brdf
    from core.sampling.adaptive import store
    from core.sampling.adaptive.records import TableOptions
    from core.sampling.adaptive.store import table_cache_key

    ggx, phong = make_brdf("ggx"), make_brdf("phong")
    key = table_cache_key(ggx, TableOptions())
    assert key == table_cache_key(ggx, TableOptions())
    assert key != table_cache_key(ggx, TableOptions(n_max=3.0))
    assert key != table_cache_key(make_brdf("ggx", {"alpha": 0.1}), TableOptions())
    files = store.source_files(ggx)
    names = {p.name for p in files}
    assert {"ggx.py", "_fresnel.py", "dispatch.py", "draw.py", "table.py"} <= names
    assert {"grow.py", "bounds.py", "probe.py"} <= {p.name for p in files if p.parent.name == "tree"}
    assert "phong.py" not in names and "integrator.py" not in names
    assert "phong.py" in {p.name for p in store.source_files(phong)}
    # a model that is a package of its own: every file of the package (RGL's lookup reads its marginals)
    from types import SimpleNamespace

    from core.rgl.material import RGL

    rgl = {p.name for p in store.source_files(SimpleNamespace(model=RGL))}  # type: ignore[arg-type]
    assert {"lookup.py", "marginal.py", "tensor_file.py"} <= rgl and "ggx.py" not in rgl


def test_a_module_s_npz_data_file_is_part_of_its_stamp(monkeypatch):
    """Tables a module reads at import (``core/models/_he_series.npz``) are frozen into its kernels: a module's
    ``.npz`` of the same name is hashed with it, so a regenerated file makes its compiles stale."""
    hashed: list[Path] = []

    def file_hash(path: Path) -> bytes:
        hashed.append(path)
        return path.name.encode()

    monkeypatch.setattr(nc, "_file_hash", file_hash)
    nc.closure_hash.__wrapped__(str(nc.ROOT / "core" / "models" / "he.py"))
    he_series = nc.ROOT / "core" / "models" / "_he_series.py"
    assert he_series in hashed
    assert hashed[hashed.index(he_series) + 1] == he_series.with_suffix(".npz")
    assert he_series.with_suffix(".npz").is_file()
    assert [p for p in hashed if p.suffix == ".npz"] == [he_series.with_suffix(".npz")]


_PROBE = "import numba\n\n\n@numba.njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n"
_CALL = (
    "import core._probe as p; p.twice(1.5); s = p.twice.stats; "
    "print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))"
)


def _copy_core(dst: Path) -> None:
    shutil.copytree(nc.ROOT / "core", dst / "core", ignore=shutil.ignore_patterns("__pycache__", "_kernels"))
    (dst / "core" / "_probe.py").write_text(_PROBE)


def _hits_and_misses(tree: Path, cache: Path) -> tuple[int, int]:
    env = {**os.environ, "PYTHONPATH": str(tree), "BRDF_STUDIO_NUMBA_CACHE": str(cache)}
    done = subprocess.run(
        [sys.executable, "-c", _CALL], cwd=tree, env=env, capture_output=True, text=True, check=True
    )
    hits, misses = done.stdout.split()
    return int(hits), int(misses)


def test_a_compile_stored_by_one_copy_of_the_sources_serves_another_and_a_wheel_seeds_it(tmp_path):
    """The cache's folders are named by the sources' place in the packages, not their absolute path: a copy
    of the same bytes elsewhere (another clone, an installed wheel) loads what the first copy compiled. A
    wheel's kernels (``core/_kernels`` with its ``BUILD_ID``, as core/_wheel_kernels.py builds them) seed an
    empty user cache once, and the installed copy then loads instead of compiling."""
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    _copy_core(a)
    cache = tmp_path / "cache"
    assert _hits_and_misses(a, cache) == (0, 1)
    assert (cache / "core" / "_probe.py").parent.is_dir()  # core/, not core_<hash of a's path>
    shutil.copytree(a, b)
    assert _hits_and_misses(b, cache) == (1, 0)
    # a wheel: compiled into the package's own core/_kernels, then installed elsewhere with an empty cache
    assert _hits_and_misses(a, a / "core" / "_kernels") == (0, 1)
    (a / "core" / "_kernels" / "BUILD_ID").write_text("b1\n")
    shutil.copytree(a, c, ignore=shutil.ignore_patterns("__pycache__"))
    user = tmp_path / "user"
    assert _hits_and_misses(c, user) == (1, 0)
    assert (user / ".seeded-b1").is_file()
    # an edit of the installed copy is a new source: compiled again, not served stale
    (c / "core" / "_probe.py").write_text(_PROBE.replace("2.0 * x", "3.0 * x"))
    assert _hits_and_misses(c, user) == (0, 1)


def test_seeding_copies_once_per_build_and_leaves_a_place_it_cannot_write_alone(tmp_path):
    prebuilt, user = tmp_path / "prebuilt", tmp_path / "user"
    (prebuilt / "core" / "models").mkdir(parents=True)
    (prebuilt / "core" / "models" / "f.py311.nbi").write_bytes(b"index")
    (prebuilt / "core" / "models" / "f.py311.1.nbc").write_bytes(b"data")
    assert nc.seed(user, prebuilt) == 0  # no BUILD_ID: not a wheel's kernels
    (prebuilt / "BUILD_ID").write_text("x1\n")
    user.mkdir()
    (user / "core" / "models").mkdir(parents=True)
    (user / "core" / "models" / "f.py311.nbi").write_bytes(b"older")
    assert nc.seed(user, prebuilt) == 2
    assert (user / "core" / "models" / "f.py311.nbi").read_bytes() == b"index"
    assert sorted(p.name for p in (user / "core" / "models").iterdir()) == ["f.py311.1.nbc", "f.py311.nbi"]
    assert nc.seed(user, prebuilt) == 0  # once per build
    (prebuilt / "BUILD_ID").write_text("x2\n")
    blocked = tmp_path / "a-file"
    blocked.write_text("not a folder")  # a cache folder under a file: nothing can be written, even by root
    assert nc.seed(blocked / "cache", prebuilt) == 0
    assert blocked.read_text() == "not a folder"
