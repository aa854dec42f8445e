"""Sweeps on a 2-worker local Dask cluster (one per test session): same rows as in process,
and a worker killed mid-sweep loses nothing."""

import logging
import os
import signal

import pytest
from sweep_files import columns_equal, mc_file

from robrst.studies.sweep import run_sweep


@pytest.fixture(scope="session")
def scheduler():
    """The address of a 2-process local cluster shared by the session's Dask tests."""
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.ERROR)
    yield cluster.scheduler_address
    cluster.close()


@pytest.fixture(scope="session")
def sequential(tmp_path_factory, robust_result):
    """The small Monte Carlo run in this process (the reference)."""
    folder = tmp_path_factory.mktemp("seq")
    path = mc_file(folder, robust_result)
    return path, run_sweep(path, folder / "out", workers=0)


@pytest.mark.slow
def test_cluster_rows_equal_the_sequential_run(sequential, scheduler, tmp_path):
    path, seq = sequential
    res = run_sweep(path, tmp_path / "out", scheduler=scheduler)
    assert res.summary["workers"] == 2 and res.complete
    columns_equal(res.table, seq.table)
    assert res.summary["certified"] == seq.summary["certified"]
    assert 0 < seq.summary["certified"] < seq.summary["n"]   # both outcomes are exercised
    for k in ("yield", "worst", "figures"):
        if k != "figures":
            assert res.summary[k] == seq.summary[k]


@pytest.mark.slow
def test_a_killed_worker_loses_only_its_chunk_which_is_retried(sequential, scheduler,
                                                                 tmp_path):
    from distributed import Client

    path, seq = sequential
    killed = []
    with Client(scheduler) as client:
        pids = client.run(os.getpid)

        def kill_one(p):
            if killed or not p.done:
                return
            busy = [a for a, keys in client.processing().items()
                    if any(str(k).startswith("robrst-chunk-") for k in keys)]
            if busy:                  # kill a worker in the middle of a chunk
                os.kill(pids[busy[0]], signal.SIGKILL)
                killed.append(busy[0])

        res = run_sweep(path, tmp_path / "out", scheduler=scheduler, progress=kill_one)
    assert killed and res.complete and res.summary["statuses"] == seq.summary["statuses"]
    columns_equal(res.table, seq.table)
