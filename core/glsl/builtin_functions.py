"""GLSL's built-in functions: each overload's signature (what the checker resolves calls against) and its
lowering to LLVM IR on scalar doubles (what the code generator emits), side by side.

Definitions follow the GLSL 1.20 specification (section 8) word for word where it gives one, so that edge
cases behave as it says: ``min(x, y) = y < x ? y : x`` (a NaN in ``x`` is returned), ``clamp = min(max(x, lo),
hi)``, ``mix = x (1 - a) + y a``, ``mod = x - y floor(x / y)``, ``step = x < edge ? 0 : 1``. ``pow`` of a
negative base is NaN, as GPUs compute it (``exp2(y log2 x)``; the specification leaves it undefined), except
for the constant exponents 1, 2 and 4, which GPU compilers turn into multiplications (:data:`CONSTANT_POWERS`),
and a constant base and exponent, which they fold as C does: the translation shows what BRDF Explorer shows,
and the host reports the NaN. Integer arguments convert to float (GLSL 1.20 has no integer overloads). sinh, cosh and tanh come from GLSL 1.30.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from llvmlite import ir

from core.glsl.types import FLOAT, FLOAT_TYPES, VEC3, GlslType

DOUBLE = ir.DoubleType()


class FloatOps:
    """Scalar double operations on an IR builder: the vocabulary the built-ins are written in. IEEE semantics,
    no fast-math flags, so the compiled shader computes what a double-precision C program would."""

    def __init__(self, builder: ir.IRBuilder) -> None:
        self.builder = builder

    def const(self, value: float) -> ir.Constant:
        return ir.Constant(DOUBLE, value)

    def add(self, a: ir.Value, b: ir.Value) -> ir.Value:
        return self.builder.fadd(a, b)

    def sub(self, a: ir.Value, b: ir.Value) -> ir.Value:
        return self.builder.fsub(a, b)

    def mul(self, a: ir.Value, b: ir.Value) -> ir.Value:
        return self.builder.fmul(a, b)

    def div(self, a: ir.Value, b: ir.Value) -> ir.Value:
        return self.builder.fdiv(a, b)

    def neg(self, a: ir.Value) -> ir.Value:
        return self.builder.fneg(a)

    def less(self, a: ir.Value, b: ir.Value) -> ir.Value:
        """``a < b`` as an i1 (false when either is NaN)."""
        return self.builder.fcmp_ordered("<", a, b)

    def select(self, condition: ir.Value, a: ir.Value, b: ir.Value) -> ir.Value:
        return self.builder.select(condition, a, b)

    def intrinsic(self, name: str, *args: ir.Value) -> ir.Value:
        """Call LLVM's ``llvm.<name>.f64`` (sqrt, pow, exp, log, sin, fabs, floor...)."""
        return self.builder.call(self._declare(f"llvm.{name}.f64", len(args)), args)

    def libm(self, name: str, *args: ir.Value) -> ir.Value:
        """Call the C math library's ``double name(double...)`` (acos, atan2, sinh... where LLVM has no
        intrinsic). The JIT resolves the symbol in the process (see :mod:`core.glsl.compiler`)."""
        return self.builder.call(self._declare(name, len(args)), args)

    def _declare(self, symbol: str, arity: int) -> ir.Function:
        module = self.builder.module
        existing = module.globals.get(symbol)
        if existing is not None:
            return existing
        return ir.Function(module, ir.FunctionType(DOUBLE, [DOUBLE] * arity), name=symbol)


Components = list[ir.Value]
Lowering = Callable[[FloatOps, Sequence[Components]], Components]


@dataclass(frozen=True, eq=False)
class Overload:
    """One signature of a built-in and how to emit it: ``lower(ops, args)`` maps each argument's components
    (a scalar has one) to the result's."""

    name: str
    param_types: tuple[GlslType, ...]
    result: GlslType
    lower: Lowering

    def signature(self) -> str:
        return f"{self.result} {self.name}({', '.join(str(t) for t in self.param_types)})"


# ---- scalar definitions


def _min(ops: FloatOps, x: ir.Value, y: ir.Value) -> ir.Value:
    return ops.select(ops.less(y, x), y, x)


def _max(ops: FloatOps, x: ir.Value, y: ir.Value) -> ir.Value:
    return ops.select(ops.less(x, y), y, x)


def _clamp(ops: FloatOps, x: ir.Value, lo: ir.Value, hi: ir.Value) -> ir.Value:
    return _min(ops, _max(ops, x, lo), hi)


def _mix(ops: FloatOps, x: ir.Value, y: ir.Value, a: ir.Value) -> ir.Value:
    return ops.add(ops.mul(x, ops.sub(ops.const(1.0), a)), ops.mul(y, a))


def _step(ops: FloatOps, edge: ir.Value, x: ir.Value) -> ir.Value:
    return ops.select(ops.less(x, edge), ops.const(0.0), ops.const(1.0))


def _smoothstep(ops: FloatOps, edge0: ir.Value, edge1: ir.Value, x: ir.Value) -> ir.Value:
    t = _clamp(ops, ops.div(ops.sub(x, edge0), ops.sub(edge1, edge0)), ops.const(0.0), ops.const(1.0))
    return ops.mul(ops.mul(t, t), ops.sub(ops.const(3.0), ops.mul(ops.const(2.0), t)))


class ParameterConstant(ir.Constant):
    """A parameter's value compiled in as a constant (a specialization): a constant to LLVM, but to the
    shader's semantics still a uniform, so that specialized and general code compute the same values."""


CONSTANT_POWERS = (1.0, 2.0, 4.0)
"""Exponents that a GPU compiler turns into multiplications when they are constants in the shader (Mesa:
``pow(a, 1) = a``, ``pow(a, 2) = a a``, ``pow(a, 4) = (a a)(a a)``), defined for a negative base too."""


def _is_literal(value: ir.Value) -> bool:
    return isinstance(value, ir.Constant) and not isinstance(value, ParameterConstant)


def _pow(ops: FloatOps, x: ir.Value, y: ir.Value) -> ir.Value:
    if _is_literal(x) and _is_literal(y):  # folded by the GPU compiler as C computes it: pow(-0.5, 10.0) > 0
        return ops.intrinsic("pow", x, y)
    if _is_literal(y) and y.constant in CONSTANT_POWERS:
        if y.constant == 1.0:
            return x
        square = ops.mul(x, x)
        return square if y.constant == 2.0 else ops.mul(square, square)
    return ops.select(ops.less(x, ops.const(0.0)), ops.const(math.nan), ops.intrinsic("pow", x, y))


def _sign(ops: FloatOps, x: ir.Value) -> ir.Value:
    # x itself when it is zero (either sign) or NaN: GLSL's 0.0 for zeros, and a NaN stays visible
    return ops.select(
        ops.less(ops.const(0.0), x),
        ops.const(1.0),
        ops.select(ops.less(x, ops.const(0.0)), ops.const(-1.0), x),
    )


def _fract(ops: FloatOps, x: ir.Value) -> ir.Value:
    return ops.sub(x, ops.intrinsic("floor", x))


def _mod(ops: FloatOps, x: ir.Value, y: ir.Value) -> ir.Value:
    return ops.sub(x, ops.mul(y, ops.intrinsic("floor", ops.div(x, y))))


def _inversesqrt(ops: FloatOps, x: ir.Value) -> ir.Value:
    return ops.div(ops.const(1.0), ops.intrinsic("sqrt", x))


def _radians(ops: FloatOps, x: ir.Value) -> ir.Value:
    return ops.mul(x, ops.const(math.pi / 180.0))


def _degrees(ops: FloatOps, x: ir.Value) -> ir.Value:
    return ops.mul(x, ops.const(180.0 / math.pi))


def _intrinsic(name: str) -> Callable[..., ir.Value]:
    return lambda ops, *args: ops.intrinsic(name, *args)


def _libm(name: str) -> Callable[..., ir.Value]:
    return lambda ops, *args: ops.libm(name, *args)


def _componentwise(scalar: Callable[..., ir.Value]) -> Lowering:
    """Apply ``scalar`` to each component; scalar arguments of a vector overload apply to every component."""

    def lower(ops: FloatOps, args: Sequence[Components]) -> Components:
        size = max(len(a) for a in args)
        spread = [a * size if len(a) == 1 else a for a in args]
        return [scalar(ops, *(a[i] for a in spread)) for i in range(size)]

    return lower


# ---- geometric functions (on whole vectors)


def _dot(ops: FloatOps, a: Components, b: Components) -> ir.Value:
    total = ops.mul(a[0], b[0])
    for x, y in zip(a[1:], b[1:], strict=True):
        total = ops.add(total, ops.mul(x, y))
    return total


def _length(ops: FloatOps, args: Sequence[Components]) -> Components:
    (x,) = args
    return [ops.intrinsic("sqrt", _dot(ops, x, x))]


def _distance(ops: FloatOps, args: Sequence[Components]) -> Components:
    a, b = args
    d = [ops.sub(p, q) for p, q in zip(a, b, strict=True)]
    return [ops.intrinsic("sqrt", _dot(ops, d, d))]


def _dot_lowering(ops: FloatOps, args: Sequence[Components]) -> Components:
    a, b = args
    return [_dot(ops, a, b)]


def _normalize(ops: FloatOps, args: Sequence[Components]) -> Components:
    (x,) = args
    length = ops.intrinsic("sqrt", _dot(ops, x, x))
    return [ops.div(c, length) for c in x]


def _cross(ops: FloatOps, args: Sequence[Components]) -> Components:
    (a0, a1, a2), (b0, b1, b2) = args
    return [
        ops.sub(ops.mul(a1, b2), ops.mul(b1, a2)),
        ops.sub(ops.mul(a2, b0), ops.mul(b2, a0)),
        ops.sub(ops.mul(a0, b1), ops.mul(b0, a1)),
    ]


def _reflect(ops: FloatOps, args: Sequence[Components]) -> Components:
    incident, normal = args  # I - 2 dot(N, I) N
    scale = ops.mul(ops.const(2.0), _dot(ops, normal, incident))
    return [ops.sub(i, ops.mul(scale, n)) for i, n in zip(incident, normal, strict=True)]


def _refract(ops: FloatOps, args: Sequence[Components]) -> Components:
    incident, normal, (eta,) = args
    # k = 1 - eta^2 (1 - dot(N, I)^2); 0 if k < 0, else eta I - (eta dot(N, I) + sqrt(k)) N
    cosine = _dot(ops, normal, incident)
    k = ops.sub(ops.const(1.0), ops.mul(ops.mul(eta, eta), ops.sub(ops.const(1.0), ops.mul(cosine, cosine))))
    scale = ops.add(ops.mul(eta, cosine), ops.intrinsic("sqrt", k))
    total_reflection = ops.less(k, ops.const(0.0))
    return [
        ops.select(total_reflection, ops.const(0.0), ops.sub(ops.mul(eta, i), ops.mul(scale, n)))
        for i, n in zip(incident, normal, strict=True)
    ]


def _faceforward(ops: FloatOps, args: Sequence[Components]) -> Components:
    normal, incident, reference = args  # dot(Nref, I) < 0 ? N : -N
    facing = ops.less(_dot(ops, reference, incident), ops.const(0.0))
    return [ops.select(facing, n, ops.neg(n)) for n in normal]


# ---- the table

BUILTINS: dict[str, tuple[Overload, ...]] = {}


def _register(name: str, overloads: list[Overload]) -> None:
    BUILTINS[name] = BUILTINS.get(name, ()) + tuple(overloads)


def _generic(
    name: str, scalar: Callable[..., ir.Value], arity: int, float_positions: Sequence[tuple[int, ...]] = ()
) -> None:
    """genType overloads: every argument of one of float, vec2, vec3, vec4; then, for each tuple of
    ``float_positions``, the vector overloads where those arguments are a float."""
    lower = _componentwise(scalar)
    overloads = [Overload(name, (t,) * arity, t, lower) for t in FLOAT_TYPES]
    for positions in float_positions:
        for t in FLOAT_TYPES[1:]:
            params = tuple(FLOAT if i in positions else t for i in range(arity))
            overloads.append(Overload(name, params, t, lower))
    _register(name, overloads)


for _name in ("sqrt", "exp", "exp2", "log", "log2", "sin", "cos", "floor", "ceil"):
    _generic(_name, _intrinsic(_name), 1)
_generic("abs", _intrinsic("fabs"), 1)
for _name in ("tan", "asin", "acos", "atan", "sinh", "cosh", "tanh"):
    _generic(_name, _libm(_name), 1)
_generic("atan", _libm("atan2"), 2)
_generic("pow", _pow, 2)
_generic("inversesqrt", _inversesqrt, 1)
_generic("radians", _radians, 1)
_generic("degrees", _degrees, 1)
_generic("sign", _sign, 1)
_generic("fract", _fract, 1)
_generic("mod", _mod, 2, [(1,)])
_generic("min", _min, 2, [(1,)])
_generic("max", _max, 2, [(1,)])
_generic("clamp", _clamp, 3, [(1, 2)])
_generic("mix", _mix, 3, [(2,)])
_generic("step", _step, 2, [(0,)])
_generic("smoothstep", _smoothstep, 3, [(0, 1)])

_register("length", [Overload("length", (t,), FLOAT, _length) for t in FLOAT_TYPES])
_register("distance", [Overload("distance", (t, t), FLOAT, _distance) for t in FLOAT_TYPES])
_register("dot", [Overload("dot", (t, t), FLOAT, _dot_lowering) for t in FLOAT_TYPES])
_register("normalize", [Overload("normalize", (t,), t, _normalize) for t in FLOAT_TYPES])
_register("cross", [Overload("cross", (VEC3, VEC3), VEC3, _cross)])
_register("reflect", [Overload("reflect", (t, t), t, _reflect) for t in FLOAT_TYPES])
_register("refract", [Overload("refract", (t, t, FLOAT), t, _refract) for t in FLOAT_TYPES])
_register("faceforward", [Overload("faceforward", (t, t, t), t, _faceforward) for t in FLOAT_TYPES])
