"""The documentation builds and its examples run: ``mkdocs build --strict`` (a broken link, a missing page or
a docstring griffe cannot read fails it), and every fenced ``python`` block of ``README.md`` and
``docs/**/*.md`` runs as written (``docs/writing-docs.md``: the blocks of a file share one namespace, a block
after a ``<!-- no-run -->`` line is skipped)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NO_RUN = "<!-- no-run -->"
FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})(?P<info>[^\n`]*)$")


def python_blocks(text: str) -> list[tuple[int, str]]:
    """The fenced ``python`` blocks of a Markdown text to run, as ``(first line number, source)``.

    A block whose fence is preceded (blank lines aside) by ``<!-- no-run -->`` is left out, and so is any
    block nested in another fence (an example of Markdown shown inside a Markdown block).
    """
    lines = text.splitlines()
    blocks: list[tuple[int, str]] = []
    i = 0
    previous = ""
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            if lines[i].strip():
                previous = lines[i].strip()
            i += 1
            continue
        indent, fence, info = m["indent"], m["fence"], m["info"].strip()
        body: list[str] = []
        j = i + 1
        while j < len(lines):
            close = FENCE.match(lines[j])
            if (
                close
                and close["fence"][0] == fence[0]
                and len(close["fence"]) >= len(fence)
                and not close["info"].strip()
            ):
                break
            body.append(lines[j][len(indent) :] if lines[j].startswith(indent) else lines[j])
            j += 1
        language = info.split()[0].lower() if info else ""
        if language in ("python", "py") and previous != NO_RUN:
            blocks.append((i + 2, "\n".join(body) + "\n"))
        previous = ""
        i = j + 1
    return blocks


def documents() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def test_extractor_skips_marked_and_nested_blocks():
    text = "\n".join(
        [
            "```python",
            "a = 1",
            "```",
            NO_RUN,
            "",
            "```python",
            "raise SystemExit",
            "```",
            "````markdown",
            "```python",
            "raise SystemExit",
            "```",
            "````",
            "```sh",
            "make docs",
            "```",
            "```py",
            "b = a",
            "```",
        ]
    )
    assert python_blocks(text) == [(2, "a = 1\n"), (18, "b = a\n")]


@pytest.mark.parametrize(
    "path",
    [p for p in documents() if python_blocks(p.read_text(encoding="utf-8"))],
    ids=lambda p: str(p.relative_to(ROOT)),
)
def test_python_examples_run(path: Path, monkeypatch):
    monkeypatch.chdir(ROOT)
    namespace: dict[str, object] = {"__name__": "__docs__"}
    for line, source in python_blocks(path.read_text(encoding="utf-8")):
        code = compile("\n" * (line - 1) + source, str(path), "exec")
        exec(code, namespace)  # noqa: S102 - the documentation's own examples


def test_mkdocs_build_strict(tmp_path):
    mkdocs = shutil.which("mkdocs", path=str(Path(sys.executable).parent))
    if mkdocs is None:
        pytest.fail("mkdocs is not installed: pip install -e '.[docs]' (the test extra includes it)")
    done = subprocess.run(
        [
            mkdocs,
            "build",
            "--strict",
            "--config-file",
            ".ci/mkdocs.yml",
            "--site-dir",
            str(tmp_path / "site"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    problems = [ln for ln in done.stderr.splitlines() if "WARNING" in ln or "ERROR" in ln]
    assert done.returncode == 0, "mkdocs build --strict failed:\n" + "\n".join(
        problems or [done.stderr[-3000:]]
    )
