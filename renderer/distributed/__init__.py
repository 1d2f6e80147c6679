"""Renders on a Dask cluster, to the image one process makes, bit for bit.

::

    with connect("tcp://10.0.0.5:8786") as cluster:        # or connect(workers=2): a local cluster
        job = prepare_distributed(cluster, load_scene("scene.json"), width=1024, height=1024)
        for frame in job.passes(spp=4096):                   # as RenderJob.passes: spp, time_s, cancel
            show(frame.image, frame.spp, frame.elapsed)

The steps, one module each:

- :mod:`~renderer.distributed.cluster`: the scheduler (or a local cluster), refused within seconds when it does
  not answer; the cluster's state (workers, tasks) for progress lines.
- :mod:`~renderer.distributed.bundle`: the scene and the bytes of every file it names, for workers without the
  client's filesystem; written on a worker by content.
- :mod:`~renderer.distributed.tables`: sampler tables built once on the client and installed in the workers'
  table caches.
- :mod:`~renderer.distributed.worker`: a task, a block of passes of one machine's plan, each pass returned.
- :mod:`~renderer.distributed.job`: the client: blocks submitted, their passes added to the film in pass order.
"""

from renderer.distributed.cluster import ClusterError, ClusterState, RenderCluster, check_address, connect
from renderer.distributed.job import DistributedJob, prepare_distributed

__all__ = [
    "ClusterError",
    "ClusterState",
    "DistributedJob",
    "RenderCluster",
    "check_address",
    "connect",
    "prepare_distributed",
]
