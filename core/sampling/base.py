"""The one sampling interface every strategy implements, and the registry of strategies by name.

``sample(wo, n, seed) -> SampleBatch``
    ``n`` directions for one outgoing direction ``wo (3,)``.
``sample_each(wo (n, 3), seed) -> SampleBatch``
    one direction for each row of ``wo`` (what a wavefront renderer needs).
``pdf(wo, wi) -> (n,)``
    the density per unit solid angle of the samples the strategy makes, at any unit vector ``wi``.
``eval(wo, wi) -> (n, 3)``
    the BRDF being sampled.

A :class:`SampleBatch` carries, as pbrt's ``BSDFSample`` does, everything computed for the draw: the
directions ``wi``, their density ``pdf`` and the BRDF value ``f`` there, so no caller evaluates the BRDF again.
All in the local frame (z = normal), reproducible for a given seed. A strategy may return directions below the
horizon (a lobe that spills over, a reflection about a half vector that leans away from ``wo``); they carry no
energy (``f = 0``), and ``pdf`` accounts for them: ``pdf(wo, .)`` is the density of the draws over the whole
sphere (it integrates to 1 there for ``wo`` above the horizon), and each draw carries ``pdf(wo, wi)`` at its
``wi``. A draw a strategy could not make is flagged by ``pdf = 0`` (and ``f = 0``); callers skip it
(``tests/core/test_sampler_horizon.py``).

Strategies live in the modules and subpackages of :mod:`core.sampling` and call :func:`register_sampler` when
imported; :func:`make_sampler` imports them all on first use, so adding a strategy is adding a module. A former
name of a strategy (:func:`register_former_name`) is accepted wherever a user names one: :func:`current_sampler`
maps it to the current name, with a :class:`~core.errors.FormerSamplerName` notice that names it.
"""

from __future__ import annotations

import importlib
import math
import os
import pkgutil
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np

from core.brdf import BRDF
from core.errors import FormerSamplerName, ParameterError, UnknownNameError
from core.kernels import DirectionSamples, eval_into


class SampleBatch(NamedTuple):
    """Directions drawn by a sampler and what was computed for them (pbrt's ``BSDFSample``)."""

    wi: np.ndarray
    """``(n, 3)`` float64: incident directions, unit vectors in the local frame (possibly below the horizon)."""
    pdf: np.ndarray
    """``(n,)`` float64: their density per unit solid angle, equal to :meth:`Sampler.pdf` there (below the
    horizon too); 0 flags a draw that could not be made."""
    f: np.ndarray
    """``(n, 3)`` float64: the BRDF's RGB value at ``(wo, wi)``; 0 where ``wi`` is below the horizon."""


def _pairs(wo: np.ndarray, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    wo = np.atleast_2d(np.asarray(wo, dtype=np.float64))
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float64))
    wo, wi = np.broadcast_arrays(wo, wi)
    return np.ascontiguousarray(wo), np.ascontiguousarray(wi)


def check_direction(wo: np.ndarray) -> np.ndarray:
    """``wo`` as float64 if it holds finite unit 3-vectors (last axis), else :class:`ParameterError`."""
    wo = np.asarray(wo, dtype=np.float64)
    if wo.shape[-1] != 3 or not np.all(np.isfinite(wo)):
        raise ParameterError("a direction must be three finite numbers")
    norm = np.linalg.norm(wo, axis=-1)
    if np.any(np.abs(norm - 1.0) > 1e-6):
        raise ParameterError("a direction must be a unit vector")
    return wo


def check_points(points: np.ndarray, n: int) -> np.ndarray:
    """``points`` as a C-contiguous ``(n, 2)`` float64 array of numbers in ``[0, 1)``, else
    :class:`ParameterError` (a caller's uniforms for :meth:`Sampler.sample_into`)."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    if points.shape != (n, 2):
        raise ParameterError(f"points must be ({n}, 2), got {points.shape}")
    if not (np.all(points >= 0.0) and np.all(points < 1.0)):  # NaN fails both
        raise ParameterError("points must be numbers in [0, 1)")
    return points


# a buffer's columns (0: a vector) and dtype by its name; any other name is (n, 3) float64
_BUFFER_KINDS = {"pdf": (0, np.float64), "mask": (0, np.bool_)}


def check_buffers(n: int, **arrays: np.ndarray) -> None:
    """:class:`ParameterError` unless every named array is a writable or readable buffer compiled loops may
    index without bounds checks: C-contiguous, ``n`` rows, ``(n, 3)`` float64 for directions and values
    (``wi``, ``f``), ``(n,)`` float64 for densities (``pdf``), ``(n,)`` bool for a row ``mask``."""
    for name, a in arrays.items():
        columns, dtype = _BUFFER_KINDS.get(name, (3, np.float64))
        shape = (n,) if columns == 0 else (n, columns)
        if not isinstance(a, np.ndarray) or a.shape != shape or a.dtype != dtype or not a.flags.c_contiguous:
            got = f"{a.shape} {a.dtype}" if isinstance(a, np.ndarray) else type(a).__name__
            raise ParameterError(
                f"{name} must be a C-contiguous {shape} {np.dtype(dtype).name} array, got {got}"
            )


class Sampler:
    """Base class of the sampling strategies.

    A strategy provides ``_sample_directions(wo (n, 3), u (n, 3)) -> DirectionSamples`` (or, where its kernel
    writes into given arrays, ``_directions_into``, from which the other is made) and
    ``_pdf_rows(wo, wi) -> (n,)``; the base class draws the uniforms and evaluates ``f`` once, in compiled
    code, for the directions drawn. A strategy whose kernels compute ``f`` anyway overrides
    :meth:`_sample_rows` (or :meth:`sample_each` and :meth:`pdf` themselves) and returns it.
    """

    name = "base"
    warp_dims: tuple[int, int] = (0, 1)
    """The columns of the uniforms ``u (n, 3)`` that the strategy's two-dimensional warp reads: a caller's
    stratified points go there (:meth:`sample_into`); the third column is its other choice (a lobe, a factor)."""
    third_uniform: bool = True
    """False: the strategy reads only the warp's two columns (``warp_dims = (0, 1)``); given a caller's points
    :meth:`sample_into` then draws no uniforms of its own (the same draws: the third column was never read)."""

    def __init__(self, brdf: BRDF):
        self.brdf = brdf

    def sample(self, wo: np.ndarray, n: int, seed: int = 0) -> SampleBatch:
        """``n`` samples for one outgoing direction.

        Parameters
        ----------
        wo : (3,) float64
            Unit outgoing direction.
        n : int
            Number of samples (positive).
        seed : int
            The same seed gives the same samples.
        """
        if int(n) <= 0:
            raise ParameterError(f"the number of samples must be positive, got {n}")
        wo = check_direction(wo).reshape(1, 3)
        return self.sample_each(np.repeat(wo, int(n), axis=0), seed)

    def sample_each(self, wo: np.ndarray, seed: int = 0) -> SampleBatch:
        """One sample for each row of ``wo (n, 3)`` (unit outgoing directions)."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        u = np.random.default_rng(seed).random((wo.shape[0], 3))
        return self._sample_rows(wo, u)

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """Density per unit solid angle ``(n,)`` of the samples at ``wi``; ``wo, wi`` of shape (3,) or (n, 3)."""
        wo, wi = _pairs(wo, wi)
        return self._pdf_rows(wo, wi)

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """The BRDF being sampled, ``(n, 3)``."""
        return self.brdf.eval(wo, wi)

    def eval_pdf(self, wo: np.ndarray, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(f (n, 3), pdf (n,))`` at the pairs ``(wo, wi)``: what MIS needs of a light sample. A strategy
        whose density is made of ``f`` (the adaptive sampler's exact mode) computes both in one pass."""
        return self.eval(wo, wi), self.pdf(wo, wi)

    def sample_into(self, wo: np.ndarray, seed: int, wi: np.ndarray, pdf: np.ndarray, f: np.ndarray,
                    points: np.ndarray | None = None) -> None:  # fmt: skip
        """:meth:`sample_each`'s draws (the same uniforms for the same ``seed``) written into the caller's
        C-contiguous float64 arrays ``wi (n, 3)``, ``pdf (n,)``, ``f (n, 3)``: a renderer's buffers, which the
        strategy's compiled loops fill without copies.

        ``points (n, 2)``: uniforms in ``[0, 1)^2`` placed by the caller (a renderer's low-discrepancy
        points), read by the strategy's warp (:attr:`warp_dims`) instead of its own stream; its other
        uniforms still come from ``seed``. Each row's density is unchanged: every point is uniform."""
        wo = np.ascontiguousarray(np.atleast_2d(wo), dtype=np.float64)
        check_buffers(wo.shape[0], wi=wi, pdf=pdf, f=f)
        if points is not None and not self.third_uniform and self.warp_dims == (0, 1):
            u = check_points(points, wo.shape[0])
        else:
            u = np.random.default_rng(seed).random((wo.shape[0], 3))
            if points is not None:
                u[:, list(self.warp_dims)] = check_points(points, wo.shape[0])
        self._directions_into(wo, u, wi, pdf)
        self._f_into(wo, wi, pdf, f)

    def eval_pdf_where(self, wo: np.ndarray, wi: np.ndarray, mask: np.ndarray, f: np.ndarray,
                       pdf: np.ndarray) -> None:  # fmt: skip
        """:meth:`eval_pdf` at the rows where ``mask (n,)`` holds, written into ``f (n, 3)`` and ``pdf (n,)``;
        the other rows are left as they are. Arrays C-contiguous (float64; ``mask`` bool), as in
        :meth:`sample_into`."""
        check_buffers(len(wo), wo=wo, wi=wi, mask=mask, f=f, pdf=pdf)
        eval_into(self.brdf.model.id, wi, wo, self.brdf.params, f, mask)
        self._pdf_where(wo, wi, mask, pdf)

    def compiled_equivalent(self) -> str | None:
        """The name of a strategy drawn in compiled code (``uniform``, ``cosine``, ``analytic``) whose density
        and pdf are this sampler's exactly, for this BRDF: a renderer may draw that one instead. None: no
        such strategy."""
        return None

    def info(self) -> dict[str, Any]:
        """Precomputation facts (memory in bytes, build seconds, ...) for reports."""
        return {"sampler": self.name, "memory_bytes": 0, "build_seconds": 0.0}

    def refresh(self, wait: bool = False) -> bool:
        """Swap in better precomputed tables built in the background, if any are ready; True when the
        density changed. A renderer calls it between passes (never within one: MIS needs one density per
        pass). Samplers without such tables never change."""
        return False

    def preload(self) -> int:
        """Load precomputed tables a disk cache holds (a render's preparation calls it, so that its timed
        passes do not); returns how many. Samplers without such tables have nothing to load."""
        return 0

    # ------------------------------------------------------------------------- what a strategy provides
    def _sample_rows(self, wo: np.ndarray, u: np.ndarray) -> SampleBatch:
        """Samples for the rows of ``wo (n, 3)`` from uniforms ``u (n, 3)``: the strategy's directions, with
        ``f`` evaluated once."""
        drawn = self._sample_directions(wo, u)
        return self._with_f(wo, drawn.wi, drawn.pdf)

    def _sample_directions(self, wo: np.ndarray, u: np.ndarray) -> DirectionSamples:
        """The strategy's directions for the rows of ``wo`` from ``u``, and their density; made from
        :meth:`_directions_into` (into new arrays) for a strategy that provides that one instead."""
        if type(self)._directions_into is Sampler._directions_into:
            raise NotImplementedError
        wi = np.empty_like(wo)
        pdf = np.empty(wo.shape[0])
        self._directions_into(wo, u, wi, pdf)
        return DirectionSamples(wi, pdf)

    def _pdf_rows(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _directions_into(self, wo: np.ndarray, u: np.ndarray, wi: np.ndarray, pdf: np.ndarray) -> None:
        """:meth:`_sample_directions` written into ``wi`` and ``pdf``; a strategy whose kernel can write there
        directly overrides it."""
        drawn = self._sample_directions(wo, u)
        wi[:], pdf[:] = drawn.wi, drawn.pdf

    def _pdf_where(self, wo: np.ndarray, wi: np.ndarray, mask: np.ndarray, pdf: np.ndarray) -> None:
        """:meth:`_pdf_rows` at the rows where ``mask`` holds, written into ``pdf``; a strategy whose kernel
        can skip rows itself overrides it."""
        rows = np.flatnonzero(mask)
        if len(rows):
            pdf[rows] = self._pdf_rows(wo[rows], wi[rows])

    def _f_into(self, wo: np.ndarray, wi: np.ndarray, pdf: np.ndarray, f: np.ndarray) -> None:
        """The BRDF's value at the rows drawn (``pdf > 0``) into ``f``, 0 at the others: a row with no draw
        (a placeholder direction) carries nothing. ``wo`` C-contiguous ``(n, 3)``."""
        drawn = pdf > 0.0
        f[~drawn] = 0.0
        eval_into(self.brdf.model.id, wi, wo, self.brdf.params, f, drawn)

    def _with_f(self, wo: np.ndarray, wi: np.ndarray, pdf: np.ndarray) -> SampleBatch:
        """The batch of directions ``wi (n, 3)`` with densities ``pdf (n,)`` drawn for ``wo`` ((3,) or
        (n, 3)), completed with the BRDF's value there (:meth:`_f_into`)."""
        wo = np.ascontiguousarray(np.broadcast_to(np.asarray(wo, dtype=np.float64), wi.shape))
        f = np.empty(wi.shape)
        self._f_into(wo, np.ascontiguousarray(wi), pdf, f)
        return SampleBatch(wi, pdf, f)


@dataclass(frozen=True)
class SamplerOption:
    """One option a strategy takes, declared with it the way a model declares its :class:`~core.brdf.Param`.

    ``kind``: ``"int"`` (a whole number in ``[lo, hi]``), ``"float"`` (a finite number in ``[lo, hi]``, or
    ``(lo, hi]`` with ``lo_open``), ``"bool"``, ``"choice"`` (one of ``choices``) or ``"cache"`` (true, false
    or a folder that can be written). :func:`make_sampler` checks every option against the declaration before
    any work, so an unknown key, a wrong type, a value out of range or a cache folder that cannot be written is
    a :class:`ParameterError` naming the option and its range (``sampler_options`` of a scene file,
    ``--n-max`` on the command line, the app's fields).
    """

    name: str
    kind: Literal["int", "float", "bool", "choice", "cache"]
    lo: float = 0.0
    hi: float = 0.0
    lo_open: bool = False
    choices: tuple[str, ...] = ()
    doc: str = ""

    def range_text(self) -> str:
        if self.kind == "bool":
            return "true or false"
        if self.kind == "cache":
            return "true, false or a folder"
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        what = "a whole number" if self.kind == "int" else "a number"
        return f"{what} in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"

    def validate(self, sampler: str, value: Any) -> Any:
        """``value`` normalized (``int``, ``float``, ``bool``, ``str``), or :class:`ParameterError`."""
        where = f"option '{self.name}' of the sampler '{sampler}'"
        bad = ParameterError(f"{where} must be {self.range_text()}, got {value!r}")
        if self.kind == "choice":
            if not isinstance(value, str) or value not in self.choices:
                raise bad
            return value
        if self.kind in ("bool", "cache"):
            if isinstance(value, bool):
                return value
            if isinstance(value, int) and value in (0, 1):
                return bool(value)
            if isinstance(value, str):
                low = value.strip().lower()
                if low in ("true", "yes", "on"):
                    return True
                if low in ("false", "no", "off"):
                    return False
                if self.kind == "cache" and value.strip() and "\0" not in value:
                    return self._cache_folder(where, value)
            if self.kind == "cache" and isinstance(value, os.PathLike):
                return self._cache_folder(where, value)
            raise bad
        if isinstance(value, bool) or not isinstance(value, int | float | str | np.integer | np.floating):
            raise bad
        try:
            number = float(value)
        except (TypeError, ValueError, OverflowError):
            raise bad from None
        if not math.isfinite(number):
            raise bad
        low_ok = number > self.lo if self.lo_open else number >= self.lo
        if not (low_ok and number <= self.hi):
            raise bad
        if self.kind == "int":
            if number != int(number):
                raise bad
            return int(number)
        return number

    @staticmethod
    def _cache_folder(where: str, folder: str | os.PathLike[str]) -> str | os.PathLike[str]:
        """A cache folder the user named: refused when it is a file or cannot be written (the tables the
        user asked to keep would silently not be kept). Not made here: a missing folder is judged by the
        nearest one above it, and made when the first table is stored."""
        from core.cache import folder_problem

        problem = folder_problem(folder, create=False)
        if problem is not None:
            raise ParameterError(f"{where}: the folder '{folder}' {problem}")
        return folder


SamplerFactory = Callable[..., Sampler]
FormerNameResolver = Callable[[dict[str, Any]], "tuple[str, dict[str, Any]] | None"]
_SAMPLERS: dict[str, SamplerFactory] = {}
_OPTIONS: dict[str, dict[str, SamplerOption]] = {}
_MEMORY: dict[str, Callable[[BRDF, dict[str, Any]], float]] = {}
_FORMER: dict[str, FormerNameResolver] = {}
_loaded = False


def register_sampler(
    name: str,
    factory: SamplerFactory,
    options: Sequence[SamplerOption] = (),
    memory: Callable[[BRDF, dict[str, Any]], float] | None = None,
) -> None:
    """Make ``factory(brdf, **options) -> Sampler`` available as ``make_sampler(name, brdf, **options)``
    (a later registration of the same name replaces the earlier one). ``options`` declares every option the
    strategy takes; :func:`make_sampler` passes only declared, validated options on. ``memory(brdf, options)``
    estimates the bytes its tables will need, checked against the machine's memory before they are built."""
    _SAMPLERS[name] = factory
    _OPTIONS[name] = {o.name: o for o in options}
    if memory is not None:
        _MEMORY[name] = memory


def register_former_name(name: str, resolve: FormerNameResolver) -> None:
    """Accept ``name`` with the options given with it as a former way of naming a strategy:
    ``resolve(options)`` returns the current name and the options it takes (the former ones removed), or
    ``None`` when ``name`` with these options is current (a registered strategy given only its own options).
    It may raise :class:`ParameterError` for former options that name nothing."""
    _FORMER[name] = resolve


def current_sampler(name: str, options: Mapping[str, Any] | None = None) -> tuple[str, dict[str, Any]]:
    """The current name and options of the strategy a user named as ``name`` with ``options``: a former name
    (or former option) is mapped to the strategy it means, with a :class:`~core.errors.FormerSamplerName`
    notice naming the current name; any other name and its options are returned as given."""
    _load_samplers()
    given = dict(options or {})
    resolve = _FORMER.get(name)
    resolved = resolve(given) if resolve is not None else None
    if resolved is None:
        return name, given
    current, current_options = resolved
    dropped = " and ".join(f"{k}={v!r}" for k, v in given.items() if k not in current_options)
    if current == name:
        text = f"the sampler '{name}' takes no {dropped}: its name says it; leave it out"
    else:
        given_as = f"'{name}' with {dropped}" if dropped else f"'{name}'"
        text = f"{given_as} is a former name of the sampler '{current}'; use '{current}'"
    warnings.warn(text, FormerSamplerName, stacklevel=3)
    return current, current_options


def current_sampler_name(name: str) -> str:
    """The current name of the strategy a user named ``name`` (no options), with the notice of
    :func:`current_sampler` for a former name."""
    return current_sampler(name)[0]


def sampler_option_set(name: str) -> dict[str, SamplerOption]:
    """The options the strategy ``name`` declares, by name (:class:`UnknownNameError` for an unknown name)."""
    _load_samplers()
    if name not in _SAMPLERS:
        raise UnknownNameError(f"unknown sampler '{name}'; known samplers: {', '.join(_SAMPLERS)}")
    return dict(_OPTIONS.get(name, {}))


def check_sampler_options(name: str, options: dict[str, Any]) -> dict[str, Any]:
    """``options`` validated against the declaration of the strategy ``name`` (values normalized); an unknown
    key, a wrong type or a value out of range is a :class:`ParameterError` naming the option and its range."""
    declared = sampler_option_set(name)
    out: dict[str, Any] = {}
    for key, value in options.items():
        option = declared.get(key) if isinstance(key, str) else None
        if option is None:
            if not declared:
                raise ParameterError(f"the sampler '{name}' takes no options, got {key!r}")
            raise ParameterError(
                f"the sampler '{name}' has no option {key!r}; its options: {', '.join(sorted(declared))}"
            )
        out[key] = option.validate(name, value)
    return out


def sampler_names() -> list[str]:
    """Every registered strategy, the basic ones first."""
    _load_samplers()
    return list(_SAMPLERS)


def make_sampler(name: str, brdf: BRDF, **options: Any) -> Sampler:
    """A sampler by name (``uniform``, ``cosine``, ``analytic``, ``adaptive_exact``, ``adaptive_warp``, ...) for
    ``brdf``; a former name is accepted with a notice (:func:`current_sampler`)."""
    _load_samplers()
    if name in _FORMER:
        name, options = current_sampler(name, options)
    try:
        factory = _SAMPLERS[name]
    except KeyError:
        raise UnknownNameError(f"unknown sampler '{name}'; known samplers: {', '.join(_SAMPLERS)}") from None
    checked = check_sampler_options(name, options)
    if name in _MEMORY:
        from core.budget import check_memory

        check_memory(
            _MEMORY[name](brdf, checked),
            f"the sampler '{name}' with these options",
            "lower its table sizes (see 'sampler_options' in docs/validation.md)",
        )
    return factory(brdf, **checked)


def applicable_samplers(brdf: BRDF) -> list[str]:
    """The strategies that can sample ``brdf`` (``analytic`` needs the model's own sampler)."""
    names = sampler_names()
    if brdf.model.sample is None:
        names = [n for n in names if n != "analytic"]
    return names


def _load_samplers() -> None:
    """Import every public module and subpackage of :mod:`core.sampling` (each registers its strategies),
    once; kept lazy because some are heavy. ``basic`` comes first so the basic strategies lead the list."""
    global _loaded
    if _loaded:
        return
    import core.sampling

    importlib.import_module("core.sampling.basic")
    for m in sorted(pkgutil.iter_modules(core.sampling.__path__), key=lambda m: m.name):
        if not m.name.startswith("_"):
            importlib.import_module(f"core.sampling.{m.name}")
    _loaded = True
