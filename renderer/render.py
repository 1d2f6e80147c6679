"""Progressive, cancellable rendering: prepare a scene, then passes until a sample or time budget is spent.

::

    job = prepare(load_scene("scene.json"), sampler="adaptive_exact")
    for frame in job.passes(spp=64):          # or time_s=10.0 (equal-time mode)
        show(frame.image, frame.spp, frame.elapsed)   # break out of the loop to stop early

``job.passes`` yields a :class:`Frame` after every pass. Stopping is cooperative: break the loop, or set the
``cancel`` event from another thread. The same scene, strategy and seed give the same image.

A render whose film does not fit the memory budget (:func:`band_plan`; a 16384x16384 image on most machines)
is prepared with ``bands=True`` and rendered by ``job.bands(spp)`` instead: bands of whole rows, top to bottom,
each with all its samples, to be streamed to the outputs (:class:`renderer.image_io.ExrRows`, ``PngRows``).
"""

from __future__ import annotations

import platform
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from core.errors import ParameterError
from core.scene import Scene
from renderer.film import Film
from renderer.integrator import PathTracer
from renderer.world import StepCallback, World

PASS_PATHS = 1 << 18
"""Paths a pass traces at least (in whole samples per pixel, at most 64)."""


@dataclass
class Frame:
    """The state after a pass: the mean ``image (h, w, 3)`` float32, samples per pixel, seconds elapsed
    (rendering only, without preparation)."""

    image: np.ndarray
    spp: int
    elapsed: float
    rays: int = 0


class Pass(NamedTuple):
    """One pass of a progressive render: its ``index`` (the key of its random numbers), the samples per pixel
    it traces and the number of its first sample (the film's samples per pixel before it)."""

    index: int
    spp: int
    first_sample: int


def pass_plan(
    batch: int, done: int = 0, done_spp: int = 0, spp: int | None = None, first_spp: int | None = None
) -> Iterator[Pass]:
    """The passes of a progressive render after ``done`` passes of ``done_spp`` samples per pixel: ``batch``
    samples per pixel each (the last one fewer, to stop at ``spp``; endless without ``spp``), the film's first
    pass at most ``first_spp``. One render on one machine (:meth:`RenderJob.passes`) and one on a cluster
    (:mod:`renderer.distributed`) both follow it, so that their passes are the same."""
    index, total = int(done), int(done_spp)
    while spp is None or total < spp:
        n = int(batch) if spp is None else min(int(batch), spp - total)
        if first_spp is not None and total == 0:
            n = max(1, min(n, int(first_spp)))
        yield Pass(index, n, total)
        index += 1
        total += n


@dataclass
class Band:
    """Rows ``row0 .. row1 - 1`` of the image, finished: their mean ``image (row1 - row0, w, 3)`` float32 over
    ``spp`` samples per pixel; ``elapsed`` seconds of rendering so far (all bands)."""

    row0: int
    row1: int
    image: np.ndarray
    spp: int
    elapsed: float


@dataclass
class RenderJob:
    """A prepared scene: geometry built, kernels compiled, sampler tables built."""

    scene: Scene
    world: World
    tracer: PathTracer
    settings: dict[str, Any]
    prepare_report: dict[str, Any]
    film: Film = field(init=False)

    def __post_init__(self) -> None:
        self.film = Film(self.tracer.width, self.tracer.height)
        self.elapsed = 0.0
        self.passes_done = 0
        # a pass traces at least ~2^18 paths (several samples per pixel for small images): the wavefront's
        # Python calls and thread hand-offs are per bounce, not per ray, and cost ~1 ms a bounce
        self.batch = pass_spp(self.tracer.width * self.tracer.height)

    def passes(
        self,
        spp: int | None = None,
        time_s: float | None = None,
        cancel: threading.Event | None = None,
        callback: Callable[[Frame], None] | None = None,
        first_spp: int | None = None,
    ) -> Iterator[Frame]:
        """Render passes until ``spp`` samples per pixel (equal-spp) or ``time_s`` seconds (equal-time, at least
        one pass; the last pass may run past the limit) are reached, or ``cancel`` is set. ``first_spp``: the
        film's first pass traces at most that many samples per pixel (a first image sooner; the samples are
        numbered on, so the estimate is the same, only the passes' sizes differ)."""
        if spp is None and time_s is None:
            spp = self.settings["spp"]
        if spp is not None and spp < 1:
            raise ParameterError(f"samples per pixel must be at least 1, got {spp}")
        if time_s is not None and not time_s > 0:
            raise ParameterError(f"the time budget must be positive, got {time_s}")
        for step in pass_plan(self.batch, self.passes_done, self.film.spp, spp, first_spp):
            if cancel is not None and cancel.is_set():
                return
            if time_s is not None and self.film.spp > 0 and self.elapsed >= time_s:
                return
            t0 = time.perf_counter()
            self.world.refresh_samplers()  # better tables built in the background, between passes only
            radiance = self.tracer.render_pass(
                step.index, step.spp, first_sample=step.first_sample, borrow=True
            )
            self.passes_done += 1
            self.film.add_pass(radiance, step.spp)
            self.elapsed += time.perf_counter() - t0
            frame = Frame(self.film.image(), self.film.spp, self.elapsed, self.tracer.stats.rays)
            if callback is not None:
                callback(frame)
            yield frame

    def bands(
        self, spp: int, rows: int | None = None, cancel: threading.Event | None = None
    ) -> Iterator[Band]:
        """The image in bands of ``rows`` whole rows (default: :func:`band_rows`), top to bottom, each rendered
        with all its ``spp`` samples per pixel before the next starts, so memory holds one band's film, never
        the image's. A band's passes are the whole film's (``passes(spp)``: the same pass indices, batch and
        sample numbers, :meth:`PathTracer.render_pass` on the band's pixels), so it is the same estimator; for
        the strategies drawn in compiled code (``uniform``, ``cosine``, ``analytic``) without RIS it is the
        same image bit for bit. ``cancel`` stops after the pass in flight (the unfinished band is not
        yielded). There is no time budget and no resume: a band is finished or it is not."""
        if spp < 1:
            raise ParameterError(f"samples per pixel must be at least 1, got {spp}")
        width, height = self.tracer.width, self.tracer.height
        rows = band_rows(width, height, self.settings["ris_candidates"]) if rows is None else int(rows)
        rows = max(1, min(rows, height))
        self.band_layout = {"rows": rows, "count": -(-height // rows), "spp": 0}
        for row0 in range(0, height, rows):
            row1 = min(height, row0 + rows)
            film = Film(width, row1 - row0)
            k = 0
            while film.spp < spp:
                if cancel is not None and cancel.is_set():
                    return
                batch = min(self.batch, spp - film.spp)
                t0 = time.perf_counter()
                self.world.refresh_samplers()
                radiance = self.tracer.render_pass(
                    k, batch, first_sample=film.spp, pixels=(row0 * width, row1 * width)
                )
                film.add_pass(radiance, batch)
                k += 1
                self.elapsed += time.perf_counter() - t0
            if row1 == height:
                self.band_layout["spp"] = spp
            yield Band(row0, row1, film.image(), film.spp, self.elapsed)

    def run(self, spp: int | None = None, time_s: float | None = None, **kw: Any) -> Frame:
        """Render to the budget and return the last frame."""
        last = None
        for frame in self.passes(spp=spp, time_s=time_s, **kw):
            last = frame
        if last is None:
            return Frame(self.film.image(), self.film.spp, self.elapsed, self.tracer.stats.rays)
        return last

    @property
    def spp(self) -> int:
        """Samples per pixel of the image: the film's, or those of every band of a finished render in bands."""
        layout = getattr(self, "band_layout", None)
        return self.film.spp if layout is None else int(layout["spp"])

    @property
    def size(self) -> tuple[int, int]:
        """The image's ``(width, height)`` in pixels."""
        return self.tracer.width, self.tracer.height

    @property
    def rays(self) -> int:
        """Rays traced by the passes so far."""
        return self.tracer.stats.rays

    def close(self) -> None:
        """Release the ray-query device (the job renders no more)."""
        self.world.accel.close()

    def info(self) -> dict[str, Any]:
        """Everything a JSON sidecar records: settings, time, spp, rays, sampler tables, versions."""
        stats = self.tracer.stats
        layout = getattr(self, "band_layout", None)
        return {
            "scene": self.scene.source,
            "settings": self.settings,
            "spp": self.spp,
            **({} if layout is None else {"bands": {"rows": layout["rows"], "count": layout["count"]}}),
            "render_seconds": round(self.elapsed, 4),
            "rays": stats.rays,
            "rays_per_second": round(stats.rays / self.elapsed) if self.elapsed > 0 else None,
            "ray_queries": self.world.accel.backend,
            "nonfinite_contributions": stats.nonfinite,
            "prepare": self.prepare_report,
            "versions": versions(),
        }


def versions() -> dict[str, str]:
    import importlib.metadata as md

    out = {"python": platform.python_version()}
    for dist in ("brdf-studio", "numpy", "numba", "embreex", "trimesh", "OpenEXR"):
        try:
            out[dist] = md.version(dist)
        except md.PackageNotFoundError:
            out[dist] = "unknown"
    return out


def prepare(
    scene: Scene,
    sampler: str | None = None,
    sampler_options: dict[str, Any] | None = None,
    width: int | None = None,
    height: int | None = None,
    seed: int | None = None,
    max_depth: int | None = None,
    threads: int = 2,
    on_step: StepCallback | None = None,
    warm_up: bool = True,
    ris_candidates: int = 0,
    material_samplers: dict[str, str] | None = None,
    warm_up_sweep: bool = False,
    bands: bool = False,
) -> RenderJob:
    """Load meshes, build the BVH and light tables, bind materials to the sampler ``sampler`` (default: the
    scene's), compile the kernels of the models used and build sampler tables (reported via ``on_step``).
    ``warm_up`` loads the trees earlier runs left in the table cache and builds the tables of table-based
    strategies for the directions a small pre-pass meets.
    ``ris_candidates > 0`` lights from the sky by resampled importance sampling with that many candidates.
    ``material_samplers`` maps material names to a strategy used for them instead of ``sampler``.
    ``warm_up_sweep`` also asks for a dense sweep of outgoing directions (every incident-angle bin), so that no
    table is built during rendering (for equal-time comparisons).
    ``bands``: accept a render whose film exceeds the memory budget if a band of its rows fits (render it with
    :meth:`RenderJob.bands`); otherwise such a render is refused (:func:`check_budget`)."""
    r = scene.render
    check_budget(
        r.width if width is None else width,
        r.height if height is None else height,
        ris_candidates,
        bands=bands,
    )
    check_environment(scene)
    t0 = t_prepare = time.perf_counter()
    with np.errstate(over="ignore"):  # coordinates out of range are reported below, not as numpy warnings
        world = World(
            scene,
            sampler=sampler,
            sampler_options=sampler_options,
            threads=threads,
            material_samplers=material_samplers,
        )
    try:
        _check_geometry(world)
    except BaseException:
        world.accel.close()
        raise
    geometry_seconds = time.perf_counter() - t0
    from renderer.integrator import PARALLEL_MIN

    w_px = r.width if width is None else width
    h_px = r.height if height is None else height
    report = world.compile(on_step, parallel=w_px * h_px > PARALLEL_MIN)
    report["geometry_seconds"] = round(geometry_seconds, 3)
    report["triangles"] = world.n_triangles
    settings = {
        "width": int(r.width if width is None else width),
        "height": int(r.height if height is None else height),
        "spp": r.spp,
        "time_s": r.time_s,
        "sampler": world.sampler_name,
        "sampler_options": world.sampler_options,
        "max_depth": int(r.max_depth if max_depth is None else max_depth),
        "rr_depth": r.rr_depth,
        "mis": r.mis,
        "seed": int(r.seed if seed is None else seed),
        "ris_candidates": int(ris_candidates),
    }
    if ris_candidates < 0:
        raise ParameterError(
            f"the number of RIS candidates must be 0 (off) or positive, got {ris_candidates}"
        )
    if settings["width"] < 1 or settings["height"] < 1:
        raise ParameterError("the image width and height must be at least 1 pixel")
    if settings["max_depth"] < 1:
        raise ParameterError("the maximum path depth must be at least 1 bounce")
    tracer = PathTracer(
        world,
        settings["width"],
        settings["height"],
        settings["max_depth"],
        settings["rr_depth"],
        settings["mis"],
        settings["seed"],
        settings["ris_candidates"],
    )
    if warm_up and {world.sampler_name, *world.material_samplers.values()} - set(EAGER_SAMPLERS):
        _warm_up(world, tracer, report, on_step, warm_up_sweep)
    job = RenderJob(scene, world, tracer, settings, report)
    t0 = time.perf_counter()
    tracer.load_kernels()
    if not bands:  # a render in bands sizes its buffers by band
        tracer.reserve(tracer.width * tracer.height * job.batch)
        job.film.reserve()
    report["kernel_load_seconds"] = round(time.perf_counter() - t0, 3)
    report["seconds"] = round(time.perf_counter() - t_prepare, 3)  # all of it: geometry, kernels, tables
    return job


# ------------------------------------------------------------------------------------------ budgets
BYTES_PER_PATH = 640
"""Peak memory of one path in a pass's wavefront: the integrator's per-path arrays (502 bytes,
``renderer.wavefront.Buffers``) and the samplers' batches; above the slope ``python bench/budgets.py``
measures."""
BYTES_PER_PIXEL = 72
"""The film's float64 running sum, the float32 image and its tone-mapped copy, per pixel."""
BYTES_PER_RIS_CANDIDATE = 400
"""Each RIS candidate of a path: its direction, pdf, BRDF value, target and weight."""
BYTES_PER_PASS_PATH = 24
"""The radiance row every path of a pass keeps until the pass is summed per pixel."""


BYTES_PER_BAND_PIXEL = 160
"""A band's film (float64 sum and float32 mean), the EXR's three float32 planes and their bytes, and the PNG's
tone-mapping temporaries, filtered rows and compressed bytes, per pixel of the band."""
BAND_BYTES = 512 << 20
"""What a band may need at most, the wavefront's buffers included (~170 rows a band at 16384 pixels wide):
large enough that a band's passes are long (their Python overhead is per wavefront and bounce), small
enough that a render in bands stays within ~1 GiB with the interpreter and the libraries."""


def pass_spp(pixels: int) -> int:
    """Samples per pixel a pass traces: at least ``PASS_PATHS`` paths for small images, at most 64."""
    return int(np.clip(PASS_PATHS // max(1, int(pixels)), 1, 64))


def render_memory(width: int, height: int, ris_candidates: int = 0) -> float:
    """Bytes a render of ``width x height`` pixels needs at its peak: the buffers of one group of wavefronts
    (a pass runs in groups of at most ``renderer.wavefront.WAVEFRONT`` paths), the pass's per-path radiance
    and the film."""
    from renderer.wavefront import WAVEFRONT

    pixels = float(width) * float(height)
    paths = pixels * pass_spp(int(min(pixels, 2**62)))
    wave = min(paths, float(WAVEFRONT))
    per_path = BYTES_PER_PATH + BYTES_PER_RIS_CANDIDATE * max(0, ris_candidates)
    return wave * per_path + paths * BYTES_PER_PASS_PATH + pixels * BYTES_PER_PIXEL


def band_memory(width: int, height: int, rows: int, ris_candidates: int = 0) -> float:
    """Bytes a render in bands of ``rows`` rows (of a ``width x height`` image) needs at its peak: one
    wavefront's buffers (a band's pass runs sample by sample, in wavefronts of at most the band's pixels), the
    per-path radiance of one pass over the band and the band's film and output buffers."""
    from renderer.wavefront import WAVEFRONT

    band = float(width) * float(rows)
    wave = min(band, float(WAVEFRONT))
    per_path = BYTES_PER_PATH + BYTES_PER_RIS_CANDIDATE * max(0, ris_candidates)
    batch = pass_spp(int(min(float(width) * float(height), 2**62)))
    return wave * per_path + band * batch * BYTES_PER_PASS_PATH + band * BYTES_PER_BAND_PIXEL


def band_rows(width: int, height: int, ris_candidates: int = 0) -> int:
    """Rows per band: the most (up to ``height``) whose :func:`band_memory` stays within :data:`BAND_BYTES`
    and the memory budget; at least 1."""
    from core.budget import MEMORY_FRACTION, available_memory

    cap = min(float(BAND_BYTES), MEMORY_FRACTION * available_memory())
    lo, hi = 1, max(1, int(height))
    while lo < hi:  # the largest rows with band_memory <= cap (band_memory grows with rows)
        mid = (lo + hi + 1) // 2
        if band_memory(width, height, mid, ris_candidates) <= cap:
            lo = mid
        else:
            hi = mid - 1
    return lo


def band_plan(width: int, height: int, ris_candidates: int = 0) -> int | None:
    """``None`` when the whole film of a ``width x height`` render fits the memory budget (a progressive
    render, :meth:`RenderJob.passes`); otherwise the rows per band of a render in bands (:meth:`RenderJob.bands`).
    Raises :class:`~core.budget.BudgetError` when not even a band of one row fits."""
    from core.budget import MEMORY_FRACTION, available_memory

    if render_memory(width, height, ris_candidates) <= MEMORY_FRACTION * available_memory():
        return None
    check_budget(width, height, ris_candidates, bands=True)
    return band_rows(width, height, ris_candidates)


def check_budget(width: int, height: int, ris_candidates: int = 0, bands: bool = False) -> None:
    """Refuse (:class:`~core.budget.BudgetError`, one line) a render whose memory exceeds the machine's, naming
    the need, the memory available and the largest image (or candidate count) that fits. With ``bands``, a
    render whose film does not fit is accepted if a band of one row does (:func:`band_memory`)."""
    from core.budget import MEMORY_FRACTION, available_memory, check_memory

    need = render_memory(width, height, ris_candidates)
    room = MEMORY_FRACTION * available_memory()
    what = f"a {width}x{height} render" + (f" with {ris_candidates} RIS candidates" if ris_candidates else "")
    if bands and need > room:
        need = band_memory(width, height, 1, ris_candidates)
        if need <= room:
            return
        from renderer.wavefront import WAVEFRONT

        plain = band_memory(width, height, 1)
        if ris_candidates > 0 and plain < room:
            fit = int((room - plain) // (min(float(width), float(WAVEFRONT)) * BYTES_PER_RIS_CANDIDATE))
            hint = f"use --ris {max(1, fit)} or fewer candidates"
        else:
            hint = f"use --width {max(1, int(width * room / need))} or smaller"
        check_memory(need, what + " in bands of one row", hint)
        return
    if ris_candidates > 0 and render_memory(width, height) < room:
        from renderer.wavefront import WAVEFRONT

        wave = min(float(width) * float(height) * pass_spp(width * height), float(WAVEFRONT))
        fit = int((room - render_memory(width, height)) // (wave * BYTES_PER_RIS_CANDIDATE))
        hint = f"use --ris {max(1, fit)} or fewer candidates"
    else:
        scale = (room / need) ** 0.5
        hint = f"use --width {max(1, int(width * scale))} --height {max(1, int(height * scale))} or smaller"
    check_memory(need, what, hint)


def check_environment(scene: Scene) -> None:
    """An environment map's pixels must be radiances: non-negative (a negative pixel is not silently read
    as 0) and, scaled, within ``core.scene.MAX_RADIANCE``; :class:`SceneError` names the field."""
    from core.errors import BrdfStudioError
    from core.scene import MAX_RADIANCE, MapEnvironment
    from renderer.image_io import read_exr

    env = scene.environment
    if not isinstance(env, MapEnvironment):
        return
    try:
        img = read_exr(scene.resolve(env.path))
    except BrdfStudioError as exc:
        raise scene.error("environment.path", str(exc)) from None
    lowest = float(img.min()) if img.size else 0.0
    if lowest < 0.0:
        n = int(np.count_nonzero(img < 0.0))
        raise scene.error(
            "environment.path",
            f"'{env.path}' holds {n} negative values (lowest {lowest:g}); radiance must be >= 0",
        )
    highest = float(img.max()) * env.scale if img.size else 0.0
    if highest > MAX_RADIANCE:
        raise scene.error(
            "environment",
            f"the map's brightest value times scale is {highest:g}; radiance must be within [0, {MAX_RADIANCE:g}]"
            " (lower 'scale')",
        )


def _check_geometry(world: World) -> None:
    """Every vertex, once transformed, within ``core.scene.MAX_COORD`` (Embree traces in float32)."""
    from core.scene import MAX_COORD

    lo, hi = world.bounds
    reach = float(np.max(np.abs(np.concatenate([lo, hi]))))
    if not reach <= MAX_COORD:
        raise world.scene.error(
            "meshes",
            f"vertices reach {reach:g} scene units once transformed; coordinates must lie within "
            f"[-{MAX_COORD:g}, {MAX_COORD:g}] (scale the mesh down with its transform)",
        )


EAGER_SAMPLERS = ("uniform", "cosine", "analytic")
"""Strategies with no tables: nothing to build before the first pass."""


def _sweep(isotropic: bool) -> np.ndarray:
    """Outgoing directions every 0.25 degrees of theta (and, for anisotropic models, every 2.5 degrees of phi)."""
    theta = np.radians(np.arange(0.0, 90.0, 0.25))
    phi = np.radians(np.arange(0.0, 360.0, 2.5)) if not isotropic else np.zeros(1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    t, p = t.ravel(), p.ravel()
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)


def _warm_up(
    world: World,
    tracer: PathTracer,
    report: dict[str, Any],
    on_step: StepCallback | None,
    sweep: bool = False,
) -> None:
    """Build the sampler tables the scene needs before the first pass (a sampler that builds lazily, per
    incident-angle bin, builds those the pre-pass meets), and record their memory and build time."""
    t0 = time.perf_counter()
    wo_by_material = tracer.incident_directions()
    used = [m for m in wo_by_material if world.materials_by_index[m] is not None]
    for k, m in enumerate(used):
        rt = world.materials_by_index[m]
        assert rt is not None
        if on_step:
            on_step(f"tables for '{rt.name}'", k, len(used))
        t1 = time.perf_counter()
        rt.sampler.preload()  # tables earlier runs built: loaded here, not in the timed passes
        wo = wo_by_material[m]
        if sweep:
            wo = np.concatenate([wo, _sweep(rt.brdf.model.isotropic)])
        rt.sampler.sample_each(wo, seed=0)
        info = dict(rt.sampler.info())
        info["warm_up_seconds"] = round(time.perf_counter() - t1, 3)
        info["warm_up_directions"] = len(wo)
        report["materials"][rt.name].update(info)
    if on_step:
        on_step("tables ready", len(used), len(used))
    report["warm_up_seconds"] = round(time.perf_counter() - t0, 3)


def render(scene: Scene, spp: int | None = None, time_s: float | None = None, **prepare_kw: Any) -> RenderJob:
    """Prepare and render to the budget (the scene's own if neither is given); returns the finished job."""
    job = prepare(scene, **prepare_kw)
    if spp is None and time_s is None:
        spp, time_s = (None, scene.render.time_s) if scene.render.time_s else (scene.render.spp, None)
    job.run(spp=spp, time_s=time_s)
    return job
