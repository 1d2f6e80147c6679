"""BRDF Explorer's analytic ``.brdf`` files as models: parameters from the file's declarations, ``eval`` from
its shader translated by :mod:`core.glsl` (the file is never executed as Python)."""

from __future__ import annotations

import contextlib
import dataclasses
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from core.brdf import Model, Param, Traits
from core.model_files import ModelFileError, ModelSource
from core.model_files.call import EVAL_ADDRESS, HEADER, eval_file_model

VISUALISATION_PREFIX = "show_"
"""BRDF Explorer's files that only visualise angles or vectors take booleans named ``show_...``."""


def _param(sp) -> Param:  # noqa: ANN001 (core.glsl.ShaderParam)
    if sp.kind == "bool":
        return Param(sp.name, float(sp.default), 0.0, 1.0, kind="bool", label=sp.name)
    if sp.kind == "color":
        hi = max(1.0, *sp.default)
        return Param(sp.name, tuple(float(c) for c in sp.default), 0.0, hi, kind="color", label=sp.name)
    return Param(sp.name, float(sp.default), float(sp.lo), float(sp.hi), label=sp.name)


SPECIALIZE = True
"""Whether shader models bind specialized code (:class:`_Specializations`). The desktop app's own process
turns it off (:func:`set_specialization`): a slider dragged through settings would compile at every step, while
the views evaluate little; its render and sampler processes keep it on."""


def set_specialization(enabled: bool) -> None:
    """Bind shader models to code specialized to each setting (True, the default) or to the general code."""
    global SPECIALIZE
    SPECIALIZE = bool(enabled)


MAX_SPECIALIZATIONS = 256
"""Parameter settings of one model compiled with their values as constants; further settings run the
general code (a specialization's code is never freed: rows in use may hold its address)."""


class _Specializations:
    """The shader compiled once per parameter setting, with the setting's values as constants.

    A shader computes much from its parameters alone at every call (``disney.brdf``: ``pow(baseColor, 2.2)``
    per channel, tints, ``log`` of the clearcoat's roughness), which the built-in models do once in their
    ``derive``. Compiled with the values in place, LLVM folds all of it: ``disney.brdf`` evaluates several
    times faster (``bench/model_files.py``), bit for bit the same values, for about 0.1 s of compile per
    new setting, once per process."""

    def __init__(self, parsed: Any) -> None:
        self.parsed = parsed
        self.compiled: dict[bytes, Any] = {}
        self.enabled = True
        self.lock = threading.Lock()

    def address(self, user: np.ndarray) -> int:
        """The specialized entry's address for ``user`` (compiled on first use), or 0 (the general code)."""
        if not (self.enabled and SPECIALIZE):
            return 0
        key = np.ascontiguousarray(user, dtype=np.float64).tobytes()
        with self.lock:
            compiled = self.compiled.get(key)
            if compiled is None:
                if len(self.compiled) >= MAX_SPECIALIZATIONS:
                    return 0
                from core.glsl import compile_brdf

                compiled = self.compiled[key] = compile_brdf(self.parsed, user)
        return int(compiled.address)

    @contextlib.contextmanager
    def paused(self) -> Iterator[None]:
        self.enabled = False
        try:
            yield
        finally:
            self.enabled = True


def load(path: str, text: str, digest: str) -> Model:
    """The model of a ``.brdf`` file's text (``path`` names it in messages)."""
    from core.glsl import compile_brdf, parse_brdf_text
    from core.model_files.probe import bad_values, measured_traits

    try:
        parsed = parse_brdf_text(text, path)
        shows = [p.name for p in parsed.params if p.name.startswith(VISUALISATION_PREFIX)]
        if shows:
            raise ModelFileError(
                f"{path}: a visualisation file (parameters {', '.join(shows[:3])}...), not a BRDF: "
                "it shows angles or vectors as colours and has no reflectance to sample or render"
            )
        compiled = compile_brdf(parsed)
    except RecursionError:
        raise ModelFileError(f"{path}: the shader is nested too deeply to translate") from None
    header = np.zeros(HEADER)
    header[EVAL_ADDRESS] = float(compiled.address)
    specialized = _Specializations(parsed)

    def derive(user: np.ndarray) -> np.ndarray:
        row = np.concatenate([header, user])
        address = specialized.address(row[HEADER:])
        if address:
            row[EVAL_ADDRESS] = float(address)
        return row

    params = tuple(_param(sp) for sp in parsed.params)
    stem = Path(path).stem
    model = Model(
        name=path,
        label=f"{stem} (.brdf)",
        citation=f"BRDF Explorer shader {path}",
        params=params,
        traits=Traits.NONE,
        eval=eval_file_model,
        derive=derive,
        doc=f"The analytic BRDF of the BRDF Explorer file {path}, translated from its GLSL.",
        source=ModelSource(path=path, text=text, digest=digest, keep=(compiled, specialized)),
    )
    with specialized.paused():  # the probes try a few settings once each: the general code serves them
        traits = measured_traits(params, model.kernel_params)
        findings = tuple(bad_values(model.kernel_params(), Path(path).name))
    source = dataclasses.replace(model.source, findings=findings)  # type: ignore[arg-type]
    return dataclasses.replace(model, traits=traits, source=source)
