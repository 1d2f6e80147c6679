"""How compiled code reaches a model loaded from a file: through native function pointers in its parameter row.

A model compiled while the program runs (a translated ``.brdf`` shader, a Python model file) cannot join the
switch of :mod:`core.dispatch` without recompiling every loop that inlines it. Instead the switch has one
more branch, :data:`core.dispatch.FILE_MODEL`, that calls the model through the addresses of its native
functions, which the model's kernel parameter row carries in its first slots (:data:`HEADER`). The built-in
kernels are compiled once, at setup, with that branch in them; loading a model compiles only the model.

The native functions take plain doubles and pointers (the C calling convention), so any compiler can provide
them: LLVM for shaders (:mod:`core.glsl`), numba's ``cfunc`` for Python files:

``void eval(double wix, wiy, wiz, wox, woy, woz, const double* p, int64 n, double* out3)``
    ``f_r(wi, wo)`` as RGB into ``out3``; ``p`` is the model's own row (after the header), ``n`` its length.
``void sample(double wox, woy, woz, const double* p, int64 n, double u1, u2, u3, double* out4)``
    a direction and its density per unit solid angle into ``out4``.
``double pdf(double wox, woy, woz, wix, wiy, wiz, const double* p, int64 n)``
    the density of ``sample``.

An address is a process's own: a parameter row holds it only in the process that loaded the model. A row is
therefore never sent to another process; a model file's :class:`core.brdf.Model` and
:class:`core.brdf.BRDF` pickle as the file's text and the parameter values, and load again on arrival.
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from core.jit import kernel

EVAL_ADDRESS = 0
"""Slot of the address of the model's native ``eval``."""
SAMPLE_ADDRESS = 1
"""Slot of the address of its native ``sample`` (0: the model has none)."""
PDF_ADDRESS = 2
"""Slot of the address of its native ``pdf`` (0: the model has none)."""
HEADER = 4
"""Slots before the model's own parameters (the fourth is reserved, 0)."""

_F64 = ir.DoubleType()
_I64 = ir.IntType(64)
_PTR = _F64.as_pointer()


def _row(context, builder, array_type, array):
    """``(pointer to the row's first parameter after the header, its length)`` of a float64 row."""
    ary = context.make_array(array_type)(context, builder, array)
    n = builder.extract_value(ary.shape, 0)
    data = builder.gep(ary.data, [ir.Constant(_I64, HEADER)])
    return data, builder.sub(n, ir.Constant(_I64, HEADER))


def _address(builder, slot_value, fnty):
    """The function pointer stored (as an exact float64 integer) in a header slot."""
    return builder.inttoptr(builder.fptoui(slot_value, _I64), fnty.as_pointer())


def _load(builder, context, array_type, array, slot):
    ary = context.make_array(array_type)(context, builder, array)
    return builder.load(builder.gep(ary.data, [ir.Constant(_I64, slot)]))


@intrinsic
def _call_eval(typingctx, p, wix, wiy, wiz, wox, woy, woz):
    sig = types.UniTuple(types.float64, 3)(p, wix, wiy, wiz, wox, woy, woz)

    def codegen(context, builder, signature, args):
        p_value, *directions = args
        fnty = ir.FunctionType(ir.VoidType(), [_F64] * 6 + [_PTR, _I64, _PTR])
        fn = _address(builder, _load(builder, context, signature.args[0], p_value, EVAL_ADDRESS), fnty)
        data, n = _row(context, builder, signature.args[0], p_value)
        out = cgutils.alloca_once(builder, _F64, size=3)
        builder.call(fn, [*directions, data, n, out])
        values = [builder.load(builder.gep(out, [ir.Constant(_I64, i)])) for i in range(3)]
        return context.make_tuple(builder, signature.return_type, values)

    return sig, codegen


@intrinsic
def _call_sample(typingctx, p, wox, woy, woz, u1, u2, u3):
    sig = types.UniTuple(types.float64, 4)(p, wox, woy, woz, u1, u2, u3)

    def codegen(context, builder, signature, args):
        p_value, x, y, z, a, b, c = args
        fnty = ir.FunctionType(ir.VoidType(), [_F64] * 3 + [_PTR, _I64] + [_F64] * 3 + [_PTR])
        fn = _address(builder, _load(builder, context, signature.args[0], p_value, SAMPLE_ADDRESS), fnty)
        data, n = _row(context, builder, signature.args[0], p_value)
        out = cgutils.alloca_once(builder, _F64, size=4)
        builder.call(fn, [x, y, z, data, n, a, b, c, out])
        values = [builder.load(builder.gep(out, [ir.Constant(_I64, i)])) for i in range(4)]
        return context.make_tuple(builder, signature.return_type, values)

    return sig, codegen


@intrinsic
def _call_pdf(typingctx, p, wox, woy, woz, wix, wiy, wiz):
    sig = types.float64(p, wox, woy, woz, wix, wiy, wiz)

    def codegen(context, builder, signature, args):
        p_value, *directions = args
        fnty = ir.FunctionType(_F64, [_F64] * 6 + [_PTR, _I64])
        fn = _address(builder, _load(builder, context, signature.args[0], p_value, PDF_ADDRESS), fnty)
        data, n = _row(context, builder, signature.args[0], p_value)
        return builder.call(fn, [*directions, data, n])

    return sig, codegen


@njit(inline="always", nogil=True, cache=True)
def _valid(x):
    """``x`` where it is a finite number >= 0, else 0 (NaN fails both tests)."""
    return x if (x >= 0.0 and x < math.inf) else 0.0


@kernel
def eval_file_model(wi, wo, p):
    """``f_r(wi, wo)`` of the model whose native functions ``p``'s header holds (see the module).

    The host keeps the kernel contract whatever the file computes: zero where either direction is at or below
    the horizon, and zero for a channel that is NaN, infinite or negative (the loader reports such values;
    :func:`core.model_files.probe`)."""
    if wi[2] <= 0.0 or wo[2] <= 0.0:
        return 0.0, 0.0, 0.0
    r, g, b = _call_eval(p, wi[0], wi[1], wi[2], wo[0], wo[1], wo[2])
    return _valid(r), _valid(g), _valid(b)


@kernel
def sample_file_model(wo, p, u1, u2, u3):
    """The model's own sample ``(x, y, z, pdf)``; ``pdf = 0`` for a model without a sampler, and for a draw
    whose density or direction is not a finite number."""
    if p[SAMPLE_ADDRESS] == 0.0:
        return 0.0, 0.0, 1.0, 0.0
    x, y, z, pdf = _call_sample(p, wo[0], wo[1], wo[2], u1, u2, u3)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        return 0.0, 0.0, 1.0, 0.0
    return x, y, z, _valid(pdf)


@kernel
def pdf_file_model(wo, wi, p):
    """The density of :func:`sample_file_model`; 0 for a model without a sampler."""
    if p[PDF_ADDRESS] == 0.0:
        return 0.0
    return _valid(_call_pdf(p, wo[0], wo[1], wo[2], wi[0], wi[1], wi[2]))


@kernel
def eval_raw_rows(wi, wo, p, out):
    """The model's own values ``(n, 3)`` into ``out`` for rows of ``wi`` and ``wo``, as the file computes
    them: no horizon test and no guard against NaN or negatives (what :mod:`core.model_files.probe` checks)."""
    for i in range(wi.shape[0]):
        r, g, b = _call_eval(p, wi[i, 0], wi[i, 1], wi[i, 2], wo[i, 0], wo[i, 1], wo[i, 2])
        out[i, 0] = r
        out[i, 1] = g
        out[i, 2] = b
