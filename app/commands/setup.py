"""``brdf-studio setup``: compile every kernel now, so that no later run waits for numba.

numba compiles a kernel the first time a process calls it and keeps it in its disk cache
(``$BRDF_STUDIO_NUMBA_CACHE``, default ``~/.cache/brdf-studio/numba``): after ``pip install`` the first
render, the first sampler check or the app's first draw would otherwise compile for minutes. This command
runs the warm-ups of :mod:`core.warmup` (the models, the samplers, the adaptive sampler's construction) and
:mod:`renderer.tracer_warmup` (the path tracer's kernels, through a tiny render of the demo scene) in two processes
at once, one line per group with its seconds, prefixed by the package. What is in the cache already only
loads (seconds); ``make setup`` runs the same.
"""

from __future__ import annotations

import argparse
import sys


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    sub.add_parser(
        "setup",
        help="compile every kernel now (minutes, once per machine and version), not at first use",
        description=(
            "Compile (or load from numba's disk cache) every kernel of the models, the samplers and the "
            "renderer, printing one line per group with its seconds."
        ),
    )
    return ["setup"]


def run(args: argparse.Namespace) -> int:
    from core.warmup import WARM_UP_MODULES, run_in_processes

    return run_in_processes(WARM_UP_MODULES, out=sys.stdout)
