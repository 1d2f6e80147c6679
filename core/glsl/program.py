"""A checked shader: every expression typed, every name bound to its variable or function, every implicit
conversion explicit. :mod:`core.glsl.checker` builds it from the syntax tree and :mod:`core.glsl.codegen`
lowers it to LLVM IR; neither the scopes nor the overload rules reach the code generator.

Its nodes repeat many of :mod:`core.glsl.syntax`'s, field for field but for a type and a bound variable: the
two trees are two stages (the text as written, the program as checked), and each stage's code matches on its
own node classes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

from core.glsl.syntax import Position
from core.glsl.types import BOOL, GlslType

if TYPE_CHECKING:
    from core.glsl.builtin_functions import Overload

VariableKind = Literal["local", "parameter", "global", "uniform"]


@dataclass(eq=False)
class Variable:
    """One declared variable; identity is the binding (two variables may share a name in different scopes).
    ``slot`` is a uniform's first index in the kernel's parameter vector."""

    name: str
    type: GlslType
    kind: VariableKind
    is_const: bool
    pos: Position
    slot: int = -1


@dataclass(eq=False)
class Function:
    """A user function; ``body`` is None until its definition is seen (a prototype may come first)."""

    name: str
    result: GlslType
    params: list[Variable]
    pos: Position
    body: Block | None = None
    callees: dict[Function, Position] = field(default_factory=dict)
    reads: set[Variable] = field(default_factory=set)

    @property
    def param_types(self) -> tuple[GlslType, ...]:
        return tuple(p.type for p in self.params)

    def signature(self) -> str:
        return f"{self.result} {self.name}({', '.join(str(t) for t in self.param_types)})"


# ---- expressions (``type`` first in each)


@dataclass(frozen=True)
class Constant:
    type: GlslType
    values: tuple[float | int | bool, ...]


@dataclass(frozen=True)
class VariableRef:
    type: GlslType
    variable: Variable


@dataclass(frozen=True)
class Convert:
    """Component-wise change of base type (int to float, float to bool, ...); the size stays."""

    type: GlslType
    operand: Expr


@dataclass(frozen=True)
class Construct:
    """A constructor: the arguments' components in order (converted to ``type.base``), the first
    ``type.size`` of them, or one scalar repeated."""

    type: GlslType
    args: tuple[Expr, ...]


@dataclass(frozen=True)
class Swizzle:
    type: GlslType
    operand: Expr
    components: tuple[int, ...]


@dataclass(frozen=True)
class IndexOf:
    """``vector[index]`` with an int index (a Constant when known)."""

    type: GlslType
    operand: Expr
    index: Expr


@dataclass(frozen=True)
class Unary:
    """``-x`` (numbers) or ``!x`` (bool)."""

    type: GlslType
    op: str
    operand: Expr


@dataclass(frozen=True)
class Arithmetic:
    """``+ - * /`` on operands of one base type; one of them may be a scalar applied to every component."""

    type: GlslType
    op: str
    left: Expr
    right: Expr


@dataclass(frozen=True)
class Compare:
    """``< > <= >=`` on scalars, ``== !=`` on equal types (vectors compare all components)."""

    op: str
    left: Expr
    right: Expr
    type: GlslType = BOOL


@dataclass(frozen=True)
class Logical:
    """``&& ||`` (the right side is evaluated only when needed) and ``^^``."""

    op: str
    left: Expr
    right: Expr
    type: GlslType = BOOL


@dataclass(frozen=True)
class Select:
    """``condition ? if_true : if_false``: only the taken branch is evaluated."""

    type: GlslType
    condition: Expr
    if_true: Expr
    if_false: Expr


@dataclass(frozen=True)
class Assign:
    """``target = value`` or, with ``op`` ``+ - * /``, ``target op= value`` (the target is evaluated once).
    Its value is the target's new value."""

    type: GlslType
    op: str | None
    target: Expr
    value: Expr


@dataclass(frozen=True)
class Update:
    """``++``/``--`` (``op`` ``+``/``-``), prefix (the new value) or postfix (the old one)."""

    type: GlslType
    op: str
    prefix: bool
    target: Expr


@dataclass(frozen=True)
class CallFunction:
    type: GlslType
    function: Function
    args: tuple[Expr, ...]


@dataclass(frozen=True)
class CallBuiltin:
    type: GlslType
    overload: Overload
    args: tuple[Expr, ...]


@dataclass(frozen=True)
class Sequence:
    type: GlslType
    items: tuple[Expr, ...]


Expr = (
    Constant
    | VariableRef
    | Convert
    | Construct
    | Swizzle
    | IndexOf
    | Unary
    | Arithmetic
    | Compare
    | Logical
    | Select
    | Assign
    | Update
    | CallFunction
    | CallBuiltin
    | Sequence
)

# ---- statements


@dataclass(frozen=True)
class Block:
    statements: tuple[Stmt, ...]


@dataclass(frozen=True)
class Declare:
    """A local variable comes into being; without an initializer it starts at zero."""

    variable: Variable
    initializer: Expr | None


@dataclass(frozen=True)
class Evaluate:
    expression: Expr


@dataclass(frozen=True)
class If:
    condition: Expr
    then: Stmt
    otherwise: Stmt | None


@dataclass(frozen=True)
class Loop:
    """``for``, ``while`` and ``do`` (``test_first`` False): init, then test / body / step."""

    init: Stmt | None
    condition: Expr | None
    step: Expr | None
    body: Stmt
    test_first: bool


@dataclass(frozen=True)
class Return:
    value: Expr | None


@dataclass(frozen=True)
class Break:
    pass


@dataclass(frozen=True)
class Continue:
    pass


Stmt = Block | Declare | Evaluate | If | Loop | Return | Break | Continue


@dataclass(frozen=True)
class GlobalVariable:
    """A global (``const`` or not), initialized in source order on entry of every evaluation."""

    variable: Variable
    initializer: Expr | None


@dataclass(frozen=True)
class Program:
    """The checked shader. ``brdf`` is ``vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)``; ``uniforms`` are
    the file's parameters in declaration order, their ``slot`` their place in the parameter vector."""

    uniforms: tuple[Variable, ...]
    globals: tuple[GlobalVariable, ...]
    functions: tuple[Function, ...]
    brdf: Function
    uses_tangents: bool
    reads_uniforms: frozenset[str]
