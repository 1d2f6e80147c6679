"""Renders on a local Dask cluster of two worker processes (:mod:`renderer.distributed`): the image one
process makes, bit for bit, also when a worker is killed in the middle; a scene file that does not reach a
worker named; an unreachable scheduler refused within seconds, in one line."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from app.commands.render import demo_scene_path
from core.scene import load_scene
from renderer.distributed import ClusterError, check_address, connect, prepare_distributed
from renderer.distributed.bundle import bundle_scene, materialize
from renderer.distributed.worker import RenderSpec, prepare_render, render_block
from renderer.render import Pass, pass_spp, prepare
from tests.renderer.scenes import make_scene, quad

ROOT = Path(__file__).resolve().parents[2]
SIZE = (64, 48)
BATCH = pass_spp(SIZE[0] * SIZE[1])
"""Small enough for seconds, large enough for several passes (64 samples per pixel a pass)."""
SPP = BATCH * 4
DEPTH = 3
"""Bounces (the scene's 6 halved: the test is about the sum, not the light)."""


@pytest.fixture(scope="module")
def cluster():
    with connect(workers=2) as c:
        yield c


@pytest.fixture(scope="module")
def demo():
    return load_scene(demo_scene_path())


@pytest.fixture(scope="module")
def one_process(demo):
    """The demo rendered by one process (two threads), seed 3: ``image(spp)``, its image after ``spp``
    samples per pixel (a whole number of passes), the render continued as far as asked."""
    job = prepare(demo, width=SIZE[0], height=SIZE[1], seed=3, max_depth=DEPTH)
    images = {}

    def image(spp: int) -> np.ndarray:
        if spp > job.film.spp:
            for frame in job.passes(spp=spp):
                images[frame.spp] = frame.image
        return images[spp]

    yield image
    job.close()


def test_the_image_is_one_processs_bit_for_bit(cluster, demo, one_process):
    """The demo (meshes, a measured material beside the scene's folder, the sky map, adaptive_warp's tables)
    on two workers, a pass per task: the image equals one process's (two threads) to the bit."""
    job = prepare_distributed(
        cluster, demo, width=SIZE[0], height=SIZE[1], seed=3, max_depth=DEPTH, block_size=1
    )
    assert len(job.prepare_report["workers"]) == 2, "each worker prepared before the passes"
    frames = list(job.passes(spp=SPP))
    spps = [f.spp for f in frames]  # the film grows in pass order (blocks that come together: one frame)
    assert spps == sorted(set(spps)) and all(n % BATCH == 0 for n in spps)
    assert frames[-1].spp == SPP == job.spp
    assert job.passes_done == 4 and job.blocks == 4
    for frame in frames:
        assert np.array_equal(frame.image, one_process(frame.spp))
    info = job.info()
    assert info["spp"] == SPP and info["rays"] > 0 and info["settings"]["seed"] == 3
    assert info["prepare"]["table_bytes"] > 0, "adaptive_warp's tables were built here and sent"
    assert sum(w["passes"] for w in info["cluster"]["workers"].values()) == 4


def test_a_killed_worker_still_gives_the_exact_image(cluster, demo, one_process):
    """One of the two worker processes is killed while blocks run: Dask runs its blocks again on the other
    (or on the worker its nanny restarts) and the image is still one process's, to the bit."""
    pids = cluster.client.run(os.getpid)
    job = prepare_distributed(
        cluster, demo, width=SIZE[0], height=SIZE[1], seed=3, max_depth=DEPTH, block_size=1
    )
    killed = False
    last = None
    for frame in job.passes(spp=SPP * 2):
        if not killed:
            running = cluster.client.processing()
            busy = [pids[a] for a, keys in running.items() if keys and a in pids]
            assert busy, "a worker is rendering a block when it is killed"
            os.kill(busy[0], signal.SIGKILL)
            killed = True
        last = frame
    assert killed and last is not None and last.spp == SPP * 2 and job.passes_done == 8
    assert np.array_equal(last.image, one_process(SPP * 2))


def test_a_time_budget_stops_on_a_whole_prefix_of_passes(cluster, demo, one_process):
    """Half a second: the film holds passes 0..k-1 (a block that came back after a gap is not added), the
    one process's image of those passes; what ran past the budget is about a pass a worker."""
    job = prepare_distributed(cluster, demo, width=SIZE[0], height=SIZE[1], seed=3, max_depth=DEPTH)
    last = job.run(time_s=0.5)
    assert last.spp > 0 and last.spp % BATCH == 0 and job.passes_done == last.spp // BATCH
    assert last.elapsed < 0.5 + 10.0  # a loaded machine's slack; on an idle one, a pass or two (~0.3 s)
    assert np.array_equal(last.image, one_process(last.spp))


def test_a_local_clusters_workers_sample_their_state_seldom(cluster):
    """The local cluster's workers (restarted ones too: a nanny keeps the configuration it started them with)
    run with :data:`~renderer.distributed.cluster.LOCAL_CONFIG`: no statistical profiler, a system monitor
    every 5 s; and a worker's idle second costs it little CPU."""
    import dask

    from renderer.distributed.cluster import LOCAL_CONFIG

    def settings():
        return {k: dask.config.get(k) for k in LOCAL_CONFIG}

    for got in cluster.client.run(settings).values():
        assert got == LOCAL_CONFIG

    def cpu():
        t = os.times()
        return t.user + t.system

    cluster.client.wait_for_workers(2, timeout=60)  # a worker killed by an earlier test is back
    before = cluster.client.run(cpu)
    time.sleep(3.0)
    after = cluster.client.run(cpu)
    assert set(after) == set(before)
    # an idle worker's CPU seconds over 3 s: ~0.17 with Dask's defaults, ~0.04 with these
    assert max(after[w] - before[w] for w in after) < 0.1


def test_a_file_that_did_not_reach_a_worker_is_named(cluster, tmp_path):
    """A worker asked to prepare a scene without the bytes of its floor mesh (which no worker has seen):
    the error names the worker, the scene, the field and the file, in one line."""
    floor = quad(tmp_path / "floor.obj")
    floor.write_text(floor.read_text() + f"# {uuid.uuid4()}\n")  # bytes no worker has seen
    scene = make_scene(tmp_path, {
        "materials": [{"name": "white", "model": "lambert", "params": {"kd": [0.5, 0.5, 0.5]}}],
        "meshes": [{"path": "floor.obj", "material": "white"}],
        "lights": [{"type": "point", "position": [0, 2, 0], "intensity": [5, 5, 5]}],
        "render": {"width": 16, "height": 16, "sampler": "cosine"},
    })  # fmt: skip
    bundle, _ = bundle_scene(scene)
    spec = RenderSpec.make(
        bundle, sampler="cosine", sampler_options={}, material_samplers={}, width=16, height=16, seed=0,
        max_depth=2, ris_candidates=0,
    )  # fmt: skip
    for task in (prepare_render, render_block):
        args = (spec, (Pass(0, 1, 0),), {}, {}) if task is render_block else (spec, {}, {})
        with pytest.raises(ClusterError) as err:
            cluster.client.submit(task, *args, pure=False).result()
        message = str(err.value)
        assert "\n" not in message
        assert (
            message.startswith("worker tcp://") and "test.json: meshes[0].path: file 'floor.obj'" in message
        )
        assert "did not reach this worker" in message


def test_damaged_bytes_are_named(tmp_path):
    quad(tmp_path / "floor.obj")
    scene = make_scene(tmp_path, {
        "materials": [{"name": "white", "model": "lambert"}],
        "meshes": [{"path": "floor.obj", "material": "white"}],
    })  # fmt: skip
    bundle, contents = bundle_scene(scene)
    damaged = {d: raw + b"#" for d, raw in contents.items()}
    with pytest.raises(Exception, match=r"meshes\[0\]\.path: file 'floor.obj' arrived damaged"):
        materialize(bundle, damaged, root=tmp_path / "worker")
    copy = materialize(bundle, contents, root=tmp_path / "worker")
    assert Path(copy.meshes[0].path).read_bytes() == (tmp_path / "floor.obj").read_bytes()
    assert Path(copy.meshes[0].path).is_relative_to(tmp_path / "worker")


def test_a_file_changed_between_two_bundles_gets_its_new_digest(tmp_path):
    """The client keeps the digests of files it read (by path and stat): a file rewritten with bytes of the
    same size is hashed again, an unchanged one is not read as changed."""
    import hashlib

    floor = quad(tmp_path / "floor.obj")
    scene = make_scene(tmp_path, {
        "materials": [{"name": "white", "model": "lambert"}],
        "meshes": [{"path": "floor.obj", "material": "white"}],
    })  # fmt: skip
    first, _ = bundle_scene(scene)
    again, _ = bundle_scene(scene)
    assert again.key == first.key and again.digests == first.digests
    text = floor.read_bytes()
    changed = text.replace(b"0", b"1", 1)
    assert changed != text and len(changed) == len(text)
    stat = floor.stat()
    floor.write_bytes(changed)
    os.utime(floor, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))  # even on a coarse clock
    after, contents = bundle_scene(scene)
    digest = hashlib.sha256(changed).hexdigest()
    assert after.files[0].digest == digest and contents[digest] == changed
    assert after.key != first.key


def test_a_client_preparing_the_same_scene_again_reuses_its_tables(tmp_path, monkeypatch):
    """The client's tables are made once per scene (its JSON and files), strategy and options."""
    from renderer.distributed import job

    quad(tmp_path / "floor.obj")
    scene = make_scene(tmp_path, {
        "materials": [{"name": "white", "model": "lambert"}],
        "meshes": [{"path": "floor.obj", "material": "white"}],
    })  # fmt: skip
    made = []

    def build(*args):
        made.append(args[1:3])
        return {"t": str(len(made)).encode()}, {}

    monkeypatch.setattr(job, "build_tables", build)
    monkeypatch.setattr(job, "_CLIENT_TABLES", type(job._CLIENT_TABLES)())
    key = bundle_scene(scene)[0].key
    first = job._client_tables(key, scene, "adaptive_warp", {"n_max": 4}, {}, None)
    assert job._client_tables(key, scene, "adaptive_warp", {"n_max": 4}, {}, None) == first
    assert len(made) == 1
    job._client_tables(key, scene, "adaptive_warp", {"n_max": 8}, {}, None)  # other options
    job._client_tables(key, scene, "adaptive_exact", {"n_max": 4}, {}, None)  # another strategy
    (tmp_path / "floor.obj").write_text((tmp_path / "floor.obj").read_text() + "# edited\n")
    job._client_tables(bundle_scene(scene)[0].key, scene, "adaptive_warp", {"n_max": 4}, {}, None)
    assert len(made) == 4


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_an_unreachable_scheduler_is_refused_within_15_s():
    address = f"tcp://127.0.0.1:{_free_port()}"
    t0 = time.monotonic()
    with pytest.raises(ClusterError, match=f"cannot reach the Dask scheduler at '{address}'"):
        connect(address)
    assert time.monotonic() - t0 < 15.0


def test_the_command_refuses_an_unreachable_scheduler_in_one_line(tmp_path):
    """Exit code 2, one line, before the scene is read (the time is the interpreter's start and a refused
    connection)."""
    address = f"tcp://127.0.0.1:{_free_port()}"
    proc = subprocess.run(
        [sys.executable, "-m", "app", "render", "--demo", "--spp", "1", "--scheduler", address,
         "-o", str(tmp_path / "out.exr")],
        capture_output=True, text=True, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"cannot reach the Dask scheduler at '{address}'" in lines[0], lines
    assert not (tmp_path / "out.exr").exists()


def test_a_port_that_answers_but_not_as_a_scheduler_is_refused():
    """A dashboard's (HTTP) port given as the scheduler's: refused in one line, not read as Dask's messages."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()

    def answer() -> None:
        while True:  # every connection, as a web server answers a request it cannot read
            try:
                conn, _ = server.accept()
            except OSError:
                return  # closed: the test is over
            with conn:
                conn.recv(1024)
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nconnection: close\r\ncontent-length: 0\r\n\r\n")

    threading.Thread(target=answer, daemon=True).start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    t0 = time.monotonic()
    with pytest.raises(ClusterError, match="something answers there, but not a Dask scheduler"):
        connect(address)
    assert time.monotonic() - t0 < 10.0
    server.close()


@pytest.mark.parametrize("address", ["tcp://", "localhost", "http://host:8786", "host:99999", "a b:1"])
def test_an_address_of_the_wrong_form_is_refused_before_any_work(address):
    with pytest.raises(Exception, match="is not a Dask scheduler address"):
        check_address(address)


def test_addresses_of_the_right_form():
    assert check_address("10.0.0.5:8786") == "tcp://10.0.0.5:8786"
    assert check_address("tls://sched.example:8786") == "tls://sched.example:8786"
    assert check_address("tcp://[::1]:8786") == "tcp://[::1]:8786"
