"""A checked :class:`~core.glsl.program.Program` to an LLVM IR module (llvmlite.ir), scalarized.

Every GLSL value is a list of LLVM scalars, one per component: float ``double``, int ``i32``, bool ``i1``
(a vec3 is three doubles). Variables are one ``alloca`` per component, which LLVM's mem2reg/SROA turn into
SSA values. User functions become internal LLVM functions (marked ``alwaysinline``) taking their arguments'
components, then two hidden pointers: the parameter vector (the uniforms) and the frame of global variables
of the current evaluation, a stack object of the entry function, so the kernel writes no memory but its
stack and its output.

The module exports::

    void brdf(double lx, double ly, double lz, double vx, double vy, double vz,
              const double* p, int64_t n, double* out)        // out[0..2] = BRDF(L, V, N=z, X=x, Y=y)
    void brdf_batch(int64_t count, const double* L, const double* V,
                    const double* p, int64_t n, double* out)  // rows of 3 doubles

Semantics that C leaves undefined are pinned down here so that no shader triggers undefined behaviour:
int division by zero gives 0, float to int saturates (NaN gives 0), an out-of-range dynamic index reads NaN
and writes nothing, a variable declared without initializer starts at zero, and falling off the end of a
function (the checker refuses it) would return NaN.
"""

from __future__ import annotations

from collections.abc import Sequence

from llvmlite import ir

from core.glsl import program as p
from core.glsl.emitter import DOUBLE, I64, PTR, FunctionEmitter, return_type, scalar_type

ENTRY_NAME = "brdf"
BATCH_NAME = "brdf_batch"


def build_module(
    program: p.Program, name: str = "shader", uniforms: Sequence[float] | None = None
) -> ir.Module:
    """The LLVM IR module of ``program`` with the entry points ``brdf`` and ``brdf_batch``.

    ``uniforms``: the parameter vector's values, compiled in as constants (a specialization: the optimizer
    folds every expression of the parameters alone, such as ``pow(baseColor, 2.2)``, once); the entry points
    keep their signature and ignore the vector they are given. Without it the parameters are read at each call.
    """
    return ModuleBuilder(program, name, uniforms).module


def _literal(expr: p.Expr, known: dict[p.Variable, list[float]]) -> list[float] | None:
    """The float components of a literal expression (a constant, converted or negated, or a ``const`` variable
    initialized by one), or None: the values a GPU compiler sees as constants where our code generator would
    otherwise load a variable (so that ``pow(x, TWO)`` with ``const float TWO = 2.0`` is ``x x`` as on a GPU)."""
    if isinstance(expr, p.Constant):
        return [float(v) for v in expr.values]
    if isinstance(expr, p.Convert) and expr.type.base == "float" and expr.operand.type.base == "int":
        return _literal(expr.operand, known)
    if isinstance(expr, p.Unary) and expr.op == "-":
        inner = _literal(expr.operand, known)
        return None if inner is None else [-v for v in inner]
    if isinstance(expr, p.VariableRef):
        return known.get(expr.variable)
    return None


class ModuleBuilder:
    def __init__(self, program: p.Program, name: str, uniforms: Sequence[float] | None = None) -> None:
        self.program = program
        self.uniforms = None if uniforms is None else [float(u) for u in uniforms]
        self.literals: dict[p.Variable, list[float]] = {}
        """``const`` float variables initialized by a literal expression: loaded as constants."""
        for global_variable in program.globals:
            self.note_literal(global_variable.variable, global_variable.initializer)
        self.module = ir.Module(name=name)
        fields: list[ir.Type] = []
        self.frame_fields: dict[p.Variable, int] = {}
        for global_variable in program.globals:
            self.frame_fields[global_variable.variable] = len(fields)
            fields.extend([scalar_type(global_variable.variable.type)] * global_variable.variable.type.size)
        self.frame_type = ir.LiteralStructType(fields)
        self.functions: dict[p.Function, ir.Function] = {}
        for function in program.functions:
            self.functions[function] = self.declare(function)
        for function in program.functions:
            FunctionEmitter(self, self.functions[function]).emit_function(function)
        self.entry = self.emit_entry()
        self.emit_batch()

    def note_literal(self, variable: p.Variable, initializer: p.Expr | None) -> None:
        if variable.is_const and variable.type.base == "float" and initializer is not None:
            values = _literal(initializer, self.literals)
            if values is not None and len(values) == variable.type.size:
                self.literals[variable] = values

    def declare(self, function: p.Function) -> ir.Function:
        arg_types: list[ir.Type] = []
        for param in function.params:
            arg_types.extend([scalar_type(param.type)] * param.type.size)
        fn_type = ir.FunctionType(return_type(function.result), [*arg_types, PTR, PTR])
        symbol = f"glsl.{function.name}({','.join(str(t) for t in function.param_types)})"
        llvm_function = ir.Function(self.module, fn_type, name=symbol)
        llvm_function.linkage = "internal"
        llvm_function.attributes.add("alwaysinline")
        llvm_function.attributes.add("nounwind")
        return llvm_function

    def emit_entry(self) -> ir.Function:
        """``brdf``: a frame for the globals on the stack, then ``glsl.main`` (which takes the frame as an
        opaque pointer, like every function), then the result to ``out``."""
        main = self.emit_main()
        fn_type = ir.FunctionType(ir.VoidType(), [DOUBLE] * 6 + [PTR, I64, PTR])
        entry = ir.Function(self.module, fn_type, name=ENTRY_NAME)
        entry.attributes.add("nounwind")
        *directions, params, _count, out = entry.args
        params.add_attribute("noalias")
        out.add_attribute("noalias")
        emitter = FunctionEmitter(self, entry)
        frame = emitter.alloca(self.frame_type)
        result = emitter.builder.call(main, [*directions, params, frame])
        for i in range(3):
            slot = emitter.builder.gep(out, [ir.Constant(I64, i)], inbounds=True, source_etype=DOUBLE)
            emitter.builder.store(emitter.builder.extract_value(result, i), slot)
        emitter.builder.ret_void()
        emitter.finish()
        return entry

    def emit_main(self) -> ir.Function:
        """``glsl.main(L, V, p, frame)``: the globals' initializers in source order, then ``BRDF`` in the
        local frame (N = z, X = x, Y = y)."""
        fn_type = ir.FunctionType(return_type(self.program.brdf.result), [DOUBLE] * 6 + [PTR, PTR])
        main = ir.Function(self.module, fn_type, name="glsl.main")
        main.linkage = "internal"
        main.attributes.add("alwaysinline")
        main.attributes.add("nounwind")
        *directions, params, frame = main.args
        emitter = FunctionEmitter(self, main)
        emitter.bind_hidden(params, frame)
        for global_variable in self.program.globals:
            emitter.initialize(global_variable.variable, global_variable.initializer)
        one, zero = ir.Constant(DOUBLE, 1.0), ir.Constant(DOUBLE, 0.0)
        frame_axes = [zero, zero, one, one, zero, zero, zero, one, zero]
        result = emitter.builder.call(
            self.functions[self.program.brdf], [*directions, *frame_axes, params, frame]
        )
        emitter.builder.ret(result)
        emitter.finish()
        return main

    def emit_batch(self) -> None:
        fn_type = ir.FunctionType(ir.VoidType(), [I64, PTR, PTR, PTR, I64, PTR])
        batch = ir.Function(self.module, fn_type, name=BATCH_NAME)
        count, lights, views, params, n, out = batch.args
        start = batch.append_basic_block("start")
        loop = batch.append_basic_block("row")
        done = batch.append_basic_block("done")
        builder = ir.IRBuilder(start)
        builder.cbranch(builder.icmp_signed(">", count, ir.Constant(I64, 0)), loop, done)
        builder.position_at_end(loop)
        row = builder.phi(I64)
        row.add_incoming(ir.Constant(I64, 0), start)
        base = builder.mul(row, ir.Constant(I64, 3))
        args: list[ir.Value] = []
        for array in (lights, views):
            for i in range(3):
                index = builder.add(base, ir.Constant(I64, i))
                args.append(
                    builder.load(builder.gep(array, [index], inbounds=True, source_etype=DOUBLE), typ=DOUBLE)
                )
        builder.call(
            self.entry, [*args, params, n, builder.gep(out, [base], inbounds=True, source_etype=DOUBLE)]
        )
        following = builder.add(row, ir.Constant(I64, 1))
        row.add_incoming(following, loop)
        builder.cbranch(builder.icmp_signed("<", following, count), loop, done)
        builder.position_at_end(done)
        builder.ret_void()
