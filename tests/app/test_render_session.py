"""The render session without Qt: each strategy's first frame before the next strategy is prepared, the
render process's time stamps and idle kernel loading, numba's compile clock."""

from __future__ import annotations

import multiprocessing
import time
from pathlib import Path

import numpy as np
import pytest

from app.render_session import FIRST_PASS_SPP, NumbaClock, Timeline, render_events, serve
from core.scene import SCENE_VERSION, scene_from_dict, scene_to_dict
from tests.app.meshes import write_obj


@pytest.fixture
def scene(tmp_path: Path):
    write_obj(tmp_path / "cubes.obj", {"a": (0, 0, 0), "b": (1.5, 0, 0)})
    data = {
        "version": SCENE_VERSION,
        "materials": [{"name": "grey", "model": "lambert", "params": {"kd": 0.5}}],
        "meshes": [{"name": "cubes", "path": "cubes.obj", "material": "grey"}],
        "environment": {"type": "constant", "radiance": [1.0, 1.0, 1.0]},
    }
    return scene_from_dict(data, base_dir=tmp_path)


def _summary(events: list[dict]) -> list[str]:
    out = []
    for e in events:
        if e["kind"] == "status":
            out.append(e["text"].split(":")[0].split(" in ")[0])
        elif e["kind"] == "frame":
            out.append(f"frame {e['strategy']} {e['spp']}")
        else:
            out.append(e["kind"])
    return out


def test_the_first_strategy_shows_a_frame_before_the_second_is_prepared(scene):
    events = list(render_events(scene, ["uniform", "cosine"], "spp", 3, 16, 12, timeline=Timeline()))
    assert FIRST_PASS_SPP == 1
    assert _summary(events)[:10] == [
        "Preparing 'uniform'", "Prepared 'uniform'", "frame uniform 1", "timing",
        "Preparing 'cosine'", "Prepared 'cosine'", "frame cosine 1", "timing",
        "frame uniform 3", "frame cosine 3",
    ]  # fmt: skip
    assert _summary(events)[-2:] == ["timing", "done"]
    # the last timing event holds every step, in order of time
    marks = events[-2]["marks"]
    steps = [m["step"].split(":")[0] for m in marks]
    assert steps == [
        "prepare uniform", "prepared uniform", "first pass uniform",
        "prepare cosine", "prepared cosine", "first pass cosine", "done",
    ]  # fmt: skip
    times = [m["t"] for m in marks]
    assert times == sorted(times)
    # the same render again is the same image (a small first pass keeps the estimate deterministic)
    again = list(render_events(scene, ["uniform", "cosine"], "spp", 3, 16, 12))
    last = {e["strategy"]: e["image"] for e in events if e["kind"] == "frame"}
    for e in again:
        if e["kind"] == "frame" and e["spp"] == 3:
            assert np.array_equal(e["image"], last[e["strategy"]])
    assert "timing" not in _summary(again)  # no timeline asked for


def test_equal_time_starts_each_strategy_with_a_small_pass_too(scene):
    frames = [
        e for e in render_events(scene, ["uniform", "cosine"], "time", 0.2, 16, 12) if e["kind"] == "frame"
    ]
    firsts = {}
    for e in frames:
        firsts.setdefault(e["strategy"], e)
    assert {name: e["spp"] for name, e in firsts.items()} == {"uniform": 1, "cosine": 1}
    assert [e["strategy"] for e in frames[:2]] == ["uniform", "cosine"]


def test_numba_clock_counts_a_compile():
    from numba import njit

    clock = NumbaClock().install()

    @njit
    def twice(x):
        return 2 * x

    assert twice(21) == 42
    assert clock.compiles >= 1 and clock.compile_s > 0.0
    assert clock.dispatch_s >= clock.compile_s * 0.99  # the compile happens inside the dispatch
    compiled = clock.compiles
    assert twice(4) == 8  # the same signature: no second compile
    assert clock.compiles == compiled


def test_render_process_loads_kernels_while_idle_and_a_job_waits_one_step_at_most(
    scene, tmp_path, monkeypatch
):
    """A job sent as the process starts is taken after at most one kernel-loading step; its frames carry
    the process's time stamps, and its timing marks run from the process's start to the first frames."""
    ctx = multiprocessing.get_context("spawn")
    child_commands, commands = ctx.Pipe(duplex=False)
    events, child_events = ctx.Pipe(duplex=False)
    process = ctx.Process(target=serve, args=(child_commands, child_events), daemon=True)
    started = time.monotonic()
    process.start()
    child_commands.close()
    child_events.close()
    job = {"id": 1, "scene": scene_to_dict(scene), "base_dir": str(scene.base_dir), "source": scene.source,
           "strategies": ["uniform", "cosine"], "mode": "spp", "budget": 2, "width": 16, "height": 12,
           "seed": 0, "reference": None}  # fmt: skip
    try:
        commands.send(("start", job))
        got = []
        while not got or got[-1]["kind"] not in ("done", "error", "cancelled"):
            assert events.poll(240), "no event from the render process within 240 s"
            got.append(events.recv())
    finally:
        commands.send(("quit",))
        process.join(30)
        if process.is_alive():
            process.kill()
    assert got[-1]["kind"] == "done", got[-1]
    assert all(e["job"] == 1 and e["pid"] == process.pid for e in got)
    frames = [e for e in got if e["kind"] == "frame"]
    assert [(e["strategy"], e["spp"]) for e in frames] == [
        ("uniform", 1),
        ("cosine", 1),
        ("uniform", 2),
        ("cosine", 2),
    ]
    assert all(started < e["sent"] <= time.monotonic() for e in got)
    marks = [e for e in got if e["kind"] == "timing"][-1]["marks"]
    steps = [m["step"] for m in marks]
    assert steps[0].startswith("process: python started") and "process: renderer imported" in steps
    assert [m["t"] for m in marks] == sorted(m["t"] for m in marks)
    assert started < marks[0]["t"]
    arrived = steps.index("job arrived")
    loading = [i for i, s in enumerate(steps) if s.startswith("process: kernels of")]
    assert len([i for i in loading if i > arrived]) <= 1  # the step in progress, then the job
    assert steps.index("job taken") > max(loading, default=arrived)
    assert steps[-1] == "done" and all(
        m["compile_s"] is not None for m in marks if m["step"] != "job arrived"
    )


def test_only_the_rejection_free_mode_starts_on_a_coarse_table(scene, monkeypatch):
    """The render's first image: ``adaptive_warp`` starts on its coarse table and swaps in the full one; the
    exact mode builds its full table at once (its coarse layout's bounds cost more than the full table's)."""
    import renderer.render

    asked: dict[str, dict] = {}
    real = renderer.render.prepare

    def prepare(scene, sampler, sampler_options=None, **kw):
        asked[sampler] = dict(sampler_options or {})
        return real(scene, sampler=sampler, sampler_options=sampler_options, **kw)

    monkeypatch.setattr(renderer.render, "prepare", prepare)
    events = list(render_events(scene, ["adaptive_exact", "adaptive_warp"], "spp", 1, 8, 6))
    assert any(e["kind"] == "done" for e in events)
    assert asked["adaptive_warp"].get("progressive") is True
    assert "progressive" not in asked["adaptive_exact"]
