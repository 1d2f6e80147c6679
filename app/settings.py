"""Per-user files of the app: recent projects, crash-recovery autosaves and the answers about Python model
files (JSON in a config folder).

The folder is ``$BRDF_STUDIO_CONFIG_DIR`` if set (the tests set it), else ``$XDG_CONFIG_HOME/brdf-studio`` or
``~/.config/brdf-studio``. Plain files, no Qt, so they are testable and readable by hand.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from core.io import atomic_write_text

MAX_RECENT = 10


def config_dir() -> Path:
    env = os.environ.get("BRDF_STUDIO_CONFIG_DIR")
    if env:
        folder = Path(env)
    else:
        base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
        folder = Path(base) / "brdf-studio"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def recent_files() -> list[Path]:
    """Recent projects, newest first, only those that still exist."""
    try:
        raw = json.loads((config_dir() / "recent.json").read_text(encoding="utf-8"))
        items = [Path(p) for p in raw if isinstance(p, str)]
    except (OSError, ValueError):
        return []
    return [p for p in items if p.is_file()]


def add_recent(path: Path) -> list[Path]:
    path = Path(path).resolve()
    items = [path] + [p for p in recent_files() if p.resolve() != path]
    items = items[:MAX_RECENT]
    with contextlib.suppress(OSError):
        atomic_write_text(config_dir() / "recent.json", json.dumps([str(p) for p in items], indent=1))
    return items


# ---- Python model files a project names ----------------------------------------------------------------
# Loading a ``.py`` model file runs its code: the app asks before it loads one that a project (or an autosave)
# names, and keeps the answer for that file's content: ``model-files.json`` maps an absolute path to the
# SHA-256 of the text answered about and the answer. Another content is asked about again.
def _model_answers() -> dict[str, Any]:
    try:
        raw = json.loads((config_dir() / "model-files.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return raw if isinstance(raw, dict) else {}


def model_file_answer(path: str | os.PathLike[str], digest: str) -> bool | None:
    """Whether the user let the app run the model file ``path`` with content ``digest`` (None: not asked)."""
    entry = _model_answers().get(str(path))
    if isinstance(entry, dict) and entry.get("digest") == digest and isinstance(entry.get("run"), bool):
        return bool(entry["run"])
    return None


def remember_model_file_answer(path: str | os.PathLike[str], digest: str, run: bool) -> None:
    """Keep the answer about the model file ``path`` with content ``digest`` (replacing the file's last)."""
    answers = _model_answers()
    answers[str(path)] = {"digest": digest, "run": bool(run)}
    with contextlib.suppress(OSError):
        atomic_write_text(config_dir() / "model-files.json", json.dumps(answers, indent=1))


# ---- where long renders run ---------------------------------------------------------------------------
CLUSTER_KINDS = ("none", "local", "address")


@dataclass(frozen=True)
class ClusterSetting:
    """Where *Make reference* and long renders run (``cluster.json``): ``"none"`` (the render process, on
    this machine), ``"local"`` (a local Dask cluster of ``workers`` processes) or ``"address"`` (the Dask
    scheduler at ``address``); see :mod:`renderer.distributed`."""

    kind: str = "none"
    workers: int = 2
    address: str = ""

    def for_job(self) -> dict[str, Any] | None:
        """What a render job carries (:mod:`app.render_session`): None on this machine."""
        return None if self.kind == "none" else asdict(self)

    def describe(self) -> str:
        if self.kind == "local":
            return f"a local cluster of {self.workers} workers"
        if self.kind == "address":
            return f"the Dask scheduler at {self.address}"
        return "this machine"


def cluster_setting() -> ClusterSetting:
    """The saved setting; this machine when none is saved or the file does not hold one."""
    try:
        raw = json.loads((config_dir() / "cluster.json").read_text(encoding="utf-8"))
        setting = ClusterSetting(str(raw["kind"]), int(raw.get("workers", 2)), str(raw.get("address", "")))
    except (OSError, ValueError, KeyError, TypeError):
        return ClusterSetting()
    if (
        setting.kind not in CLUSTER_KINDS
        or setting.workers < 1
        or (setting.kind == "address" and not setting.address)
    ):
        return ClusterSetting()
    return setting


def set_cluster_setting(setting: ClusterSetting) -> None:
    atomic_write_text(config_dir() / "cluster.json", json.dumps(asdict(setting), indent=1))


# ---- crash recovery ------------------------------------------------------------------------------------
# Each running app writes ``autosave-<pid>.json`` (atomically) while it holds unsaved edits and deletes it when
# the edits are saved, discarded or the app quits normally. A file whose session is no longer running is an
# *orphan*: the app crashed, was killed or the machine went down, and the next launch offers it.
def autosave_path(pid: int | None = None) -> Path:
    return config_dir() / f"autosave-{os.getpid() if pid is None else pid}.json"


def process_start(pid: int) -> str | None:
    """When process ``pid`` started, as ``"<boot id>:<start ticks>"`` (Linux), or None where that cannot be
    read. Stored in an autosave beside the pid, it tells the session that wrote the file from a later process
    that got the same pid (pids repeat, after a reboot often)."""
    try:
        boot = Path("/proc/sys/kernel/random/boot_id").read_text(encoding="ascii").strip()
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
        return f"{boot}:{stat[stat.rindex(')') + 2 :].split()[19]}"  # field 22, starttime
    except (OSError, ValueError, IndexError):
        return None


def write_autosave(document: dict[str, Any], project: Path | None) -> Path:
    """Write the unsaved document for this process (atomically: a crash while writing leaves the previous
    autosave whole)."""
    path = autosave_path()
    payload = {
        "time": time.time(),
        "session": process_start(os.getpid()),
        "project": str(project) if project else None,
        "document": document,
    }
    atomic_write_text(path, json.dumps(payload))
    return path


def clear_autosave() -> None:
    with contextlib.suppress(OSError):
        autosave_path().unlink()


def _running(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _session_of(path: Path) -> str | None:
    with contextlib.suppress(OSError, ValueError, AttributeError):
        return json.loads(path.read_text(encoding="utf-8")).get("session")
    return None


def orphaned_autosaves() -> list[Path]:
    """Autosaves left by sessions that are no longer running (they crashed or were killed), newest first.
    A file whose pid now belongs to another process (one that started at another time) is an orphan too."""
    out = []
    for p in config_dir().glob("autosave-*.json"):
        try:
            pid = int(p.stem.split("-", 1)[1])
        except ValueError:
            continue
        if _running(pid):
            written_by, now = _session_of(p), process_start(pid)
            if written_by is None or now is None or written_by == now:
                continue
        out.append(p)
    return sorted(out, key=lambda p: p.stat().st_mtime, reverse=True)


def read_autosave(path: Path) -> dict[str, Any]:
    """The payload of an autosave file (``time``, ``project``, ``document``); ``ValueError`` if unreadable."""
    try:
        payload = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"autosave '{path.name}' is unreadable: {exc}") from None
    if not isinstance(payload, dict) or "document" not in payload:
        raise ValueError(f"autosave '{path.name}' holds no document")
    return payload


def set_aside(path: Path) -> Path:
    """Move an autosave that cannot be restored to ``unrestored/`` in the config folder (kept for the user to
    read, never offered again); returns where it went."""
    folder = config_dir() / "unrestored"
    folder.mkdir(exist_ok=True)
    target = folder / f"{path.stem}-{int(time.time())}{path.suffix}"
    os.replace(path, target)
    return target
