"""Compile the renderer's cached kernels once, at setup: ``python -m renderer.warmup`` (after
``python -m core.warmup``, which compiles the models and samplers; see :mod:`core.warmup`).

The kernels (:mod:`renderer.kernels`, the environment map's in :mod:`renderer.envmap`) are compiled by
rendering the bundled demo scene (an area light, a sky map, analytic and measured materials) at a few pixels,
so that they see the argument types a real render gives them.
"""

from __future__ import annotations

import sys
from importlib.resources import files

from core.scene import load_scene
from core.warmup import WarmUp, run


def _demo_render() -> None:
    """Two passes of a 6 x 4 pixel render of the demo scene: BRDF sampling with next-event estimation, then
    the sky by resampled importance sampling."""
    from renderer.render import render

    scene = load_scene(str(files("resources") / "scenes" / "demo" / "demo.json"))
    for ris_candidates in (0, 2):
        render(scene, spp=1, width=6, height=4, max_depth=3, threads=1, ris_candidates=ris_candidates)


WARM_UPS: list[WarmUp] = [
    WarmUp("renderer: path tracing kernels, environment map (a tiny demo render)", _demo_render),
]
"""The groups ``python -m renderer.warmup`` compiles, in order."""


def main() -> int:
    """``python -m renderer.warmup``: compile (or load) every group of :data:`WARM_UPS`."""
    run(WARM_UPS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
