"""Side-by-side progressive renders as one generator (no Qt): prepare each strategy, then interleave their
passes so both advance together; each event is a plain dict the render panel draws.

Events: ``{"kind": "status", "text"}`` while preparing; ``{"kind": "frame", "strategy", "image", "spp",
"seconds", "rays", "rmse", "relmse"}`` after every pass (errors only with a reference image);
``{"kind": "done"}`` at the end.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from core.errors import ParameterError
from core.scene import Scene


def render_events(
    scene: Scene,
    strategies: Sequence[str],
    mode: str = "spp",
    budget: float = 16,
    width: int = 256,
    height: int = 192,
    seed: int = 0,
    reference: np.ndarray | None = None,
) -> Iterator[dict[str, Any]]:
    """Render ``scene`` with each strategy to the same budget: ``mode`` ``"spp"`` (samples per pixel) or
    ``"time"`` (seconds of rendering each, preparation excluded)."""
    from renderer.image_io import image_errors
    from renderer.render import prepare

    if mode not in ("spp", "time"):
        raise ParameterError(f"the budget mode is 'spp' or 'time', got {mode!r}")
    if not budget > 0:
        raise ParameterError(f"the render budget must be positive, got {budget}")
    if reference is not None and reference.shape[:2] != (height, width):
        raise ParameterError(
            f"the reference image is {reference.shape[1]}x{reference.shape[0]}; render at that size "
            f"(now {width}x{height}) or load another reference"
        )
    jobs = {}
    for name in strategies:
        steps: list[str] = []
        yield {"kind": "status", "text": f"Preparing '{name}': geometry, kernels, sampler tables ..."}
        jobs[name] = prepare(
            scene, sampler=name, width=width, height=height, seed=seed,
            on_step=lambda label, i, n, steps=steps: steps.append(f"{label} ({i}/{n})"),
        )  # fmt: skip
        report = jobs[name].prepare_report
        secs = sum(v for k, v in report.items() if k.endswith("seconds") and isinstance(v, int | float))
        yield {"kind": "status", "text": f"Prepared '{name}' in {secs:.1f} s ({len(steps)} steps)"}
    passes = {
        name: job.passes(spp=int(budget)) if mode == "spp" else job.passes(time_s=float(budget))
        for name, job in jobs.items()
    }
    active = list(passes)
    while active:
        for name in list(active):
            try:
                frame = next(passes[name])
            except StopIteration:
                active.remove(name)
                continue
            event = {
                "kind": "frame",
                "strategy": name,
                "image": frame.image,
                "spp": frame.spp,
                "seconds": frame.elapsed,
                "rays": frame.rays,
                "rmse": float("nan"),
                "relmse": float("nan"),
            }
            if reference is not None:
                event.update(image_errors(frame.image, reference))
            yield event
    yield {"kind": "done"}
