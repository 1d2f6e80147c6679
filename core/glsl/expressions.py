"""Typing of expressions for the checker (:mod:`core.glsl.checker`): names looked up in scopes, operators,
swizzles and indexing, assignments, calls resolved among overloads, constructors; each syntax node becomes the
typed node of :mod:`core.glsl.program`, or a :class:`ShaderError` at its token. The rules are listed in
:mod:`core.glsl.checker`."""

from __future__ import annotations

from collections.abc import Sequence

from core.glsl import program as p
from core.glsl import syntax as s
from core.glsl.brdf_file import ShaderParam
from core.glsl.builtin_functions import BUILTINS, Overload
from core.glsl.errors import ShaderError
from core.glsl.types import (
    BOOL,
    FLOAT,
    INT,
    TYPES_BY_NAME,
    VEC3,
    VOID,
    GlslType,
    float_type,
    implicitly_converts,
)

_SWIZZLE_SETS = ("xyzw", "rgba", "stpq")
_RESERVED_OPERATORS = {"%", "<<", ">>", "&", "|", "^", "~"}
_COMPOUND_OPERATORS = {"+=": "+", "-=": "-", "*=": "*", "/=": "/"}
_INT_MIN, _INT_MAX = -(2**31), 2**31 - 1


def _kind_type(param: ShaderParam) -> GlslType:
    return {"float": FLOAT, "color": VEC3, "bool": BOOL}[param.kind]


def describe_types(types: Sequence[GlslType]) -> str:
    return ", ".join(str(t) for t in types)


class ExpressionChecker:
    """The state of one check (scopes, functions, globals, the function being checked) and the typing of
    expressions; :class:`core.glsl.checker.Checker` adds declarations and statements."""

    def __init__(self, path: str, params: Sequence[ShaderParam], shader_line: int) -> None:
        self.path = path
        self.shader_line = shader_line
        self.scopes: list[dict[str, p.Variable]] = [{}]
        self.functions: dict[str, list[p.Function]] = {}
        self.defined: list[p.Function] = []
        self.first_calls: dict[p.Function, s.Position] = {}
        self.globals: list[p.GlobalVariable] = []
        self.global_reads: set[p.Variable] = set()
        self.current: p.Function | None = None
        self.loop_depth = 0
        slot = 0
        uniforms = []
        for param in params:
            variable = p.Variable(param.name, _kind_type(param), "uniform", True, s.Position(0, 0), slot)
            slot += param.slot_count
            uniforms.append(variable)
            self.scopes[0][param.name] = variable
        self.uniforms = tuple(uniforms)

    def line(self, pos: s.Position) -> int:
        """The ``.brdf`` file's line of a position in the shader."""
        return pos.line + self.shader_line - 1

    def error(self, pos: s.Position, message: str) -> ShaderError:
        return ShaderError(self.path, self.line(pos), pos.column, message)

    # ---- expressions

    def lookup(self, name: str) -> p.Variable | None:
        for scope in reversed(self.scopes):
            if name in scope:
                return scope[name]
        return None

    def read(self, variable: p.Variable) -> None:
        if self.current is not None:
            self.current.reads.add(variable)
        else:
            self.global_reads.add(variable)

    def expr(self, e: s.Expression) -> p.Expr:
        method = getattr(self, f"expr_{type(e).__name__}")
        return method(e)

    def expr_FloatLiteral(self, e: s.FloatLiteral) -> p.Expr:
        return p.Constant(FLOAT, (e.value,))

    def expr_IntLiteral(self, e: s.IntLiteral) -> p.Expr:
        if e.value > _INT_MAX:
            raise self.error(e.pos, f"integer {e.value} does not fit in 32 bits")
        return p.Constant(INT, (e.value,))

    def expr_BoolLiteral(self, e: s.BoolLiteral) -> p.Expr:
        return p.Constant(BOOL, (e.value,))

    def expr_Name(self, e: s.Name) -> p.Expr:
        variable = self.lookup(e.name)
        if variable is None:
            if e.name in self.functions or e.name in BUILTINS:
                raise self.error(e.pos, f"'{e.name}' is a function: call it with arguments")
            raise self.error(e.pos, f"unknown identifier '{e.name}'")
        self.read(variable)
        return p.VariableRef(variable.type, variable)

    def expr_Sequence(self, e: s.Sequence) -> p.Expr:
        items = tuple(self.expr(item) for item in e.items)
        return p.Sequence(items[-1].type, items)

    def expr_Unary(self, e: s.Unary) -> p.Expr:
        if e.op in _RESERVED_OPERATORS:
            raise self.error(e.pos, f"operator '{e.op}' is reserved in GLSL 1.20")
        if e.op == "-" and isinstance(e.operand, s.IntLiteral):
            value = -e.operand.value
            if value < _INT_MIN:
                raise self.error(e.operand.pos, f"integer {value} does not fit in 32 bits")
            return p.Constant(INT, (value,))
        operand = self.value(self.expr(e.operand), e.pos)
        if e.op == "!":
            if operand.type != BOOL:
                raise self.error(e.pos, f"operator '!' needs a bool, not {operand.type}")
            return p.Unary(BOOL, "!", operand)
        if not operand.type.is_numeric:
            raise self.error(e.pos, f"operator '{e.op}' needs a number or a vector, not {operand.type}")
        return operand if e.op == "+" else p.Unary(operand.type, "-", operand)

    def expr_Binary(self, e: s.Binary) -> p.Expr:
        op = e.op
        if op in _RESERVED_OPERATORS:
            raise self.error(e.pos, f"operator '{op}' is reserved in GLSL 1.20")
        left = self.value(self.expr(e.left), e.pos)
        right = self.value(self.expr(e.right), e.pos)
        if op in ("&&", "||", "^^"):
            for side in (left, right):
                if side.type != BOOL:
                    raise self.error(e.pos, f"operator '{op}' needs bools, not {side.type}")
            return p.Logical(op, left, right)
        if op in ("+", "-", "*", "/"):
            result_type, left, right = self.arithmetic(op, left, right, e.pos)
            return p.Arithmetic(result_type, op, left, right)
        if op in ("<", ">", "<=", ">="):
            if not (
                left.type.is_numeric
                and left.type.is_scalar
                and right.type.is_numeric
                and right.type.is_scalar
            ):
                raise self.error(
                    e.pos, f"operator '{op}' compares scalar numbers, not {left.type} and {right.type}"
                )
            left, right = self.common(left, right, e.pos, f"operator '{op}'")
            return p.Compare(op, left, right)
        assert op in ("==", "!=")
        left, right = self.common(left, right, e.pos, f"operator '{op}'")
        return p.Compare(op, left, right)

    def arithmetic(
        self, op: str, left: p.Expr, right: p.Expr, pos: s.Position
    ) -> tuple[GlslType, p.Expr, p.Expr]:
        for side in (left, right):
            if not side.type.is_numeric:
                raise self.error(pos, f"operator '{op}' needs numbers or vectors, not {side.type}")
        if left.type == INT and right.type == INT:
            return INT, left, right
        left = self.convert(left, float_type(left.type.size), pos, f"operator '{op}'")
        right = self.convert(right, float_type(right.type.size), pos, f"operator '{op}'")
        if left.type.size != right.type.size and not (left.type.is_scalar or right.type.is_scalar):
            raise self.error(pos, f"operator '{op}' cannot combine {left.type} and {right.type}")
        return (left.type if left.type.size >= right.type.size else right.type), left, right

    def common(self, a: p.Expr, b: p.Expr, pos: s.Position, what: str) -> tuple[p.Expr, p.Expr]:
        """``a`` and ``b`` converted to one type (int to float), or an error."""
        if a.type == b.type:
            return a, b
        if implicitly_converts(a.type, b.type):
            return self.convert(a, b.type, pos, what), b
        if implicitly_converts(b.type, a.type):
            return a, self.convert(b, a.type, pos, what)
        raise self.error(pos, f"{what}: {a.type} and {b.type} do not match")

    def convert(self, value: p.Expr, target: GlslType, pos: s.Position, what: str) -> p.Expr:
        if value.type == target:
            return value
        if value.type == VOID:
            raise self.error(pos, f"{what}: the expression has no value (void)")
        if not implicitly_converts(value.type, target):
            raise self.error(pos, f"{what}: cannot convert {value.type} to {target}")
        if isinstance(value, p.Constant):
            return p.Constant(target, tuple(float(v) for v in value.values))
        return p.Convert(target, value)

    def value(self, value: p.Expr, pos: s.Position) -> p.Expr:
        if value.type == VOID:
            raise self.error(pos, "a void function call has no value to use here")
        return value

    def expr_Conditional(self, e: s.Conditional) -> p.Expr:
        condition = self.expr(e.condition)
        if condition.type != BOOL:
            raise self.error(e.pos, f"the condition of '?:' must be a bool, not {condition.type}")
        if_true = self.value(self.expr(e.if_true), e.pos)
        if_false = self.value(self.expr(e.if_false), e.pos)
        if_true, if_false = self.common(if_true, if_false, e.pos, "the two branches of '?:'")
        return p.Select(if_true.type, condition, if_true, if_false)

    def expr_Field(self, e: s.Field) -> p.Expr:
        operand = self.value(self.expr(e.operand), e.pos)
        return self.swizzle(operand, e.name, e.pos)

    def swizzle(self, operand: p.Expr, name: str, pos: s.Position) -> p.Swizzle:
        if not operand.type.is_vector:
            raise self.error(pos, f"a {operand.type} has no components: '.{name}' needs a vector")
        letters = next((set_ for set_ in _SWIZZLE_SETS if set_.find(name[0]) >= 0), None)
        if letters is None or len(name) > 4 or any(c not in letters for c in name):
            raise self.error(
                pos, f"'.{name}' is not a swizzle (use up to 4 of xyzw, rgba or stpq, from one set)"
            )
        components = tuple(letters.index(c) for c in name)
        if max(components) >= operand.type.size:
            raise self.error(
                pos, f"'.{name}' reaches past the {operand.type.size} components of a {operand.type}"
            )
        return p.Swizzle(float_type(len(components)), operand, components)

    def expr_Index(self, e: s.Index) -> p.Expr:
        return self.index_of(self.value(self.expr(e.operand), e.pos), e)

    def index_of(self, operand: p.Expr, e: s.Index) -> p.IndexOf:
        """``operand[e.index]``, read or assigned: a vector indexed by an int, a constant index in range."""
        if not operand.type.is_vector:
            raise self.error(e.pos, f"a {operand.type} cannot be indexed: '[]' needs a vector")
        index = self.expr(e.index)
        if index.type != INT:
            raise self.error(e.index.pos, f"an index must be an int, not {index.type}")
        if isinstance(index, p.Constant) and not 0 <= int(index.values[0]) < operand.type.size:
            raise self.error(
                e.index.pos,
                f"index {index.values[0]} is outside the {operand.type.size} components of a {operand.type}",
            )
        return p.IndexOf(FLOAT, operand, index)

    # ---- assignments

    def target(self, e: s.Expression, op: str) -> p.Expr:
        """The checked left side of an assignment or ``++``/``--``; it is read too unless ``op`` is ``=``."""
        if isinstance(e, s.Name):
            variable = self.lookup(e.name)
            if variable is None:
                raise self.error(e.pos, f"unknown identifier '{e.name}'")
            if variable.kind == "uniform":
                raise self.error(
                    e.pos, f"cannot assign to '{e.name}': the file's parameters are read-only uniforms"
                )
            if variable.is_const:
                raise self.error(e.pos, f"cannot assign to const '{e.name}'")
            if op != "=":
                self.read(variable)
            return p.VariableRef(variable.type, variable)
        if isinstance(e, s.Field):
            operand = self.target(e.operand, op)
            swizzle = self.swizzle(operand, e.name, e.pos)
            if len(set(swizzle.components)) != len(swizzle.components):
                raise self.error(e.pos, f"cannot assign to '.{e.name}': it names a component twice")
            return swizzle
        if isinstance(e, s.Index):
            return self.index_of(self.target(e.operand, op), e)
        raise self.error(e.pos, "this expression cannot be assigned to")

    def expr_Assignment(self, e: s.Assignment) -> p.Expr:
        if e.op != "=" and e.op not in _COMPOUND_OPERATORS:
            raise self.error(e.pos, f"operator '{e.op}' is reserved in GLSL 1.20")
        target = self.target(e.target, e.op)
        value = self.value(self.expr(e.value), e.pos)
        if e.op == "=":
            return p.Assign(target.type, None, target, self.convert(value, target.type, e.pos, "assignment"))
        op = _COMPOUND_OPERATORS[e.op]
        result_type, _, converted = self.arithmetic(op, target, value, e.pos)
        if result_type != target.type:
            raise self.error(e.pos, f"'{e.op}' would turn the {target.type} on its left into a {result_type}")
        return p.Assign(target.type, op, target, converted)

    def expr_Update(self, e: s.Update) -> p.Expr:
        target = self.target(e.target, e.op)
        if not target.type.is_numeric:
            raise self.error(e.pos, f"operator '{e.op}' needs a number or a vector, not {target.type}")
        return p.Update(target.type, e.op[0], e.prefix, target)

    # ---- calls

    def expr_Call(self, e: s.Call) -> p.Expr:
        args = tuple(self.value(self.expr(a), a.pos) for a in e.args)
        if e.is_constructor:
            return self.constructor(e, args)
        variable = self.lookup(e.callee)
        if variable is not None and variable.kind in ("local", "parameter"):
            raise self.error(
                e.pos, f"'{e.callee}' is a variable here (line {self.line(variable.pos)}), not a function"
            )
        arg_types = tuple(a.type for a in args)
        user = self.functions.get(e.callee)
        if user:
            function = self.resolve(e.callee, user, arg_types, e.pos)
            assert isinstance(function, p.Function)
            if self.current is not None:
                self.current.callees.setdefault(function, e.pos)
            self.first_calls.setdefault(function, e.pos)
            converted = self.arguments(args, function.param_types, e)
            return p.CallFunction(function.result, function, converted)
        builtin = BUILTINS.get(e.callee)
        if builtin is None:
            raise self.error(e.pos, f"unknown function '{e.callee}'")
        overload = self.resolve(e.callee, builtin, arg_types, e.pos)
        assert isinstance(overload, Overload)
        return p.CallBuiltin(overload.result, overload, self.arguments(args, overload.param_types, e))

    def arguments(self, args: Sequence[p.Expr], types: Sequence[GlslType], e: s.Call) -> tuple[p.Expr, ...]:
        return tuple(
            self.convert(a, t, e.pos, f"argument {i + 1} of '{e.callee}'")
            for i, (a, t) in enumerate(zip(args, types, strict=True))
        )

    def resolve(
        self,
        name: str,
        candidates: Sequence[p.Function | Overload],
        arg_types: tuple[GlslType, ...],
        pos: s.Position,
    ) -> p.Function | Overload:
        same_arity = [c for c in candidates if len(c.param_types) == len(arg_types)]
        if not same_arity:
            counts = sorted({len(c.param_types) for c in candidates})
            expected = " or ".join(str(n) for n in counts)
            plural = "" if counts == [1] else "s"
            raise self.error(pos, f"'{name}' takes {expected} argument{plural}, not {len(arg_types)}")
        for candidate in same_arity:
            if candidate.param_types == arg_types:
                return candidate
        viable = [
            c
            for c in same_arity
            if all(implicitly_converts(a, t) for a, t in zip(arg_types, c.param_types, strict=True))
        ]
        if len(viable) > 1:
            costs = [sum(a != t for a, t in zip(arg_types, c.param_types, strict=True)) for c in viable]
            best = min(costs)
            viable = [c for c, cost in zip(viable, costs, strict=True) if cost == best]
        if len(viable) == 1:
            return viable[0]
        call = f"{name}({describe_types(arg_types)})"
        if viable:
            raise self.error(
                pos, f"the call {call} is ambiguous between {' and '.join(c.signature() for c in viable)}"
            )
        listed = "; ".join(c.signature() for c in same_arity[:6]) + ("; ..." if len(same_arity) > 6 else "")
        raise self.error(pos, f"no overload of '{name}' matches {call} (candidates: {listed})")

    def constructor(self, e: s.Call, args: tuple[p.Expr, ...]) -> p.Expr:
        target = TYPES_BY_NAME[e.callee]
        if target == VOID:
            raise self.error(e.pos, "void is not a constructor")
        if not args:
            raise self.error(e.pos, f"{target}() needs at least one argument")
        if target.is_scalar:
            if len(args) > 1:
                raise self.error(e.pos, f"{target}() takes one argument, not {len(args)}")
            (arg,) = args
            if arg.type == target:
                return arg
            if isinstance(arg, p.Constant) and arg.type.is_scalar:
                return p.Constant(target, (_convert_constant(arg.values[0], target),))
            return p.Construct(target, args)
        if len(args) == 1 and args[0].type.is_scalar:
            return p.Construct(target, args)
        total = 0
        for index, arg in enumerate(args):
            if total >= target.size:
                raise self.error(e.pos, f"too many arguments to {target}(): argument {index + 1} is not used")
            total += arg.type.size
        if total < target.size:
            raise self.error(e.pos, f"{target}() needs {target.size} components, the arguments give {total}")
        return p.Construct(target, args)


def _convert_constant(value: float | int | bool, target: GlslType) -> float | int | bool:
    """A scalar constructor on a constant, as the generated code would compute it (int() truncates toward
    zero and saturates)."""
    if target == FLOAT:
        return float(value)
    if target == BOOL:
        return bool(value)
    return min(max(int(value), _INT_MIN), _INT_MAX)
