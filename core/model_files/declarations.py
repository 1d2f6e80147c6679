"""Where a model file declares each of its parameters: the line an error about a parameter's value names.

A value outside a parameter's range is the user's to fix in one of two places, the value (``--param``, a
scene's ``params``) or the declaration (``float n 1 1000 400``, ``Param("n", 400.0, 1.0, 1000.0)``); a message
that names the declaration's line as ``path:line`` shows both.
"""

from __future__ import annotations

import ast
from pathlib import Path

from core.model_files import ModelSource

BRDF_KINDS = ("float", "color", "bool")
"""The first word of a parameter line of a ``.brdf`` file's ``::begin parameters`` section."""


def brdf_param_line(text: str, name: str) -> int | None:
    """The 1-based line of a ``.brdf`` text's parameters section that declares ``name`` (None: no such line)."""
    inside = False
    for number, raw in enumerate(text.splitlines(), start=1):
        words = raw.split()
        if words[:2] == ["::begin", "parameters"]:
            inside = True
        elif words[:1] == ["::end"] or words[:1] == ["::begin"]:
            inside = False
        elif inside and len(words) >= 2 and words[0] in BRDF_KINDS and words[1] == name:
            return number
    return None


def _is_param_call(node: ast.AST) -> bool:
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    return (isinstance(f, ast.Name) and f.id == "Param") or (
        isinstance(f, ast.Attribute) and f.attr == "Param"
    )


def _declared_name(call: ast.Call) -> str | None:
    first = call.args[0] if call.args else next((k.value for k in call.keywords if k.arg == "name"), None)
    return first.value if isinstance(first, ast.Constant) and isinstance(first.value, str) else None


def python_param_line(text: str, name: str) -> int | None:
    """The line of the ``Param("name", ...)`` call in a Python model file's text (None: not found as such,
    e.g. a name built at run time, or a text that does not parse)."""
    try:
        tree = ast.parse(text)
    except (SyntaxError, ValueError):
        return None
    for node in ast.walk(tree):
        if _is_param_call(node) and _declared_name(node) == name:  # type: ignore[arg-type]
            return node.lineno  # type: ignore[attr-defined, no-any-return]
    return None


def param_line(source: ModelSource, name: str) -> int | None:
    """The line of the model file ``source`` that declares the parameter ``name``."""
    if Path(source.path).suffix.lower() == ".brdf":
        return brdf_param_line(source.text, name)
    return python_param_line(source.text, name)


def param_location(source: ModelSource, name: str) -> str:
    """``path:line`` of the declaration of ``name``, or ``path`` when the line is not known."""
    line = param_line(source, name)
    return f"{source.path}:{line}" if line is not None else source.path
