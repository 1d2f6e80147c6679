"""A scene and the bytes of every file it names, for workers that do not share the client's filesystem.

The client reads each file the scene references once (:func:`bundle_scene`): the meshes, the measured
materials, the sky map, any other file a material names (a model file, say), and the files a glTF mesh
refers to (its buffers and images). Each is known by the SHA-256 of its bytes. A worker writes each file it
has not seen yet into a folder of its temporary directory named by that digest (:func:`materialize`),
points the scene's fields at those copies and reads the scene as usual, so the same content is written once
per machine, whichever scene or render names it. A file that did not arrive or arrived damaged is a
:class:`~core.scene.SceneError` that names the scene, the field and the file.
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
import tempfile
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any
from urllib.parse import unquote

from core.errors import BrdfStudioError
from core.io import atomic_write_bytes
from core.scene import Scene, SceneError, scene_from_dict, scene_to_dict

FILE_FIELDS = frozenset({"path", "measured"})
"""Fields that always name a file (a mesh, a measured material, the sky map): it must exist on the client."""
NAME_FIELDS = frozenset(
    {"name", "material", "group_materials", "exclude_groups", "notes", "tags", "type", "sampler", "mis"}
)
"""Fields whose strings are names, never files (a material called ``floor.obj`` stays a name)."""
ROOT_ENV = "BRDF_STUDIO_SCENE_FILES"
"""The folder workers write scene files into (default ``<temporary directory>/brdf-studio-scene-files``)."""


@dataclass(frozen=True)
class SceneFile:
    """One file a scene names: where (``location``, its JSON path; ``where``, as errors print it), the string
    the scene holds, its bytes' digest, and the files it refers to itself (``companions``: paths relative to
    it and their digests)."""

    location: tuple[str | int, ...]
    where: str
    written: str
    digest: str
    companions: tuple[tuple[str, str], ...] = ()

    @property
    def name(self) -> str:
        return Path(self.written).name

    @property
    def folder(self) -> str:
        """The folder a worker writes it into: its digest, or with companions the digest of all of them."""
        if not self.companions:
            return self.digest
        return _digest(json.dumps([self.digest, *self.companions]).encode())


@dataclass(frozen=True)
class SceneBundle:
    """What a worker needs to read a scene: its JSON form, the name errors give it, and its files (the bytes
    travel apart, by digest)."""

    data: dict[str, Any]
    source: str
    files: tuple[SceneFile, ...]
    key: str
    """A digest of the scene's JSON and of every file's bytes: same key, same scene."""

    @property
    def digests(self) -> list[str]:
        """Every file's digest (companions included), each once."""
        out = [f.digest for f in self.files] + [d for f in self.files for _, d in f.companions]
        return list(dict.fromkeys(out))


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


_FILE_DIGESTS: dict[tuple[str, int, int, int, int], str] = {}
"""Digests of files this process read, by path and stat (device, inode, size, modification time in ns): a
client that renders the same scene again hashes only the files that changed."""
_FILE_DIGESTS_MAX = 256


def _file_digest(path: Path, raw: bytes, stat: os.stat_result | None) -> str:
    """``raw``'s digest; looked up by ``stat`` (the file's before it was read) when the file is unchanged
    since (same stat after the read: a file written meanwhile is hashed)."""
    if stat is None:
        return _digest(raw)
    key = (os.path.abspath(path), stat.st_dev, stat.st_ino, stat.st_size, stat.st_mtime_ns)
    digest = _FILE_DIGESTS.get(key)
    if digest is None or len(raw) != stat.st_size:
        digest = _digest(raw)
        if len(raw) == stat.st_size:
            if len(_FILE_DIGESTS) >= _FILE_DIGESTS_MAX:
                _FILE_DIGESTS.pop(next(iter(_FILE_DIGESTS)))
            _FILE_DIGESTS[key] = digest
    return digest


def _strings(data: Any, location: tuple[str | int, ...] = ()) -> list[tuple[tuple[str | int, ...], str]]:
    """Every string of the scene's JSON with its location, but those of :data:`NAME_FIELDS`."""
    out: list[tuple[tuple[str | int, ...], str]] = []
    if isinstance(data, dict):
        for k, v in data.items():
            if k not in NAME_FIELDS:
                out += _strings(v, (*location, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            out += _strings(v, (*location, i))
    elif isinstance(data, str):
        out.append((location, data))
    return out


def _where(location: tuple[str | int, ...]) -> str:
    text = ""
    for part in location:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _gltf_companions(path: Path, data: bytes) -> list[str]:
    """The relative files a ``.gltf`` names (buffers, images); none for other formats or embedded data."""
    if path.suffix.lower() != ".gltf":
        return []
    try:
        doc = json.loads(data)
    except (ValueError, UnicodeDecodeError):
        return []  # the mesh reader reports it
    uris = [item.get("uri") for key in ("buffers", "images") for item in (doc.get(key) or [])
            if isinstance(item, dict)]  # fmt: skip
    out = []
    for uri in uris:
        if not isinstance(uri, str) or not uri or uri.startswith("data:") or "://" in uri:
            continue
        rel = PurePosixPath(unquote(uri))
        if not rel.is_absolute() and ".." not in rel.parts:
            out.append(str(rel))
    return out


def bundle_scene(
    scene: Scene, texts: Mapping[str, str] | None = None
) -> tuple[SceneBundle, dict[str, bytes]]:
    """The scene as a :class:`SceneBundle` and the bytes of its files by digest. ``texts``: the text to send
    for these absolute paths instead of what the files hold (the desktop app sends the version of a model
    file it uses). Raises :class:`~core.scene.SceneError` naming the field when a file cannot be read here."""
    data = scene_to_dict(scene)
    contents: dict[str, bytes] = {}
    files: list[SceneFile] = []
    given = {os.path.abspath(k): v.encode("utf-8") for k, v in (texts or {}).items()}

    def read(path: Path, where: str, written: str) -> tuple[bytes, str]:
        """The file's bytes and digest."""
        if os.path.abspath(path) in given:
            raw = given[os.path.abspath(path)]
            return raw, _digest(raw)
        try:
            before = path.stat()
            raw = path.read_bytes()
            after = path.stat()
        except FileNotFoundError:
            raise scene.error(where, f"file '{written}' not found (looked for {path})") from None
        except OSError as exc:
            raise scene.error(where, f"cannot read '{written}': {exc.strerror or exc}") from None
        same = (before.st_ino, before.st_size, before.st_mtime_ns) == (
            after.st_ino,
            after.st_size,
            after.st_mtime_ns,
        )
        return raw, _file_digest(path, raw, before if same else None)

    for location, value in _strings(data):
        where = _where(location)
        path = scene.resolve(value)
        named = location[-1] in FILE_FIELDS
        if not named and not (Path(value).suffix and (path.is_file() or os.path.abspath(path) in given)):
            continue
        raw, digest = read(path, where, value)
        contents[digest] = raw
        companions = []
        for rel in _gltf_companions(path, raw):
            extra, extra_digest = read(path.parent / rel, where, f"{value}: {rel}")
            contents[extra_digest] = extra
            companions.append((rel, extra_digest))
        files.append(SceneFile(location, where, value, digest, tuple(companions)))
    key = _digest(
        json.dumps([data, scene.source, [(f.where, f.folder) for f in files]], sort_keys=True).encode()
    )
    return SceneBundle(data, scene.source, tuple(files), key), contents


# ------------------------------------------------------------------------------------------ on a worker
_VERIFIED: set[Path] = set()
"""Files this process wrote or checked (their digests match): not read again."""
_LOCK = threading.Lock()


def default_root() -> Path:
    env = os.environ.get(ROOT_ENV)
    return Path(env) if env else Path(tempfile.gettempdir()) / "brdf-studio-scene-files"


def _place(target: Path, digest: str, contents: dict[str, bytes], fail: Any) -> None:
    """``target`` holding the bytes of ``digest`` (written now unless a file with those bytes is there)."""
    with _LOCK:
        if target in _VERIFIED:
            return
    try:
        if target.is_file() and _digest(target.read_bytes()) == digest:
            with _LOCK:
                _VERIFIED.add(target)
            return
    except OSError:
        pass  # unreadable: written again below
    raw = contents.get(digest)
    if raw is None:
        raise fail("did not reach this worker")
    if _digest(raw) != digest:
        raise fail("arrived damaged (its checksum does not match the client's)")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(target, raw, durable=False)  # checked by digest before every first use
    except (OSError, BrdfStudioError) as exc:
        raise fail(f"cannot be written to {target.parent}: {getattr(exc, 'strerror', None) or exc}") from None
    with _LOCK:
        _VERIFIED.add(target)


def materialize(bundle: SceneBundle, contents: dict[str, bytes], root: Path | None = None) -> Scene:
    """The bundle's scene, read from copies of its files under ``root`` (default :func:`default_root`);
    ``contents`` maps digests to bytes (those already on disk may be missing). Raises
    :class:`~core.scene.SceneError` naming the scene, the field and the file that could not be had."""
    root = default_root() if root is None else Path(root)
    data = copy.deepcopy(bundle.data)
    for f in bundle.files:
        folder = root / f.folder

        def fail(why: str, f: SceneFile = f) -> SceneError:
            return SceneError(f"{bundle.source}: {f.where}: file '{f.written}' {why}")

        _place(folder / f.name, f.digest, contents, fail)
        for rel, digest in f.companions:
            _place(folder / rel, digest, contents, lambda why, rel=rel, f=f: fail(f"(its '{rel}') {why}"))
        node: Any = data
        for part in f.location[:-1]:
            node = node[part]
        node[f.location[-1]] = str(folder / f.name)
    return scene_from_dict(data, source=bundle.source, base_dir=root, check_files=True)
