"""How a BRDF model is declared, registered and bound to parameter values.

A model is declared once, in its own module under ``core/models/``: its parameters, its traits and its
numba kernels. Everything else (the property editor, the samplers, the renderer, the tests) reads the
declaration and needs no per-model code.

Kernel conventions (all in the local shading frame, z = normal; directions are 3-tuples of float64):

``eval(wi, wo, p) -> (r, g, b)``
    the BRDF value ``f_r`` for incident ``wi`` and outgoing ``wo`` (the seed's ``v`` and ``u``). ``p`` is the
    float64 kernel parameter vector (see :meth:`Model.kernel_params`). Must return finite, non-negative
    values for every pair of unit vectors, zero when either lies below the horizon.
``sample(wo, p, u1, u2, u3) -> (x, y, z, pdf)``
    an analytic importance sample ``wi`` for outgoing ``wo`` from three uniforms in [0, 1), with its density
    per unit solid angle. The density may put mass below the horizon (such samples carry no energy); it must
    equal ``pdf(wo, wi, p)`` at the returned direction.
``pdf(wo, wi, p) -> float``
    the density of ``sample`` per unit solid angle at any unit vector ``wi`` (either hemisphere).
"""

from __future__ import annotations

import enum
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from core.errors import ParameterError, UnknownNameError

if TYPE_CHECKING:
    from core.model_files import ModelSource

ParamValue = float | tuple[float, float, float]


class Traits(enum.Flag):
    """Physical properties a model guarantees for every parameter setting within its bounds."""

    NONE = 0
    ISOTROPIC = enum.auto()
    """Invariant under a common rotation of ``wi`` and ``wo`` about the normal."""
    RECIPROCAL = enum.auto()
    """``f(wi, wo) == f(wo, wi)``."""
    ENERGY_CONSERVING = enum.auto()
    """Directional albedo ``rho(wo) <= 1`` for every ``wo``."""
    MIRROR_SYMMETRIC = enum.auto()
    """Invariant under mirroring ``wi`` and ``wo`` together in the x-z plane, and in the y-z plane (the
    tangent frame's axes are the anisotropy's axes of symmetry). The adaptive sampler then builds trees for
    one quadrant of ``phi_o`` only."""


@dataclass(frozen=True)
class Param:
    """One user-facing parameter of a model.

    ``kind`` is ``"float"`` (one slot in the kernel vector), ``"color"`` (three slots, linear RGB, each channel
    within ``[lo, hi]``) or ``"bool"`` (one slot, 0 or 1).
    """

    name: str
    default: ParamValue
    lo: float = 0.0
    hi: float = 1.0
    unit: str = ""
    label: str = ""
    log: bool = False
    kind: Literal["float", "color", "bool"] = "float"
    doc: str = ""

    @property
    def size(self) -> int:
        return 3 if self.kind == "color" else 1

    def range_text(self) -> str:
        if self.kind == "bool":
            return "true or false"
        return f"[{self.lo:g}, {self.hi:g}]"

    def validate(self, model_name: str, value: Any) -> ParamValue:
        """Return ``value`` normalized (colors as 3-tuples), or raise :class:`ParameterError`."""
        where = f"parameter '{self.name}' of model '{model_name}'"
        if self.kind == "bool":
            if isinstance(value, str):
                low = value.strip().lower()
                if low in ("true", "1", "yes", "on"):
                    return 1.0
                if low in ("false", "0", "no", "off"):
                    return 0.0
                raise ParameterError(f"{where} must be true or false, got {value!r}")
            try:
                f = float(value)
            except (TypeError, ValueError, OverflowError):
                raise ParameterError(f"{where} must be true or false, got {value!r}") from None
            if f not in (0.0, 1.0):
                raise ParameterError(f"{where} must be true or false, got {value!r}")
            return f
        if self.kind == "color":
            if isinstance(value, str):
                value = [v for v in value.replace(";", ",").split(",") if v.strip()]
            if np.ndim(value) == 0:
                value = (value, value, value)
            vals = list(value)
            if len(vals) == 1:
                vals = vals * 3
            if len(vals) != 3:
                raise ParameterError(f"{where} is an RGB color: give one number or three, got {len(vals)}")
            return tuple(self._check_number(where, v) for v in vals)  # type: ignore[return-value]
        return self._check_number(where, value)

    def _check_number(self, where: str, v: Any) -> float:
        try:
            f = float(v)
        except (TypeError, ValueError, OverflowError):
            raise ParameterError(f"{where} must be a number in {self.range_text()}, got {v!r}") from None
        if not math.isfinite(f):
            raise ParameterError(f"{where} must be a finite number in {self.range_text()}, got {f}")
        if not (self.lo <= f <= self.hi):
            raise ParameterError(f"{where} = {f:g} is outside its allowed range {self.range_text()}")
        return f


def _has_trait(trait: Traits) -> property:
    """A read-only ``bool`` property of a :class:`Model`: whether its traits include ``trait``."""
    return property(lambda model: trait in model.traits, doc=f"Whether the model is {trait.name}.")


@dataclass(frozen=True)
class Model:
    """A BRDF model: its declaration and its kernels. Create with :func:`declare` in the model's module."""

    name: str
    label: str
    citation: str
    params: tuple[Param, ...]
    traits: Traits
    eval: Callable[..., tuple[float, float, float]]
    sample: Callable[..., tuple[float, float, float, float]] | None = None
    pdf: Callable[..., float] | None = None
    derive: Callable[[np.ndarray], np.ndarray] | None = None
    """Optional: maps the user parameter vector to the full kernel vector (appending tables or constants)."""
    doc: str = ""
    notes: str = ""
    """How a shading model becomes a BRDF, known limits, and the like."""
    measured: bool = False
    defaults_override: Mapping[str, ParamValue] = field(default_factory=dict)
    source: ModelSource | None = None
    """Where a model loaded from a file comes from (:mod:`core.model_files`); ``None`` for a built-in."""

    def __post_init__(self) -> None:
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError(f"model {self.name}: duplicate parameter names")

    @property
    def id(self) -> int:
        """The model's id in the compiled switch of :mod:`core.dispatch`."""
        from core.dispatch import FILE_MODEL, model_id

        return FILE_MODEL if self.source is not None else model_id(self.name)

    def __reduce_ex__(self, protocol: Any) -> str | tuple[Any, ...]:
        # a file model travels as its text and loads again on arrival (its native functions are the process's)
        if self.source is not None:
            from core.model_files import loaded_from_source

            return loaded_from_source, (self.source.path, self.source.text)
        return super().__reduce_ex__(protocol)

    isotropic = _has_trait(Traits.ISOTROPIC)
    reciprocal = _has_trait(Traits.RECIPROCAL)
    energy_conserving = _has_trait(Traits.ENERGY_CONSERVING)
    mirror_symmetric = _has_trait(Traits.MIRROR_SYMMETRIC)

    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        allowed = ", ".join(p.name for p in self.params) or "(none)"
        raise ParameterError(f"model '{self.name}' has no parameter '{name}'; its parameters are: {allowed}")

    def defaults(self) -> dict[str, ParamValue]:
        return {p.name: self.defaults_override.get(p.name, p.default) for p in self.params}

    def resolve(self, values: Mapping[str, Any] | None = None) -> dict[str, ParamValue]:
        """Defaults updated with ``values``, every entry validated."""
        out = self.defaults()
        for name, value in (values or {}).items():
            out[name] = self.param(name).validate(self.name, value)
        return {p.name: p.validate(self.name, out[p.name]) for p in self.params}

    def user_vector(self, values: Mapping[str, ParamValue]) -> np.ndarray:
        flat: list[float] = []
        for p in self.params:
            v = values[p.name]
            flat.extend(v if isinstance(v, tuple) else (v,))
        return np.asarray(flat, dtype=np.float64)

    def kernel_params(self, values: Mapping[str, Any] | None = None) -> np.ndarray:
        """The float64 vector the kernels take: user parameters in declaration order, then derived data."""
        vec = self.user_vector(self.resolve(values))
        if self.derive is not None:
            vec = np.ascontiguousarray(self.derive(vec), dtype=np.float64)
        return vec

    def bind(self, values: Mapping[str, Any] | None = None, **kwargs: Any) -> BRDF:
        """A :class:`BRDF`: this model with validated parameter values."""
        merged = dict(values or {})
        merged.update(kwargs)
        return BRDF(self, self.resolve(merged))


class BRDF:
    """A model bound to parameter values; vectorized evaluation in the local frame.

    Note the argument order of the Python API, ``eval(wo, wi)``: the outgoing (view) direction first, as the
    samplers take it; the kernels take ``(wi, wo, p)``.
    """

    def __init__(self, model: Model, values: Mapping[str, ParamValue], params: np.ndarray | None = None):
        self.model = model
        self.values = dict(values)
        self.params = params if params is not None else model.kernel_params(values)

    @property
    def name(self) -> str:
        return self.model.name

    def key(self) -> str:
        """A stable text key of model and parameter values (for caches); a file model's names its content."""
        items = ",".join(f"{k}={v!r}" for k, v in sorted(self.values.items()))
        source = self.model.source
        name = self.model.name if source is None else f"{self.model.name}@{source.digest[:16]}"
        return f"{name}({items})"

    def __reduce_ex__(self, protocol: Any) -> str | tuple[Any, ...]:
        if self.model.source is not None:
            # bound again on arrival: a file model's parameter row holds this process's addresses
            return _bind_again, (self.model, self.values)
        return super().__reduce_ex__(protocol)

    def eval(self, wo: np.ndarray, wi: np.ndarray, threads: bool = False) -> np.ndarray:
        """``f_r`` as RGB, shape ``(n, 3)``, for directions ``wo`` and ``wi`` of shape ``(3,)`` or ``(n, 3)``."""
        from core.kernels import eval_batch

        wo, wi = _as_pairs(wo, wi)
        return eval_batch(self.model, wi, wo, self.params, threads=threads)

    def luminance(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """Scalar ``f_r`` (Rec. 709 luminance of the RGB value), shape ``(n,)``."""
        return luminance(self.eval(wo, wi))

    def __repr__(self) -> str:
        return f"BRDF({self.key()})"


def _bind_again(model: Model, values: Mapping[str, ParamValue]) -> BRDF:
    return BRDF(model, values)


LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def luminance(rgb: np.ndarray) -> np.ndarray:
    return np.asarray(rgb) @ LUMINANCE


def _as_pairs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.atleast_2d(np.asarray(a, dtype=np.float64))
    b = np.atleast_2d(np.asarray(b, dtype=np.float64))
    a, b = np.broadcast_arrays(a, b)
    return np.ascontiguousarray(a), np.ascontiguousarray(b)


_REGISTRY: dict[str, Model] = {}


def register(model: Model) -> Model:
    """Add ``model`` to the registry (by its ``name``) and return it."""
    if model.name in _REGISTRY:
        raise ValueError(f"model '{model.name}' registered twice")
    _REGISTRY[model.name] = model
    return model


def declare(namespace: Mapping[str, Any], label: str, traits: Traits, **fields: Any) -> Model:
    """Register the model a module of ``core/models/`` declares, read from its ``namespace`` (``globals()``).

    The module's names say the rest: the model is named after the module (``core.models.ward`` declares
    ``ward``), its parameters are ``PARAMS``, its citation ``CITATION``, its notes ``NOTES`` (optional), its
    documentation the module's docstring, and its kernels ``eval_<module>``, ``sample_<module>``,
    ``pdf_<module>`` and ``derive_<module>`` (all but ``eval`` optional). ``fields`` give any other
    :class:`Model` field, or one of these in place of the module's (two models of one module differ in
    ``name`` and ``params``)::

        WARD = declare(globals(), "Ward (1992)", Traits.RECIPROCAL | Traits.MIRROR_SYMMETRIC)
    """
    module = str(namespace["__name__"]).rpartition(".")[2]
    declared: dict[str, Any] = {
        "name": module,
        "citation": namespace["CITATION"],
        "params": namespace["PARAMS"],
        "eval": namespace[f"eval_{module}"],
        "sample": namespace.get(f"sample_{module}"),
        "pdf": namespace.get(f"pdf_{module}"),
        "derive": namespace.get(f"derive_{module}"),
        "doc": namespace.get("__doc__") or "",
        "notes": namespace.get("NOTES", ""),
    }
    return register(Model(label=label, traits=traits, **(declared | fields)))


def _load_models() -> None:
    import core.models  # noqa: F401  (registers every model module)


def all_models() -> list[Model]:
    """Every registered model, in registration order."""
    _load_models()
    return list(_REGISTRY.values())


def get_model(name: str | os.PathLike[str]) -> Model:
    """The model registered as ``name``, or the model a ``.brdf`` or ``.py`` file declares when ``name`` is
    such a path (:func:`core.model_files.load_model_file`; relative to the working directory)."""
    from core.model_files import is_model_file, load_model_file

    if is_model_file(name):
        return load_model_file(name)
    _load_models()
    try:
        return _REGISTRY[str(name)]
    except KeyError:
        raise UnknownNameError(
            f"unknown model '{name}'; known models: {', '.join(sorted(_REGISTRY))}, "
            "or a model file (.brdf, .py)"
        ) from None


def make_brdf(name: str | os.PathLike[str], params: Mapping[str, Any] | Sequence[str] | None = None) -> BRDF:
    """A BRDF from a model name or model file and parameters (a mapping, or ``["k=v", ...]`` strings as the
    CLI takes)."""
    return get_model(name).bind(parse_assignments(params))


def param_offsets(params: Sequence[Param], *names: str) -> tuple[int, ...]:
    """The offset in the kernel row of each named parameter, in the order the names are given.

    The kernel row holds the parameters in declaration order, one slot for a ``float`` or ``bool`` and three
    for a ``color`` (red, green, blue); a parameter's offset is its first slot, so a color's green channel is
    ``p[KD + 1]``. A model module names its slots once, at import, from the same declaration the rest of the
    program reads, and its kernels read ``p[ALPHA]``, never ``p[3]``: the offsets follow any edit of the
    declaration, and numba compiles a module's int constants into its kernels as literals::

        PARAMS = (Param("kd", (0.5, 0.5, 0.5), kind="color"), Param("ks", 0.5), Param("n", 60.0, 1.0, 1e4))
        KD, KS, N = param_offsets(PARAMS, "kd", "ks", "n")  # 0, 3, 4
        DERIVED = param_row_size(PARAMS)  # 5: where derive appends its data

    Raises :class:`~core.errors.ParameterError` for a name that ``params`` does not declare (the message lists
    the ones it does) or declares twice.
    """
    offsets: dict[str, int] = {}
    at = 0
    for p in params:
        if p.name in offsets:
            raise ParameterError(f"parameter '{p.name}' is declared twice")
        offsets[p.name] = at
        at += p.size
    unknown = [name for name in names if name not in offsets]
    if unknown:
        raise ParameterError(
            f"no parameter {', '.join(repr(name) for name in unknown)}; "
            f"the parameters are: {', '.join(offsets) or '(none)'}"
        )
    return tuple(offsets[name] for name in names)


def param_row_size(params: Sequence[Param]) -> int:
    """The number of kernel-row slots ``params`` take: the offset at which a model's ``derive`` appends."""
    return sum(p.size for p in params)


def parse_assignments(params: Mapping[str, Any] | Sequence[str] | None) -> dict[str, Any]:
    if params is None:
        return {}
    if isinstance(params, Mapping):
        return dict(params)
    out: dict[str, Any] = {}
    for item in params:
        if "=" not in item:
            raise ParameterError(f"parameter '{item}' must be written name=value")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out
