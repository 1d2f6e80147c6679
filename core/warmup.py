"""Compile every cached kernel of ``core`` once, at setup: ``python -m core.warmup``.

numba compiles a ``cache=True`` function on its first call and stores it on disk, stamped by the sources it
imports (:mod:`core._numba_cache`): after an edit, the compiles that could have seen it are made again, minutes
on two cores for the model switch. The warm-up pays that cost at setup (``make setup`` runs it after every
change of the sources; what is still valid only loads) instead of in the first render, the first test or the
app's first edit.

Each entry of :data:`WARM_UPS` is a :class:`WarmUp`, a label and a function that calls one group of kernels
on tiny inputs through the same public functions the program uses, so that the argument types (and the
compiled signatures) are the program's. Another package adds its groups by appending to the list (the
renderer's, which ``core`` cannot import, are in :mod:`renderer.tracer_warmup`).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from typing import NamedTuple, TextIO

import numpy as np


class WarmUp(NamedTuple):
    """One group of kernels to compile."""

    label: str
    """What the line of the report names."""
    run: Callable[[], object]
    """Calls every kernel of the group once (on tiny inputs)."""


def _directions() -> tuple[np.ndarray, np.ndarray]:
    """Two pairs ``(wi, wo)`` of unit directions, ``(2, 3)`` each: one above the horizon, one below."""
    wi = np.array([[0.3, 0.1, 0.948683298050514], [0.0, 0.6, -0.8]])
    wo = np.array([[-0.2, 0.4, 0.894427190999916], [0.6, 0.0, 0.8]])
    return wi, wo


def _model_batches() -> int:
    """The batch drivers of :mod:`core.kernels` (one loop for all models), for every model id."""
    from core.brdf import all_models
    from core.kernels import eval_batch, eval_into, pdf_batch, sample_batch

    wi, wo = _directions()
    u = np.full((2, 3), 0.5)
    f, where = np.empty((2, 3)), np.array([True, False])
    models = all_models()
    for model in models:
        p = model.kernel_params()
        for threads in (False, True):
            eval_batch(model.id, wi, wo, p, threads=threads)
        eval_into(model.id, wi, wo, p, f, where)
        sample_batch(model.id, wo, p, u)
        pdf_batch(model.id, wo, wi, p)
    return len(models)


def _measured() -> None:
    """The MERL writer's loop (:func:`core.merl.tabulate`) and the measured lookups (in the switch above)."""
    from core.brdf import make_brdf
    from core.merl import MeasuredBRDF, tabulate

    table = tabulate(make_brdf("lambert"), subcells=1)
    wi, wo = _directions()
    for interpolate in (True, False):
        MeasuredBRDF(table, None, interpolate).eval(wo, wi)


def _rgl() -> None:
    """RGL ``.bsdf`` materials: the exporter's loops (:func:`core.rgl.export.tabulate`, small tables) and the
    ``rgl_warp`` sampler's draws and densities (the lookups are in the switch above)."""
    from core.brdf import make_brdf
    from core.rgl.export import ExportOptions, tabulate
    from core.rgl.material import RGLBRDF
    from core.sampling import make_sampler

    small = ExportOptions(
        n_theta_i=3, vndf=(4, 4), samples=(4, 4), ndf=(4, 4), sigma=(4, 4), quadrature=(8, 8)
    )
    brdf = RGLBRDF(tabulate(make_brdf("lambert"), small))
    _, wo = _directions()
    sampler = make_sampler("rgl_warp", brdf)
    drawn = sampler.sample_each(wo, seed=1)
    sampler.pdf(wo, drawn.wi)


def _basic_samplers() -> None:
    """``uniform``, ``cosine`` and ``analytic`` (sample, ``f`` and pdf)."""
    from core.brdf import make_brdf
    from core.sampling import make_sampler

    _, wo = _directions()
    brdf = make_brdf("phong")
    for name in ("uniform", "cosine", "analytic"):
        sampler = make_sampler(name, brdf)
        drawn = sampler.sample_each(wo, seed=1)
        sampler.pdf(wo, drawn.wi)


def _tabulated_samplers() -> None:
    """``uniform_cdf``, ``compress_cdf`` and ``factored`` on tiny tables (isotropic and anisotropic)."""
    from core.brdf import make_brdf
    from core.sampling import make_sampler

    _, wo = _directions()
    small = {
        "uniform_cdf": {"n_theta_o": 2, "n_theta": 4, "n_phi": 4, "substeps": 1},
        "compress_cdf": {"n_theta_o": 2, "n_theta": 4, "n_phi": 4, "substeps": 1},
        "factored": {"n_theta_o": 2, "n_phi_o": 2, "n_theta_p": 4, "n_phi_p": 4, "terms_j": 1, "terms_k": 1},
    }
    for brdf in (make_brdf("phong"), make_brdf("ward", {"sx": 0.1, "sy": 0.3})):
        for name, options in small.items():
            sampler = make_sampler(name, brdf, **options)
            drawn = sampler.sample_each(wo, seed=1)
            sampler.pdf(wo, drawn.wi)
            sampler.eval_pdf_where(wo, drawn.wi, np.array([True, False]), drawn.f, drawn.pdf)


def _adaptive_sampler() -> None:
    """The adaptive sampler: the construction (a small table of an isotropic and an anisotropic material,
    not stored), and both modes' draws, densities, normalizer and acceptance (serial and threaded)."""
    from core.brdf import make_brdf
    from core.geometry import degrees_to_dir
    from core.sampling.adaptive import AdaptiveSampler, clear_memory_cache
    from core.sampling.adaptive import sampler as adaptive

    wo = np.repeat(degrees_to_dir(40.0, 30.0)[None, :], 4, axis=0)
    small = {"max_thetas": 7, "warp_tol": 0.5, "quad_tol": 1e-2, "phi_count": 2, "capacity": 256}
    for brdf in (make_brdf("phong"), make_brdf("ward", {"sx": 0.1, "sy": 0.3})):
        for mode in ("exact", "warp"):
            for threads in (False, True):
                sampler = AdaptiveSampler(brdf, mode=mode, cache=False, threads=threads, **small)
                old = adaptive.PARALLEL_MIN
                adaptive.PARALLEL_MIN = 1  # the threaded loop compiles on a tiny batch too
                try:
                    drawn = sampler.sample_each(wo, seed=1)
                finally:
                    adaptive.PARALLEL_MIN = old
                sampler.eval_pdf(wo, drawn.wi)
                sampler.normalizer(wo)
                sampler.acceptance(wo)
    clear_memory_cache()


def _random_streams() -> None:
    """The counter-based random streams of :mod:`core.rng`."""
    from core.rng import stream

    stream(1, 2)


WARM_UPS: list[WarmUp] = [
    WarmUp("models: eval, sample, pdf batches", _model_batches),
    WarmUp("measured (MERL) lookups and writer", _measured),
    WarmUp("measured (RGL .bsdf) exporter and the rgl_warp sampler", _rgl),
    WarmUp("samplers: uniform, cosine, analytic", _basic_samplers),
    WarmUp("samplers: uniform_cdf, compress_cdf, factored", _tabulated_samplers),
    WarmUp("random streams", _random_streams),
    WarmUp("adaptive sampler: construction, both modes' draws and densities", _adaptive_sampler),
]
"""The groups ``python -m core.warmup`` compiles, in order."""


def run(warm_ups: Sequence[WarmUp], out: TextIO = sys.stdout) -> float:
    """Run every group, printing one line per group with its seconds; returns the total seconds."""
    from core._numba_cache import configure

    folder = configure()
    print(f"numba cache: {folder if folder is not None else '(next to the sources)'}", file=out, flush=True)
    total = 0.0
    for warm_up in warm_ups:
        t0 = time.perf_counter()
        warm_up.run()
        seconds = time.perf_counter() - t0
        total += seconds
        print(f"{seconds:8.1f} s  {warm_up.label}", file=out, flush=True)
    print(f"{total:8.1f} s  total", file=out, flush=True)
    return total


WARM_UP_MODULES = ("core.warmup", "renderer.tracer_warmup")
"""Every warm-up of the distribution, by module: what ``brdf-studio setup`` and the wheel's build run, each in
its own process (:func:`run_in_processes`; ``core`` names the renderer's module, it never imports it)."""


def run_in_processes(modules: Sequence[str], out: TextIO = sys.stdout) -> int:
    """Run ``python -m MODULE`` for each of ``modules`` (warm-up modules such as this one) at the same time,
    each in its own process, and relay their lines to ``out`` prefixed by the module's package as they come;
    returns 0, or the first non-zero exit code. numba compiles one function at a time in a process (it holds
    a lock), so independent groups compile in parallel only in separate processes; a kernel both groups call
    is compiled by whichever gets there first and loaded from the cache by the other when it is stored in
    time (numba writes each cache file whole, under a temporary name)."""
    import subprocess
    import threading

    lock = threading.Lock()

    def relay(name: str, stream: TextIO) -> None:
        for line in stream:
            with lock:
                print(f"[{name}] {line.rstrip()}", file=out, flush=True)

    procs, threads = [], []
    for module in modules:
        proc = subprocess.Popen(
            [sys.executable, "-m", module], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        assert proc.stdout is not None
        t = threading.Thread(target=relay, args=(module.partition(".")[0], proc.stdout), daemon=True)
        t.start()
        procs.append(proc)
        threads.append(t)
    codes = [proc.wait() for proc in procs]
    for t in threads:
        t.join()
    return next((c for c in codes if c != 0), 0)


def main() -> int:
    """``python -m core.warmup``: compile (or load) every group of :data:`WARM_UPS`."""
    run(WARM_UPS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
