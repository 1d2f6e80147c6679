"""The body of each function of a checked program in LLVM IR (llvmlite.ir), scalarized: statements and
expressions, each expression lowered to its components (see :mod:`core.glsl.codegen` for the value model and
the semantics pinned down where C's are undefined). :mod:`core.glsl.codegen` builds the module around them."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from llvmlite import ir

from core.glsl import program as p
from core.glsl.builtin_functions import FloatOps, ParameterConstant
from core.glsl.types import GlslType

if TYPE_CHECKING:
    from core.glsl.codegen import ModuleBuilder

DOUBLE = ir.DoubleType()
I1 = ir.IntType(1)
I32 = ir.IntType(32)
I64 = ir.IntType(64)
PTR = ir.PointerType()

_SCALAR_TYPES: dict[str, ir.Type] = {"float": DOUBLE, "int": I32, "bool": I1}
_INT_MIN = -(2**31)


def scalar_type(t: GlslType) -> ir.Type:
    return _SCALAR_TYPES[t.base]


def return_type(t: GlslType) -> ir.Type:
    if t.size == 0:
        return ir.VoidType()
    if t.size == 1:
        return scalar_type(t)
    return ir.LiteralStructType([DOUBLE] * t.size)


def zero_value(t: GlslType) -> ir.Constant:
    return ir.Constant(scalar_type(t), 0)


@dataclass
class Place:
    """Where an assignment writes: one pointer per component of the target, or, with ``dynamic_index``, one
    of ``pointers`` chosen at run time."""

    pointers: list[ir.Value]
    type: GlslType
    dynamic_index: ir.Value | None = None


class FunctionEmitter:
    def __init__(self, module_builder: ModuleBuilder, function: ir.Function) -> None:
        self.module_builder = module_builder
        self.function = function
        # allocas get a first block of their own (where mem2reg wants them), which falls through to the code
        self.allocas = ir.IRBuilder(function.append_basic_block("allocas"))
        self.code_start = function.append_basic_block("code")
        self.builder = ir.IRBuilder(self.code_start)
        self.ops = FloatOps(self.builder)
        self.variables: dict[p.Variable, list[ir.Value]] = {}
        self.loops: list[tuple[ir.Block, ir.Block]] = []  # (continue target, break target)
        self.params_pointer: ir.Value | None = None
        self.frame_pointer: ir.Value | None = None

    def alloca(self, t: ir.Type) -> ir.Value:
        return self.allocas.alloca(t)

    def finish(self) -> None:
        self.allocas.branch(self.code_start)

    def bind_hidden(self, params: ir.Value, frame: ir.Value) -> None:
        """Take the parameter vector and the frame of globals; the globals' addresses are computed here, in the
        entry block, where they dominate every use."""
        self.params_pointer, self.frame_pointer = params, frame
        frame_type = self.module_builder.frame_type
        for variable, field in self.module_builder.frame_fields.items():
            self.variables[variable] = [
                self.builder.gep(
                    frame,
                    [ir.Constant(I32, 0), ir.Constant(I32, field + i)],
                    inbounds=True,
                    source_etype=frame_type,
                )
                for i in range(variable.type.size)
            ]

    def storage(self, variable: p.Variable) -> list[ir.Value]:
        """One pointer per component of a local, parameter or global (uniforms are read with :meth:`load`)."""
        pointers = self.variables.get(variable)
        if pointers is None:
            pointers = [self.alloca(scalar_type(variable.type)) for _ in range(variable.type.size)]
            self.variables[variable] = pointers
        return pointers

    def load(self, variable: p.Variable) -> list[ir.Value]:
        literal = self.module_builder.literals.get(variable)
        if literal is not None:
            return [ir.Constant(DOUBLE, v) for v in literal]
        if variable.kind != "uniform":
            t = scalar_type(variable.type)
            return [self.builder.load(pointer, typ=t) for pointer in self.storage(variable)]
        values = []
        uniforms = self.module_builder.uniforms
        for i in range(variable.type.size):
            if uniforms is not None:
                values.append(ParameterConstant(DOUBLE, uniforms[variable.slot + i]))
                continue
            slot = self.builder.gep(
                self.params_pointer, [ir.Constant(I64, variable.slot + i)], inbounds=True, source_etype=DOUBLE
            )
            values.append(self.builder.load(slot, typ=DOUBLE))
        if variable.type.base == "bool":  # true iff != 0
            return [self.builder.fcmp_unordered("!=", values[0], ir.Constant(DOUBLE, 0.0))]
        return values

    def initialize(self, variable: p.Variable, initializer: p.Expr | None) -> None:
        """Store ``initializer``'s value (zero without one) in a local's or a global's storage."""
        pointers = self.storage(variable)
        if initializer is None:
            values = [zero_value(variable.type)] * len(pointers)
        else:
            values = self.expr(initializer)
        for pointer, value in zip(pointers, values, strict=True):
            self.builder.store(value, pointer)

    # ---- functions and statements

    def emit_function(self, function: p.Function) -> None:
        args = list(self.function.args)
        self.bind_hidden(args[-2], args[-1])
        position = 0
        for param in function.params:
            for pointer in self.storage(param):
                self.builder.store(args[position], pointer)
                position += 1
        assert function.body is not None
        self.statement(function.body)
        if not self.builder.block.is_terminated:
            if function.result.size == 0:
                self.builder.ret_void()
            else:
                fallback = float("nan") if function.result.base == "float" else 0
                self.emit_return(
                    function.result,
                    [ir.Constant(scalar_type(function.result), fallback)] * function.result.size,
                )
        self.finish()

    def emit_return(self, result: GlslType, values: Sequence[ir.Value]) -> None:
        if result.size == 0:
            self.builder.ret_void()
        elif result.size == 1:
            self.builder.ret(values[0])
        else:
            aggregate = ir.Constant(return_type(result), ir.Undefined)
            for i, value in enumerate(values):
                aggregate = self.builder.insert_value(aggregate, value, i)
            self.builder.ret(aggregate)

    def continue_in_new_block(self, name: str) -> None:
        """After a jump, code of the same block is unreachable: it goes to a fresh block LLVM will drop."""
        self.builder.position_at_end(self.function.append_basic_block(name))

    def statement(self, statement: p.Stmt) -> None:
        if isinstance(statement, p.Block):
            for child in statement.statements:
                self.statement(child)
        elif isinstance(statement, p.Declare):
            self.module_builder.note_literal(statement.variable, statement.initializer)
            self.initialize(statement.variable, statement.initializer)
        elif isinstance(statement, p.Evaluate):
            self.expr(statement.expression)
        elif isinstance(statement, p.If):
            (condition,) = self.expr(statement.condition)
            if statement.otherwise is None:
                with self.builder.if_then(condition):
                    self.statement(statement.then)
            else:
                with self.builder.if_else(condition) as (then, otherwise):
                    with then:
                        self.statement(statement.then)
                    with otherwise:
                        self.statement(statement.otherwise)
        elif isinstance(statement, p.Loop):
            self.loop(statement)
        elif isinstance(statement, p.Return):
            if statement.value is None:
                self.builder.ret_void()
            else:
                self.emit_return(statement.value.type, self.expr(statement.value))
            self.continue_in_new_block("after_return")
        elif isinstance(statement, p.Break):
            self.builder.branch(self.loops[-1][1])
            self.continue_in_new_block("after_break")
        else:
            assert isinstance(statement, p.Continue)
            self.builder.branch(self.loops[-1][0])
            self.continue_in_new_block("after_continue")

    def loop(self, loop: p.Loop) -> None:
        if loop.init is not None:
            self.statement(loop.init)
        test = self.function.append_basic_block("loop_test")
        body = self.function.append_basic_block("loop_body")
        step = self.function.append_basic_block("loop_step")
        end = self.function.append_basic_block("loop_end")
        self.builder.branch(test if loop.test_first else body)
        self.builder.position_at_end(test)
        if loop.condition is None:
            self.builder.branch(body)
        else:
            (condition,) = self.expr(loop.condition)
            self.builder.cbranch(condition, body, end)
        self.builder.position_at_end(body)
        self.loops.append((step, end))
        self.statement(loop.body)
        self.loops.pop()
        if not self.builder.block.is_terminated:
            self.builder.branch(step)
        self.builder.position_at_end(step)
        if loop.step is not None:
            self.expr(loop.step)
        self.builder.branch(test)
        self.builder.position_at_end(end)

    # ---- expressions: each returns the value's components

    def expr(self, e: p.Expr) -> list[ir.Value]:
        return getattr(self, f"expr_{type(e).__name__}")(e)

    def expr_Constant(self, e: p.Constant) -> list[ir.Value]:
        t = scalar_type(e.type)
        return [ir.Constant(t, int(v) if e.type.base != "float" else float(v)) for v in e.values]

    def expr_VariableRef(self, e: p.VariableRef) -> list[ir.Value]:
        return self.load(e.variable)

    def expr_Convert(self, e: p.Convert) -> list[ir.Value]:
        return [self.convert(v, e.operand.type.base, e.type.base) for v in self.expr(e.operand)]

    def convert(self, value: ir.Value, source: str, target: str) -> ir.Value:
        b = self.builder
        if source == target:
            return value
        if target == "float":
            if isinstance(value, ir.Constant) and not isinstance(value, ParameterConstant):
                return ir.Constant(
                    DOUBLE, float(int(value.constant))
                )  # a literal stays a constant: pow(x, 2)
            return b.sitofp(value, DOUBLE) if source == "int" else b.uitofp(value, DOUBLE)
        if target == "int":
            if source == "bool":
                return b.zext(value, I32)
            module = self.module_builder.module
            saturating = module.globals.get("llvm.fptosi.sat.i32.f64") or ir.Function(
                module, ir.FunctionType(I32, [DOUBLE]), name="llvm.fptosi.sat.i32.f64"
            )
            return b.call(saturating, [value])
        if source == "float":
            return b.fcmp_unordered("!=", value, ir.Constant(DOUBLE, 0.0))
        return b.icmp_signed("!=", value, ir.Constant(I32, 0))

    def expr_Construct(self, e: p.Construct) -> list[ir.Value]:
        components: list[ir.Value] = []
        for arg in e.args:
            components.extend(self.convert(v, arg.type.base, e.type.base) for v in self.expr(arg))
        if len(e.args) == 1 and e.args[0].type.is_scalar:
            return components * e.type.size
        return components[: e.type.size]

    def expr_Swizzle(self, e: p.Swizzle) -> list[ir.Value]:
        values = self.expr(e.operand)
        return [values[i] for i in e.components]

    def expr_IndexOf(self, e: p.IndexOf) -> list[ir.Value]:
        values = self.expr(e.operand)
        if isinstance(e.index, p.Constant):
            return [values[int(e.index.values[0])]]
        (index,) = self.expr(e.index)
        return [self.pick(values, index)]

    def pick(self, values: Sequence[ir.Value], index: ir.Value) -> ir.Value:
        result: ir.Value = ir.Constant(DOUBLE, float("nan"))
        for i in reversed(range(len(values))):
            result = self.builder.select(
                self.builder.icmp_signed("==", index, ir.Constant(I32, i)), values[i], result
            )
        return result

    def expr_Unary(self, e: p.Unary) -> list[ir.Value]:
        values = self.expr(e.operand)
        if e.op == "!":
            return [self.builder.not_(v) for v in values]
        if e.type.base == "int":
            return [self.builder.sub(ir.Constant(I32, 0), v) for v in values]
        return [  # a negative literal stays a constant (what GPU compilers fold: pow(-0.5, 10.0))
            ir.Constant(DOUBLE, -v.constant)
            if isinstance(v, ir.Constant) and not isinstance(v, ParameterConstant)
            else self.builder.fneg(v)
            for v in values
        ]

    def expr_Arithmetic(self, e: p.Arithmetic) -> list[ir.Value]:
        return self.arithmetic(e.op, e.type, self.expr(e.left), self.expr(e.right))

    def arithmetic(self, op: str, t: GlslType, left: list[ir.Value], right: list[ir.Value]) -> list[ir.Value]:
        if len(left) < t.size:
            left = left * t.size
        if len(right) < t.size:
            right = right * t.size
        b = self.builder
        if t.base == "float":
            emit = {"+": b.fadd, "-": b.fsub, "*": b.fmul, "/": b.fdiv}[op]
            return [emit(x, y) for x, y in zip(left, right, strict=True)]
        if op == "/":
            return [self.int_divide(x, y) for x, y in zip(left, right, strict=True)]
        emit = {"+": b.add, "-": b.sub, "*": b.mul}[op]
        return [emit(x, y) for x, y in zip(left, right, strict=True)]

    def int_divide(self, numerator: ir.Value, denominator: ir.Value) -> ir.Value:
        """sdiv without its undefined cases: x / 0 is 0 and INT_MIN / -1 wraps to INT_MIN."""
        b = self.builder
        zero = b.icmp_signed("==", denominator, ir.Constant(I32, 0))
        overflow = b.and_(
            b.icmp_signed("==", numerator, ir.Constant(I32, _INT_MIN)),
            b.icmp_signed("==", denominator, ir.Constant(I32, -1)),
        )
        safe = b.select(b.or_(zero, overflow), ir.Constant(I32, 1), denominator)
        return b.select(zero, ir.Constant(I32, 0), b.sdiv(numerator, safe))

    def expr_Compare(self, e: p.Compare) -> list[ir.Value]:
        left, right = self.expr(e.left), self.expr(e.right)
        b = self.builder
        base = e.left.type.base
        results = []
        for x, y in zip(left, right, strict=True):
            if base == "float":
                results.append(b.fcmp_unordered("!=", x, y) if e.op == "!=" else b.fcmp_ordered(e.op, x, y))
            elif base == "int":
                results.append(b.icmp_signed(e.op, x, y))
            else:
                results.append(b.icmp_unsigned(e.op, x, y))
        combined = results[0]
        for result in results[1:]:  # vectors: == if all components are, != if any is
            combined = b.or_(combined, result) if e.op == "!=" else b.and_(combined, result)
        return [combined]

    def expr_Logical(self, e: p.Logical) -> list[ir.Value]:
        b = self.builder
        (left,) = self.expr(e.left)
        if e.op == "^^":
            (right,) = self.expr(e.right)
            return [b.xor(left, right)]
        left_end = b.block
        rhs = self.function.append_basic_block("logical_rhs")
        merge = self.function.append_basic_block("logical_end")
        if e.op == "&&":
            b.cbranch(left, rhs, merge)
        else:
            b.cbranch(left, merge, rhs)
        b.position_at_end(rhs)
        (right,) = self.expr(e.right)
        rhs_end = b.block
        b.branch(merge)
        b.position_at_end(merge)
        phi = b.phi(I1)
        phi.add_incoming(ir.Constant(I1, 0 if e.op == "&&" else 1), left_end)
        phi.add_incoming(right, rhs_end)
        return [phi]

    def expr_Select(self, e: p.Select) -> list[ir.Value]:
        b = self.builder
        (condition,) = self.expr(e.condition)
        taken = self.function.append_basic_block("select_true")
        other = self.function.append_basic_block("select_false")
        merge = self.function.append_basic_block("select_end")
        b.cbranch(condition, taken, other)
        b.position_at_end(taken)
        if_true = self.expr(e.if_true)
        taken_end = b.block
        b.branch(merge)
        b.position_at_end(other)
        if_false = self.expr(e.if_false)
        other_end = b.block
        b.branch(merge)
        b.position_at_end(merge)
        results = []
        for x, y in zip(if_true, if_false, strict=True):
            phi = b.phi(x.type)
            phi.add_incoming(x, taken_end)
            phi.add_incoming(y, other_end)
            results.append(phi)
        return results

    # ---- assignment

    def place(self, target: p.Expr) -> Place:
        if isinstance(target, p.VariableRef):
            return Place(self.storage(target.variable), target.type)
        if isinstance(target, p.Swizzle):
            base = self.place(target.operand)
            return Place([base.pointers[i] for i in target.components], target.type)
        assert isinstance(target, p.IndexOf)
        base = self.place(target.operand)
        if isinstance(target.index, p.Constant):
            return Place([base.pointers[int(target.index.values[0])]], target.type)
        (index,) = self.expr(target.index)
        return Place(base.pointers, target.type, index)

    def read_place(self, place: Place) -> list[ir.Value]:
        t = scalar_type(place.type)
        values = [self.builder.load(pointer, typ=t) for pointer in place.pointers]
        return values if place.dynamic_index is None else [self.pick(values, place.dynamic_index)]

    def write_place(self, place: Place, values: Sequence[ir.Value]) -> None:
        b = self.builder
        if place.dynamic_index is None:
            for pointer, value in zip(place.pointers, values, strict=True):
                b.store(value, pointer)
            return
        (value,) = values
        for i, pointer in enumerate(place.pointers):
            chosen = b.icmp_signed("==", place.dynamic_index, ir.Constant(I32, i))
            b.store(b.select(chosen, value, b.load(pointer, typ=DOUBLE)), pointer)

    def expr_Assign(self, e: p.Assign) -> list[ir.Value]:
        place = self.place(e.target)
        if e.op is None:
            values = self.expr(e.value)
        else:
            current = self.read_place(place)
            values = self.arithmetic(e.op, e.type, current, self.expr(e.value))
        self.write_place(place, values)
        return values

    def expr_Update(self, e: p.Update) -> list[ir.Value]:
        place = self.place(e.target)
        old = self.read_place(place)
        one = [ir.Constant(scalar_type(e.type), 1 if e.type.base == "int" else 1.0)]
        new = self.arithmetic(e.op, e.type, old, one)
        self.write_place(place, new)
        return new if e.prefix else old

    # ---- calls

    def expr_CallFunction(self, e: p.CallFunction) -> list[ir.Value]:
        args: list[ir.Value] = []
        for arg in e.args:
            args.extend(self.expr(arg))
        result = self.builder.call(
            self.module_builder.functions[e.function], [*args, self.params_pointer, self.frame_pointer]
        )
        if e.type.size == 0:
            return []
        if e.type.size == 1:
            return [result]
        return [self.builder.extract_value(result, i) for i in range(e.type.size)]

    def expr_CallBuiltin(self, e: p.CallBuiltin) -> list[ir.Value]:
        return e.overload.lower(self.ops, [self.expr(arg) for arg in e.args])

    def expr_Sequence(self, e: p.Sequence) -> list[ir.Value]:
        values: list[ir.Value] = []
        for item in e.items:
            values = self.expr(item)
        return values
