"""pydantic's validation errors as the lines a user reads: ``scene.json: materials[2].params.n: ...``, a union's
members merged into what was meant, at most six problems."""

from __future__ import annotations

import re
from typing import Any

from pydantic import ValidationError


def _loc_text(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif part in ("point", "quad", "constant", "map") and (
            out == "" or out.startswith(("lights", "environment"))
        ):
            continue  # pydantic adds the discriminator value as a path step; it is not a field
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


_UNION_TAG = re.compile(r"^(constrained-[a-z]+|[a-z][a-z-]*\[.*\])$")
"""The step pydantic adds to the location of an error in one member of a union (``scale`` is one number or
a list: ``scale.constrained-float``, ``scale.tuple[constrained-float, ...]``); a type's name, not a field."""


_UNION_WORDS = {"tuple": "a list of numbers", "list": "a list", "constrained-float": "a number",
                "constrained-int": "a whole number", "constrained-str": "text"}  # fmt: skip


def _union_errors(errors: list[Any]) -> list[Any]:
    """``errors`` with each union's members merged into what the user meant: the member whose form the value
    has (its error, the member's name left out of the location: ``scale: Input should be less than or equal
    to 1000000``), or, when the value has none of their forms, ``scale: expected a list of numbers or a
    number``."""
    out: list[Any] = []
    groups: dict[tuple[Any, ...], list[Any]] = {}
    for err in errors:
        loc = tuple(err["loc"])
        at = next((i for i, p in enumerate(loc) if isinstance(p, str) and _UNION_TAG.match(p)), None)
        if at is None:
            out.append(err)
            continue
        field = loc[:at]
        if field not in groups:
            groups[field] = []
            out.append(field)  # the union's place among the errors: its first member's
        groups[field].append({**err, "loc": field + loc[at + 1 :], "member": loc[at]})
    merged: list[Any] = []
    for item in out:
        if not isinstance(item, tuple):
            merged.append(item)
            continue
        members = groups[item]
        formed = [e for e in members if not e["type"].endswith(("_type", "_parsing"))]
        if formed:
            merged += formed
            continue
        words = dict.fromkeys(_UNION_WORDS.get(e["member"].split("[")[0], e["member"]) for e in members)
        merged.append({"loc": item, "type": "union", "msg": "expected " + " or ".join(words)})
    return merged


def format_validation(source: str, exc: ValidationError) -> str:
    lines = []
    errors = _union_errors(list(exc.errors()))
    for err in errors[:6]:
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown field (check the spelling)"
        elif err["type"] == "missing":
            msg = "required field is missing"
        lines.append(f"{source}: {_loc_text(tuple(err['loc']))}: {msg}")
    more = len(errors) - len(lines)
    if more > 0:
        lines.append(f"... and {more} more problem(s)")
    return "\n".join(lines)
