"""A ``.brdf`` file to native code: parse, check, emit LLVM IR, optimize, JIT with MCJIT.

The result is a C function pointer (:attr:`CompiledBrdf.address`) any compiled loop can call, numba's
included::

    void brdf(double lx, double ly, double lz, double vx, double vy, double vz,
              const double* p, int64_t n, double* out)

It writes ``BRDF(L, V, N=(0,0,1), X=(1,0,0), Y=(0,1,0))`` to ``out[0..2]``, computed in double precision
from the shader's raw formula: no clamping, NaN and negative values pass through. ``p`` holds the file's
parameters in declaration order (float and bool one slot, bool true iff nonzero; color three slots); ``n`` is
its length (unused). The function is pure, so it is thread-safe and reentrant.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import threading
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import llvmlite.binding as llvm
import numpy as np

from core.errors import ParameterError
from core.glsl.brdf_file import BrdfFile
from core.glsl.checker import check_program
from core.glsl.codegen import BATCH_NAME, ENTRY_NAME, build_module
from core.glsl.parser import parse_shader
from core.glsl.program import Program

OPTIMIZATION_LEVEL = 2
# LLVM's parser, optimizer and JIT share llvmlite's global context: one compilation at a time
_LLVM_LOCK = threading.Lock()

_BATCH_SIGNATURE = ctypes.CFUNCTYPE(
    None, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p
)


@cache
def _initialize_llvm() -> None:
    """Once per process: the native code generator, and the C math library's symbols (acos, atan2, sinh...)
    made visible to the JIT's linker."""
    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    libm = ctypes.util.find_library("m")
    if libm is not None:
        llvm.load_library_permanently(libm)


_PROGRAMS: dict[tuple[Any, ...], Program] = {}
_MAX_PROGRAMS = 64


def _checked(brdf_file: BrdfFile) -> Program:
    """The parsed and checked program of ``brdf_file``'s shader (kept per file: a specialization compiles the
    same program again with other constants)."""
    key = (brdf_file.path, brdf_file.shader, brdf_file.shader_line, tuple(brdf_file.params))
    program = _PROGRAMS.get(key)
    if program is None:
        unit = parse_shader(brdf_file.shader, brdf_file.path, brdf_file.shader_line)
        program = check_program(unit, brdf_file.params, brdf_file.path, brdf_file.shader_line)
        if len(_PROGRAMS) >= _MAX_PROGRAMS:
            _PROGRAMS.clear()
        _PROGRAMS[key] = program
    return program


def _target_machine() -> llvm.TargetMachine:
    """A target machine for this host's CPU (a new one per module: the JIT engine takes ownership of it)."""
    target = llvm.Target.from_default_triple()
    try:
        cpu, features = llvm.get_host_cpu_name(), llvm.get_host_cpu_features().flatten()
    except RuntimeError:  # features are not available on every host
        cpu, features = "", ""
    return target.create_target_machine(cpu=cpu, features=features, opt=OPTIMIZATION_LEVEL, jit=True)


@dataclass(frozen=True, eq=False)
class CompiledBrdf:
    """A ``.brdf`` shader compiled to native code; keep this object alive while its address is in use.

    Attributes
    ----------
    source : BrdfFile
        The file it was compiled from (its parameters give the layout of ``p``).
    address : int
        Address of ``void brdf(lx, ly, lz, vx, vy, vz, const double* p, int64_t n, double* out)``.
    batch_address : int
        Address of ``void brdf_batch(int64_t count, const double* L, const double* V, const double* p,
        int64_t n, double* out)`` over ``count`` rows of three doubles.
    uses_tangents : bool
        True if ``BRDF`` reads its ``X`` or ``Y`` argument (itself or by passing it to a function): the
        model may be anisotropic.
    reads_uniforms : frozenset[str]
        The parameters the code reachable from ``BRDF`` reads.
    """

    source: BrdfFile
    address: int
    batch_address: int
    uses_tangents: bool
    reads_uniforms: frozenset[str]
    _engine: llvm.ExecutionEngine = field(repr=False)

    def evaluate(self, wi: np.ndarray, wo: np.ndarray, params: np.ndarray | None = None) -> np.ndarray:
        """The shader's ``BRDF(L=wi, V=wo, ...)`` for each row, through the compiled batch function.

        Parameters
        ----------
        wi : (n, 3) float64
            ``L``, toward the light, in the local frame (normal +z).
        wo : (n, 3) float64
            ``V``, toward the viewer.
        params : (k,) float64, optional
            The parameter vector (see :meth:`BrdfFile.default_parameters`); the defaults if omitted.

        Returns
        -------
        (n, 3) float64
            The raw RGB value of the shader.
        """
        lights = np.ascontiguousarray(wi, dtype=np.float64)
        views = np.ascontiguousarray(wo, dtype=np.float64)
        if lights.ndim != 2 or lights.shape[1] != 3 or views.shape != lights.shape:
            raise ValueError(f"wi and wo must both be (n, 3) arrays, got {np.shape(wi)} and {np.shape(wo)}")
        vector = (
            self.source.default_parameters()
            if params is None
            else np.ascontiguousarray(params, dtype=np.float64)
        )
        expected = sum(param.slot_count for param in self.source.params)
        if vector.shape != (expected,):
            raise ParameterError(
                f"{self.source.path}: expected {expected} parameter values, got shape {vector.shape}"
            )
        out = np.empty_like(lights)
        batch = _BATCH_SIGNATURE(self.batch_address)
        batch(
            len(lights),
            lights.ctypes.data,
            views.ctypes.data,
            vector.ctypes.data,
            len(vector),
            out.ctypes.data,
        )
        return out


def compile_brdf(brdf_file: BrdfFile, uniforms: Sequence[float] | None = None) -> CompiledBrdf:
    """Compile the shader of ``brdf_file`` to native code (in double precision, optimized at O2). Safe to
    call from several threads (the LLVM part runs one at a time).

    ``uniforms``: a parameter vector to compile in as constants (the optimizer then computes what depends on
    the parameters alone once, here, instead of at every call); the code ignores the ``p`` it is given.

    Raises
    ------
    ShaderError
        The shader does not parse or does not type-check; the message names the file, line and column.
    """
    program = _checked(brdf_file)
    if uniforms is not None:
        uniforms = [float(u) for u in uniforms]
        expected = sum(param.slot_count for param in brdf_file.params)
        if len(uniforms) != expected:
            raise ParameterError(
                f"{brdf_file.path}: expected {expected} parameter values, got {len(uniforms)}"
            )
    module_ir = str(build_module(program, name=Path(brdf_file.path).stem or "shader", uniforms=uniforms))
    with _LLVM_LOCK:
        _initialize_llvm()
        machine = _target_machine()
        module = llvm.parse_assembly(module_ir)
        module.triple = machine.triple
        module.data_layout = str(machine.target_data)
        module.verify()
        tuning = llvm.create_pipeline_tuning_options(speed_level=OPTIMIZATION_LEVEL)
        pass_builder = llvm.create_pass_builder(machine, tuning)
        pass_builder.getModulePassManager().run(module, pass_builder)
        engine = llvm.create_mcjit_compiler(module, machine)
        engine.finalize_object()
        address = engine.get_function_address(ENTRY_NAME)
        batch_address = engine.get_function_address(BATCH_NAME)
    return CompiledBrdf(
        source=brdf_file,
        address=address,
        batch_address=batch_address,
        uses_tangents=program.uses_tangents,
        reads_uniforms=program.reads_uniforms,
        _engine=engine,
    )
