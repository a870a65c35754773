# The recipe of docs/python.md, "Beyond one machine": a Monte Carlo experiment's shards computed on a
# dask.distributed cluster (here a LocalCluster of two worker processes) and merged equal the
# unsharded run bit for bit.
import json

import pytest

import networked_estimation as ne

# Debian's python3-distributed (scripts/install_deps.sh --tests installs it; it has no rosdep key, so
# a ROS workspace may lack it): without it this test is skipped, and pytest -rs prints why.
distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed "
                                  "(Debian: python3-distributed): the cluster recipe is not tested")
Client, LocalCluster = distributed.Client, distributed.LocalCluster


def test_shards_on_a_dask_cluster_merge_to_the_unsharded_run():
    args = dict(runs=400, steps=40, seed=8)
    whole = ne.montecarlo("zhou_fig1", **args)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster, \
            Client(cluster) as client:
        futures = [client.submit(ne.montecarlo, "zhou_fig1", shard=(k, 4), pure=False, **args) for k in range(1, 5)]
        shards = client.gather(futures)
    merged = ne.merge(shards)
    assert merged.csv() == whole.csv()
    a, b = json.loads(merged.json()), json.loads(whole.json())
    for d in (a, b):
        d.pop("threads")
        d.pop("wall_seconds")
    assert a == b
