"""Forms generated from the scene schema, the way :class:`app.editors.params.ParamEditor` is generated from a
model's ``Param`` list: one row per field of a :mod:`core.scene` pydantic class, chosen by the field's type.

- ``Vec3`` (three floats): :class:`app.editors.rows.Vec3Row`;
- ``RGB`` (three non-negative floats): :class:`app.editors.rows.EmissionRow` (colour, strength);
- a float: :class:`app.editors.params.FloatRow`, its range from the field's bounds (``gt``/``ge``/``lt``/
  ``le``) where the schema has them, else from :data:`HINTS`;
- a bool: :class:`app.editors.rows.CheckRow`;
- a union of one number and a tuple of numbers (``scale: tuple[Scale, ...] | Scale``, one factor or one per
  axis): :class:`app.editors.rows.NumberOrVec3Row`, its range from the number's bounds;
- the ``type`` discriminator and strings (file paths) get no row (the page that holds the form offers them).

:data:`HINTS` adds what the schema does not say: a label, a unit, a tooltip, a slider range for unbounded
numbers. A field without a hint still gets a row labelled from its name.
"""

from __future__ import annotations

import types
import typing
from dataclasses import dataclass
from typing import Any

from annotated_types import Ge, Gt, Le, Lt
from pydantic import BaseModel
from PySide6.QtCore import Signal
from PySide6.QtWidgets import QFormLayout, QLabel, QWidget

from app.editors.params import FloatRow
from app.editors.rows import CheckRow, EmissionRow, NumberOrVec3Row, Vec3Row
from core.brdf import Param


@dataclass(frozen=True)
class Hint:
    label: str = ""
    unit: str = ""
    tip: str = ""
    lo: float | None = None
    hi: float | None = None
    log: bool = False


HINTS: dict[str, Hint] = {
    "position": Hint("Position", tip="Where it is (scene units)"),
    "intensity": Hint("Intensity", "W/sr", "Radiant intensity, linear RGB (irradiance at distance d is intensity / d^2)"),
    "corner": Hint("Corner", tip="One corner of the parallelogram"),
    "edge1": Hint("Edge 1", tip="The first edge from the corner"),
    "edge2": Hint("Edge 2", tip="The second edge; light leaves on the side of edge1 x edge2"),
    "radiance": Hint("Radiance", "W/(m^2 sr)", "Emitted radiance, linear RGB"),
    "two_sided": Hint("Two-sided", tip="Emits on both sides"),
    "target": Hint("Look at", tip="The point the camera looks at"),
    "up": Hint("Up", tip="Which way is up in the image (need not be unit length)"),
    "fov_deg": Hint("Field of view", "deg", "Vertical field of view", lo=1.0, hi=179.0),
    "scale": Hint("Scale", tip="Multiplies the map's radiance", lo=1e-3, hi=1e3, log=True),
    "rotate_deg": Hint("Rotation", "deg", "Rotation of the map about +y", lo=-180.0, hi=180.0),
    "Transform.translate": Hint("Translation", tip="Moves the mesh (scene units), after rotation and scale"),
    "Transform.rotate_deg": Hint("Rotation", "deg", "About x, then y, then z"),
    "Transform.scale": Hint("Scale", tip="One factor for every axis, or one per axis (applied first)"),
}  # fmt: skip
"""Labels, units, tooltips and slider ranges of scene fields, by field name (``Class.field`` where one name
means different things in different classes)."""


def hint_for(model: type[BaseModel], name: str) -> Hint:
    return HINTS.get(f"{model.__name__}.{name}") or HINTS.get(name, Hint())


def _bounds(metadata: list[Any]) -> tuple[float | None, float | None]:
    lo = hi = None
    for m in metadata:
        if isinstance(m, Ge | Gt):
            lo = float(m.ge if isinstance(m, Ge) else m.gt)
        elif isinstance(m, Le | Lt):
            hi = float(m.le if isinstance(m, Le) else m.lt)
    return lo, hi


def _item_metadata(annotation: Any) -> list[Any]:
    """The bounds of one item of a tuple type (``Annotated[float, Field(ge=0)]``)."""
    out: list[Any] = []
    for extra in typing.get_args(annotation)[1:]:
        out += list(getattr(extra, "metadata", [extra]))
    return out


def _number(annotation: Any) -> tuple[bool, list[Any]]:
    """Whether a type is a float (possibly ``Annotated`` with bounds), and its bounds."""
    if annotation is float:
        return True, []
    if typing.get_origin(annotation) is typing.Annotated and typing.get_args(annotation)[0] is float:
        return True, _item_metadata(annotation)
    return False, []


def _number_or_tuple(annotation: Any) -> list[Any] | None:
    """For ``tuple[X, ...] | X`` with ``X`` a (bounded) float: the bounds of ``X``; else ``None``."""
    if typing.get_origin(annotation) not in (typing.Union, types.UnionType):
        return None
    args = typing.get_args(annotation)
    numbers = [a for a in args if _number(a)[0]]
    tuples = [a for a in args if typing.get_origin(a) is tuple]
    if len(args) != 2 or len(numbers) != 1 or len(tuples) != 1:
        return None
    items = typing.get_args(tuples[0])
    if not items or not _number(items[0])[0]:
        return None
    return _number(numbers[0])[1]


def row_for(name: str, annotation: Any, metadata: list[Any], hint: Hint | None = None) -> QWidget | None:
    """The row editing a field of this type, or ``None`` for fields a form leaves out."""
    hint = hint if hint is not None else HINTS.get(name, Hint())
    args = typing.get_args(annotation)
    union_bounds = _number_or_tuple(annotation)
    if union_bounds is not None:
        lo, hi = _bounds(union_bounds + metadata)
        return NumberOrVec3Row(name, -1e6 if lo is None else lo, 1e6 if hi is None else hi)
    if typing.get_origin(annotation) is tuple and len(args) == 3:
        non_negative = all(_bounds(_item_metadata(a))[0] == 0.0 for a in args)
        return EmissionRow(name, hint.unit) if non_negative else Vec3Row(name, hint.unit)
    if annotation is bool:
        return CheckRow(name, hint.tip or hint.label)
    if annotation is float:
        lo, hi = _bounds(metadata)
        lo = hint.lo if hint.lo is not None else lo
        hi = hint.hi if hint.hi is not None else hi
        if lo is None or hi is None:
            lo, hi = -1e3, 1e3
        return FloatRow(Param(name, lo, lo, hi, unit=hint.unit, label=hint.label or name, log=hint.log))
    return None  # the type discriminator, paths


class SchemaForm(QWidget):
    """A form for one :mod:`core.scene` class. ``edited(field, value)`` from any row, ``released()`` when a
    drag ends; ``rows`` by field name; :meth:`show_values` shows a model's values without emitting."""

    edited = Signal(str, object)
    released = Signal()

    def __init__(self, model: type[BaseModel], title: str, parent: QWidget | None = None):
        super().__init__(parent)
        self.model = model
        self.form = QFormLayout(self)
        self.form.setContentsMargins(0, 0, 0, 0)
        self.heading = QLabel(f"<b>{title}</b>")
        self.form.addRow(self.heading)
        self.rows: dict[str, Any] = {}
        for name, info in model.model_fields.items():
            hint = hint_for(model, name)
            row = row_for(name, info.annotation, list(info.metadata), hint)
            if row is None:
                continue
            row.edited.connect(self.edited)  # type: ignore[attr-defined]
            if hasattr(row, "released"):
                row.released.connect(self.released)
            label = QLabel(
                "" if isinstance(row, CheckRow) else hint.label or name.replace("_", " ").capitalize()
            )
            tip = hint.tip + (f" ({hint.unit})" if hint.unit else "")
            label.setToolTip(tip)
            row.setToolTip(tip)
            self.form.addRow(label, row)
            self.rows[name] = row

    def show_values(self, values: BaseModel) -> None:
        for name, row in self.rows.items():
            row.set_value(getattr(values, name))
