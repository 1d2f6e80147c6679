"""The README's "Command line" block is parsed by the real parser, as written (issue 17: one command's list
option once refused the form another's accepted): every line must parse with no unrecognized argument."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from app.cli import build_parser

README = Path(__file__).resolve().parents[2] / "README.md"


def readme_commands() -> list[str]:
    text = README.read_text()
    block = text.split("## Command line", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    commands = []
    for line in block.splitlines():
        code, _, comment = line.partition("#")
        candidates = [code]
        if "or: " in comment:  # "# or: render SCENE.json ..." shows a second form of the same command
            candidates.append("brdf-studio " + comment.split("or: ", 1)[1])
        for c in candidates:
            c = re.sub(r"\[[^\]]*\]", "", c).strip()  # optional parts in brackets
            if c.startswith("brdf-studio ") and c != "brdf-studio":
                commands.append(c)
    return commands


def test_the_block_was_found():
    commands = readme_commands()
    assert len(commands) >= 10 and any(
        "check --model ward --sampler adaptive_exact --theta 0 30" in c for c in commands
    )


@pytest.mark.parametrize("command", readme_commands())
def test_readme_command_parses(command, capsys):
    parser, handlers = build_parser()
    argv = shlex.split(command)[1:]
    try:
        args, extra = parser.parse_known_args(argv)
    except SystemExit:
        pytest.fail(f"{command!r}: {capsys.readouterr().err.strip()}")
    assert not extra, f"{command!r}: unrecognized {extra}"
    assert args.command in handlers


def every_readme_command() -> list[str]:
    """Every ``brdf-studio ...`` line in every ``sh`` block of the README (Install, Your own models, ...), with
    the same reading of comments and bracketed optional parts as :func:`readme_commands`."""
    commands = []
    for block in README.read_text().split("```sh")[1:]:
        for line in block.split("```", 1)[0].splitlines():
            code = re.sub(r"\[[^\]]*\]", "", line.partition("#")[0]).strip()
            if code.startswith("brdf-studio ") and code != "brdf-studio":
                commands.append(code)
    return commands


@pytest.mark.parametrize("command", every_readme_command())
def test_every_readme_command_parses(command, capsys):
    parser, handlers = build_parser()
    try:
        args, extra = parser.parse_known_args(shlex.split(command)[1:])
    except SystemExit:
        pytest.fail(f"{command!r}: {capsys.readouterr().err.strip()}")
    assert not extra, f"{command!r}: unrecognized {extra}"
    assert args.command in handlers
