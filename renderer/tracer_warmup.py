"""Compile the renderer's cached kernels once, at setup: ``python -m renderer.tracer_warmup`` (after
``python -m core.warmup``, which compiles the models and samplers; see :mod:`core.warmup`).

The kernels (:mod:`renderer.stages`, the environment map's in :mod:`renderer.envmap`) are compiled by
rendering the bundled demo scene (an area light, a sky map, analytic and measured materials) at a few pixels,
so that they see the argument types a real render gives them.

:func:`load_kernels` does the same in a long-lived process that will render later (the app's render
process, while the user sets up the render): loading the compiled kernels from numba's disk cache takes
seconds, which the first render would otherwise wait for.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator, Sequence
from importlib.resources import files

import numpy as np

from core.scene import load_scene
from core.warmup import WarmUp, run


def _demo_render() -> None:
    """Two passes of a 6 x 4 pixel render of the demo scene: BRDF sampling with next-event estimation, then
    the sky by resampled importance sampling."""
    from renderer.render import render

    scene = load_scene(str(files("resources") / "scenes" / "demo" / "demo.json"))
    for ris_candidates in (0, 2):
        render(scene, spp=1, width=6, height=4, max_depth=3, threads=1, ris_candidates=ris_candidates)


SMALL_ADAPTIVE = {"cache": False, "max_thetas": 7, "warp_tol": 0.5, "quad_tol": 1e-2, "phi_count": 2,
                  "capacity": 256}  # fmt: skip
"""Options of the adaptive tables :func:`load_kernels` builds: small (all the kernels of a full build, in a
fraction of its time) and never stored (the table cache holds only the tables renders asked for)."""


KERNEL_MATERIALS = ("floor", "red plastic (measured, synthetic MERL)", "brushed steel")
"""The demo's materials :func:`load_kernels` renders: an isotropic analytic, a measured and an anisotropic
one reach every kernel (one switch serves all models); each further material only adds table builds
(~0.15 s each for the adaptive modes, most of it their normalizer's Python loop)."""


def _kernel_scene():  # type: ignore[no-untyped-def]
    """The bundled demo scene (its light, sky and mesh formats) with the meshes of :data:`KERNEL_MATERIALS`."""
    import json

    from core.scene import scene_from_dict

    folder = files("resources") / "scenes" / "demo"
    data = json.loads((folder / "demo.json").read_text(encoding="utf-8"))
    data["materials"] = [m for m in data["materials"] if m["name"] in KERNEL_MATERIALS]
    data["meshes"] = [m for m in data["meshes"] if m["material"] in KERNEL_MATERIALS]
    return scene_from_dict(data, source="demo.json (kernel loading)", base_dir=str(folder))


class _Stopped(Exception):
    """Raised between two steps of :func:`load_kernels`'s preparation when its caller wants it to stop."""


def load_kernels(
    strategies: Sequence[str] = ("uniform", "adaptive_warp", "adaptive_exact"),
    stop: Callable[[], bool] = lambda: False,
) -> Iterator[tuple[str, float]]:
    """Load into this process every kernel a render with ``strategies`` calls (numba's compiled code, read
    from its disk cache; compiled if the setup's warm-up did not run), by rendering the bundled demo scene
    (analytic, measured and anisotropic materials, an area light and a sky; :func:`_kernel_scene`) at 8x6
    pixels with each strategy in the order given (the first step loads most: the mesh readers, the models,
    the path tracer, and the threaded evaluation the preparation of a large image calls). Adaptive
    strategies build small tables, kept neither on disk nor in memory; other table-based strategies are
    skipped (their first render loads their kernels). Yields ``(strategy, seconds)`` after each step.
    ``stop()`` is asked before each material's preparation and before each pass: once it returns True (a
    render is waiting), loading ends there, and the render loads what is still missing itself."""
    from renderer.render import EAGER_SAMPLERS, prepare

    def check(*_: object) -> None:
        if stop():
            raise _Stopped

    scene = None
    wo = np.array([[0.0, 0.6, 0.8]])
    first = True
    for name in dict.fromkeys(strategies):
        adaptive = name.startswith("adaptive")
        if name not in EAGER_SAMPLERS and not adaptive:
            continue
        t0 = time.perf_counter()
        try:
            check()
            if scene is None:  # read after the first check: a waiting render does not wait for it
                scene = _kernel_scene()
            job = prepare(scene, sampler=name, sampler_options=dict(SMALL_ADAPTIVE) if adaptive else {},
                          width=8, height=6, seed=0, on_step=check)  # fmt: skip
            try:
                check()
                job.run(spp=1)
                if first:  # what every strategy's preparation calls on a large image
                    for rt in job.world.materials_by_index:
                        if rt is not None:
                            rt.brdf.eval(wo, wo, threads=True)
                    first = False
            finally:
                job.world.accel.close()
        except _Stopped:
            return
        finally:
            if adaptive:
                from core.sampling.adaptive import clear_memory_cache

                clear_memory_cache()
        yield name, time.perf_counter() - t0


WARM_UPS: list[WarmUp] = [
    WarmUp("renderer: path tracing kernels, environment map (a tiny demo render)", _demo_render),
]
"""The groups ``python -m renderer.tracer_warmup`` compiles, in order."""


def main() -> int:
    """``python -m renderer.tracer_warmup``: compile (or load) every group of :data:`WARM_UPS`."""
    run(WARM_UPS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
