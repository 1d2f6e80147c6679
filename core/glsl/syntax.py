"""The syntax tree of a shader as written, before any type is known (:mod:`core.glsl.parser` builds it,
:mod:`core.glsl.checker` reads it). Every node carries its position in the shader text (line 1 is the
shader's first line; the checker reports errors in the ``.brdf`` file's lines)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple


class Position(NamedTuple):
    """1-based line and column in the shader text."""

    line: int
    column: int


# ---- expressions


@dataclass(frozen=True)
class FloatLiteral:
    pos: Position
    value: float


@dataclass(frozen=True)
class IntLiteral:
    pos: Position
    value: int


@dataclass(frozen=True)
class BoolLiteral:
    pos: Position
    value: bool


@dataclass(frozen=True)
class Name:
    pos: Position
    name: str


@dataclass(frozen=True)
class Unary:
    """``-x``, ``+x``, ``!x`` (and the reserved ``~x``)."""

    pos: Position
    op: str
    operand: Expression


@dataclass(frozen=True)
class Update:
    """``++x``, ``--x``, ``x++``, ``x--``."""

    pos: Position
    op: str
    prefix: bool
    target: Expression


@dataclass(frozen=True)
class Binary:
    """Arithmetic, comparison and logical operators; ``pos`` is the operator's."""

    pos: Position
    op: str
    left: Expression
    right: Expression


@dataclass(frozen=True)
class Conditional:
    """``condition ? if_true : if_false``; ``pos`` is the ``?``."""

    pos: Position
    condition: Expression
    if_true: Expression
    if_false: Expression


@dataclass(frozen=True)
class Assignment:
    """``target op value`` for ``=`` and the compound operators; ``pos`` is the operator's."""

    pos: Position
    op: str
    target: Expression
    value: Expression


@dataclass(frozen=True)
class Call:
    """A function call, or a constructor when ``callee`` is a type name (``vec3(1.0)``)."""

    pos: Position
    callee: str
    args: tuple[Expression, ...]
    is_constructor: bool


@dataclass(frozen=True)
class Field:
    """``operand.name``: a swizzle such as ``v.xy``; ``pos`` is the name's."""

    pos: Position
    operand: Expression
    name: str


@dataclass(frozen=True)
class Index:
    """``operand[index]``."""

    pos: Position
    operand: Expression
    index: Expression


@dataclass(frozen=True)
class Sequence:
    """``a, b, c``: evaluated left to right, the value of the last."""

    pos: Position
    items: tuple[Expression, ...]


Expression = (
    FloatLiteral
    | IntLiteral
    | BoolLiteral
    | Name
    | Unary
    | Update
    | Binary
    | Conditional
    | Assignment
    | Call
    | Field
    | Index
    | Sequence
)

# ---- statements and declarations


@dataclass(frozen=True)
class TypeName:
    pos: Position
    name: str


@dataclass(frozen=True)
class Qualifier:
    pos: Position
    name: str


@dataclass(frozen=True)
class Declarator:
    """One ``name`` or ``name = initializer`` of a declaration."""

    pos: Position
    name: str
    initializer: Expression | None


@dataclass(frozen=True)
class Declaration:
    """``const float a = 1, b;`` — local or global."""

    pos: Position
    qualifiers: tuple[Qualifier, ...]
    type_name: TypeName
    declarators: tuple[Declarator, ...]


@dataclass(frozen=True)
class Block:
    pos: Position
    statements: tuple[Statement, ...]


@dataclass(frozen=True)
class ExpressionStatement:
    pos: Position
    expression: Expression | None


@dataclass(frozen=True)
class If:
    pos: Position
    condition: Expression
    then: Statement
    otherwise: Statement | None


@dataclass(frozen=True)
class For:
    pos: Position
    init: Statement
    condition: Expression | None
    step: Expression | None
    body: Statement


@dataclass(frozen=True)
class While:
    pos: Position
    condition: Expression
    body: Statement


@dataclass(frozen=True)
class DoWhile:
    pos: Position
    body: Statement
    condition: Expression


@dataclass(frozen=True)
class Return:
    pos: Position
    value: Expression | None


@dataclass(frozen=True)
class Break:
    pos: Position


@dataclass(frozen=True)
class Continue:
    pos: Position


@dataclass(frozen=True)
class Discard:
    pos: Position


Statement = (
    Block
    | Declaration
    | ExpressionStatement
    | If
    | For
    | While
    | DoWhile
    | Return
    | Break
    | Continue
    | Discard
)


@dataclass(frozen=True)
class Parameter:
    pos: Position
    qualifiers: tuple[Qualifier, ...]
    type_name: TypeName
    name: str | None


@dataclass(frozen=True)
class FunctionDeclaration:
    """A function definition, or a prototype when ``body`` is None."""

    pos: Position
    return_type: TypeName
    name: str
    params: tuple[Parameter, ...]
    body: Block | None


@dataclass(frozen=True)
class TranslationUnit:
    """The whole shader: global declarations and functions in source order."""

    items: tuple[Declaration | FunctionDeclaration, ...]
