"""Sweeps on a 2-worker local Dask cluster (one per test session, -m slow): same rows as in
process, and a worker killed mid-sweep loses nothing; by default, the same comparison on a
cheap sweep and a one-worker cluster in this process."""

import logging
import os
import signal

import pytest
from sweep_files import columns_equal, fast_file, mc_file

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


def test_cluster_rows_equal_the_sequential_run_on_a_cheap_sweep(tmp_path):
    """The scheduler path (client, chunks submitted and gathered, rows written) on a
    one-worker cluster of threads in this process: the rows of the in-process run."""
    distributed = pytest.importorskip("distributed")
    path = fast_file(tmp_path, n=12, chunk=3)
    seq = run_sweep(path, tmp_path / "seq", workers=0)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None, silence_logs=logging.ERROR) as cl:
        res = run_sweep(path, tmp_path / "out", scheduler=cl.scheduler_address)
    assert res.summary["executor"] == "scheduler" and res.summary["workers"] == 1
    assert res.complete and res.summary["n"] == 12
    columns_equal(res.table, seq.table)
    assert res.summary["statuses"] == seq.summary["statuses"]


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
