"""A small evented layer over a pydantic model, with snapshot undo/redo (napari's ``EventedModel`` idea,
written for one purpose: the app edits a :class:`core.scene.Scene` in place and every view hears what
changed).

There is no second schema: the edited object *is* the model. :class:`EventedModel` holds it and offers one
way to change it, :meth:`EventedModel.edit`: copy the model (a deep copy: a scene is a few kilobytes), apply
the change to the copy, run the model's own checks on it, and compare field by field. A refused change (a
pydantic ``ValidationError`` or the model's check) leaves the model untouched and raises
:class:`ParameterError` with the field and the reason; an accepted one replaces the model and becomes an undo
step holding the model before and after. A model is never changed once it is in place, so the steps hold the
models themselves (no copies), and an object a view got from the document never changes under it. The events
are generated from the model's fields (``events.lights``, ``events.camera``, ...): nobody writes an event per
kind of edit. Each is emitted with the indices of the changed items of a list field, or ``None`` when items
were added, removed or reordered (or the field is not a list).

Plain Python, no Qt: widgets connect to the events and write back through the document's methods.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from pydantic import BaseModel, ValidationError

from core.errors import BrdfStudioError, ParameterError

M = TypeVar("M", bound=BaseModel)

Items = frozenset[int] | None
"""What changed in a list field: the indices of changed items, or ``None`` for a change of its length or order
(or of a field that is not a list)."""

MERGE_SECONDS = 1.0
"""Edits with the same merge key within this time are one undo step (a slider drag is one step)."""


class Event:
    """Callbacks connected to it are called in order by :meth:`emit`."""

    def __init__(self) -> None:
        self._callbacks: list[Callable[..., Any]] = []

    def connect(self, callback: Callable[..., Any]) -> Callable[..., Any]:
        self._callbacks.append(callback)
        return callback

    def disconnect(self, callback: Callable[..., Any]) -> None:
        if callback in self._callbacks:
            self._callbacks.remove(callback)

    def emit(self, *args: Any) -> None:
        for callback in list(self._callbacks):
            callback(*args)


class FieldEvents:
    """One :class:`Event` per field of a pydantic model class, as attributes of the same names."""

    def __init__(self, model: type[BaseModel]) -> None:
        self.names = tuple(model.model_fields)
        for name in self.names:
            setattr(self, name, Event())

    def __getitem__(self, name: str) -> Event:
        return getattr(self, name)  # type: ignore[no-any-return]


def changed_fields(before: BaseModel, after: BaseModel) -> dict[str, Items]:
    """The fields that differ between two models of one class, each with :data:`Items`."""
    out: dict[str, Items] = {}
    for name in type(after).model_fields:
        a, b = getattr(before, name), getattr(after, name)
        if a == b:
            continue
        if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
            out[name] = frozenset(i for i, (x, y) in enumerate(zip(a, b, strict=True)) if x != y)
        else:
            out[name] = None
    return out


def validation_text(exc: ValidationError, where: str = "") -> str:
    """A pydantic error as the scene loader words it: ``lights[0].radiance[1]: Input should be ...``."""
    lines = []
    for err in exc.errors()[:4]:
        path = where
        for part in err["loc"]:
            if isinstance(part, int):
                path += f"[{part}]"
            elif part not in ("point", "quad", "constant", "map"):  # pydantic's discriminator step
                path += ("." if path else "") + str(part)
        msg = "unknown field (check the spelling)" if err["type"] == "extra_forbidden" else err["msg"]
        lines.append(f"{path or '(value)'}: {msg}")
    return "\n".join(lines)


@dataclass
class Step(Generic[M]):
    label: str
    before: M
    after: M
    merge_key: Any = None
    stamp: float = 0.0


class EventedModel(Generic[M]):
    """A pydantic model edited in place, its field events, and its snapshot history.

    ``check(model)`` runs after every change (the schema's cross-field checks); it raises
    :class:`core.errors.BrdfStudioError` to refuse the change.
    """

    def __init__(self, model: M, check: Callable[[M], None] | None = None) -> None:
        self.model = model
        self._check = check
        self.events = FieldEvents(type(model))
        self.history_changed = Event()
        self._undo: list[Step[M]] = []
        self._redo: list[Step[M]] = []
        self._clean_index: int | None = 0
        self.revision = 0
        """Increases with every change of the model (autosave and caches compare it)."""

    # ---- the one way to change the model ------------------------------------------------------------
    def edit(
        self,
        label: str,
        change: Callable[[M], None],
        merge_key: Any = None,
        where: str = "",
        join_last: bool = False,
    ) -> dict[str, Items]:
        """Apply ``change`` to the model as one undoable step and return what changed (nothing changed: no
        step). A refused change leaves the model as it was and raises :class:`ParameterError`; ``where``
        prefixes the field path of a pydantic error (``"lights[0]"``). Consecutive edits with the same
        ``merge_key`` within :data:`MERGE_SECONDS` are one step; ``join_last`` makes the change part of the
        last step whatever its key and age (a consequence of that step, e.g. the view framing an import)."""
        before = self.model
        candidate = before.model_copy(deep=True)
        try:
            change(candidate)
            if self._check is not None:
                self._check(candidate)
        except ValidationError as exc:
            raise ParameterError(validation_text(exc, where)) from None
        except BrdfStudioError as exc:
            raise ParameterError(str(exc)) from None
        changes = changed_fields(before, candidate)
        if not changes:
            return changes
        self.model = candidate
        now = time.monotonic()
        top = self._undo[-1] if self._undo else None
        mergeable = merge_key is not None and top is not None and top.merge_key == merge_key
        if (
            top is not None
            and not self._redo
            and (join_last or (mergeable and now - top.stamp < MERGE_SECONDS))
            and self._clean_index != len(self._undo)
        ):
            top.after = candidate
            top.stamp = now
        else:
            if self._redo and self._clean_index is not None and self._clean_index > len(self._undo):
                self._clean_index = None  # the saved state was in the redo branch being discarded
            self._undo.append(Step(label, before, candidate, merge_key, now))
        self._redo.clear()
        self.revision += 1
        self._changed(changes)
        self.history_changed.emit()
        return changes

    def _changed(self, changes: dict[str, Items]) -> None:
        """Emit the field events (subclasses fix their view state first)."""
        for name, items in changes.items():
            self.events[name].emit(items)

    # ---- history ----------------------------------------------------------------------------------------
    @property
    def dirty(self) -> bool:
        return self._clean_index != len(self._undo)

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    @property
    def undo_steps(self) -> int:
        return len(self._undo)

    def undo_text(self) -> str:
        return self._undo[-1].label if self._undo else ""

    def redo_text(self) -> str:
        return self._redo[-1].label if self._redo else ""

    def end_merge(self) -> None:
        """Stop merging into the last step (a slider was released)."""
        if self._undo:
            self._undo[-1].merge_key = None

    def undo(self) -> None:
        if self._undo:
            step = self._undo.pop()
            self._redo.append(step)
            self._restore(step.before)

    def redo(self) -> None:
        if self._redo:
            step = self._redo.pop()
            self._undo.append(step)
            self._restore(step.after)

    def _restore(self, snapshot: M) -> None:
        old, self.model = self.model, snapshot
        self.revision += 1
        self._changed(changed_fields(old, self.model))
        self.history_changed.emit()

    def reset(self, model: M) -> None:
        """A new model: history cleared, clean; every field's event fires."""
        self.model = model
        self._undo.clear()
        self._redo.clear()
        self._clean_index = 0
        self.revision += 1
        self._changed(dict.fromkeys(self.events.names))
        self.history_changed.emit()

    def mark_clean(self) -> None:
        self._clean_index = len(self._undo)
        self.history_changed.emit()

    def mark_unsaved(self) -> None:
        """The model differs from any saved file (restored edits)."""
        self._clean_index = None
        self.history_changed.emit()
