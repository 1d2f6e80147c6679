"""The sampler view's snapshot process (:mod:`app.snapshot_process`): a real spawned process, compared with
the same snapshot computed here; errors come back as themselves; a killed process is replaced; a killed app
leaves no process behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from app import snapshot_process
from app.sampling_data import sampling_snapshot
from core.brdf import get_model
from core.errors import BrdfStudioError

OPTIONS = {"n_samples": 300, "grid": 24, "seed": 3}


@pytest.fixture(autouse=True)
def _fresh_process():
    snapshot_process.shutdown()
    yield
    snapshot_process.shutdown()


def test_snapshot_in_the_process_equals_the_one_computed_here():
    params = {"n": 40.0}
    spec = snapshot_process.spec_of("phong", None, params)
    remote = snapshot_process.snapshot(spec, 35.0, 10.0, **OPTIONS)
    local = sampling_snapshot(get_model("phong").bind(params), 35.0, 10.0, **OPTIONS)
    np.testing.assert_array_equal(remote.tree.boxes, local.tree.boxes)
    np.testing.assert_array_equal(remote.tree.density, local.tree.density)
    assert remote.tree.normalizer == local.tree.normalizer
    np.testing.assert_array_equal(remote.samples, local.samples)
    np.testing.assert_array_equal(remote.ratio, local.ratio)


def test_colours_read_from_a_project_file_as_lists_work():
    """A project loaded from JSON holds colours as lists; the spec must still be usable (hashable)."""
    spec = snapshot_process.spec_of("lambert", None, {"kd": [0.2, 0.5, 0.1]})
    snap = snapshot_process.snapshot(spec, 30.0, 0.0, **OPTIONS)
    local = sampling_snapshot(get_model("lambert").bind({"kd": (0.2, 0.5, 0.1)}), 30.0, 0.0, **OPTIONS)
    assert snap.tree.normalizer == pytest.approx(local.tree.normalizer)


def test_a_newer_request_makes_the_waits_of_older_ones_give_up(monkeypatch, tmp_path):
    """A slider drag's new value must not queue behind a wait for an earlier value's full table: the table's
    facts and a follow-up snapshot wait for the background build, and give up (None: the facts are asked
    again, the follow-up's picture is not wanted) as soon as the app interrupts them."""
    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path))  # the new process's tables: none stored yet
    spec = snapshot_process.spec_of("ward", None, {"sx": 0.05, "sy": 0.25})  # its full table takes seconds
    first = snapshot_process.snapshot(spec, 40.0, 0.0, progressive=True, **OPTIONS)
    assert not first.table["complete"]  # a first picture; the full table is built when asked for again
    with ThreadPoolExecutor(1) as pool:
        facts = pool.submit(snapshot_process.table_facts, spec, snapshot_process.generation())
        follow_up = pool.submit(
            snapshot_process.snapshot, spec, 40.0, 0.0, snapshot_process.generation(),
            progressive=True, settle=600.0, **OPTIONS,
        )  # fmt: skip
        time.sleep(0.1)
        snapshot_process.interrupt()
        assert facts.result(timeout=300) is None
        assert follow_up.result(timeout=300) is None  # no picture: a newer request is on its way
    # asked without a count, both wait for the table
    assert snapshot_process.table_facts(spec).startswith("Adaptive table:")
    assert snapshot_process.snapshot(spec, 40.0, 0.0, progressive=True, settle=600.0, **OPTIONS).table[
        "complete"
    ]


def test_an_error_in_the_process_comes_back_as_itself():
    with pytest.raises(BrdfStudioError, match="unknown model 'no_such_model'"):
        snapshot_process.snapshot(snapshot_process.spec_of("no_such_model", None, {}), 30.0, 0.0, **OPTIONS)
    # and the process still serves the next request
    ok = snapshot_process.snapshot(snapshot_process.spec_of("lambert", None, {}), 30.0, 0.0, **OPTIONS)
    assert len(ok.tree.boxes) > 0


def test_a_killed_process_is_replaced():
    spec = snapshot_process.spec_of("lambert", None, {})
    snapshot_process.snapshot(spec, 30.0, 0.0, **OPTIONS)
    pool = snapshot_process._pool()
    (pid,) = list(pool._processes)  # one worker process
    os.kill(pid, signal.SIGKILL)
    again = snapshot_process.snapshot(spec, 40.0, 0.0, **OPTIONS)
    assert len(again.tree.boxes) > 0
    assert pid not in snapshot_process._pool()._processes


def test_the_process_ends_when_the_app_is_killed():
    """An app killed without cleanup (SIGKILL) must not leave its snapshot process behind."""
    code = (
        "import os\n"
        "from app import snapshot_process as sp\n"
        "sp.snapshot(sp.spec_of('lambert', None, {}), 30.0, 0.0, n_samples=50, grid=8)\n"
        "print(list(sp._pool()._processes)[0], flush=True)\n"
        "os.kill(os.getpid(), 9)\n"
    )
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=300)
    assert out.returncode == -signal.SIGKILL
    child = int(out.stdout.split()[0])
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline and _alive(child):
        time.sleep(0.1)
    assert not _alive(child)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"  # a zombie has ended (its parent is gone, init reaps it)
    except FileNotFoundError:
        return False
