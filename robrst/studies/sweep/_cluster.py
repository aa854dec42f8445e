"""Running chunks on Dask: a local cluster of processes, or a running scheduler.

:class:`DaskExecutor` registers a worker plugin carrying the sweep's context; each worker
runs :func:`robrst.studies.sweep._evaluate.build_state` once when the plugin is set up (also on a
worker that joins or is restarted later), and every task — one chunk of variants — uses that
state.  A worker that dies takes only its running chunk with it: the scheduler runs the
chunk again elsewhere (up to ``distributed.scheduler.allowed-failures`` times, then the
engine splits the chunk into single variants).
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator
import os
import signal
import threading
import warnings
from typing import TYPE_CHECKING, Any

import dask
from distributed import Client, LocalCluster, as_completed, get_worker
from distributed.diagnostics.plugin import WorkerPlugin

from robrst.base.errors import RobrstError
from robrst.base.threads import available_cores
from robrst.studies.sweep._evaluate import build_state, evaluate_chunk

if TYPE_CHECKING:
    import numpy as np
    from distributed import Worker

    from robrst.studies.sweep._evaluate import SweepContext

__all__ = ["SweepPlugin", "run_task", "DaskExecutor", "default_workers", "sigint_ignored",
           "quiet_shutdown"]


def default_workers() -> int:
    """The cores this process may use (the default size of the local cluster).

    Returns
    -------
    int
        :func:`robrst.base.threads.available_cores`: the CPU affinity's size, else
        ``os.cpu_count()``, at least 1.
    """
    return available_cores()


def _main_thread():
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def sigint_ignored() -> Iterator[None]:
    """Hold SIGINT (Ctrl-C) back in this block, when this is the main thread.

    SIGINT is blocked (``pthread_sigmask``) rather than ignored: processes and threads
    started meanwhile (a local cluster's workers, its event loop) inherit the blocked
    signal, so Ctrl-C in the terminal never reaches them (no traceback from a worker), and
    a Ctrl-C that arrives while the cluster starts stays pending and interrupts the driver
    when the block ends (the driver closes the cluster).  Where signals cannot be blocked,
    SIGINT is ignored in the block instead.

    Yields
    ------
    None
    """
    if not _main_thread():
        yield
        return
    if hasattr(signal, "pthread_sigmask"):
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


@contextlib.contextmanager
def quiet_shutdown() -> Iterator[None]:
    """distributed's, tornado's and asyncio's loggers silenced while a cluster closes: its
    comms closing can log ``CommClosedError`` tracebacks after a successful run that say
    nothing about the sweep (the sweep's own failures are rows, not log lines).

    Yields
    ------
    None
    """
    loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "asyncio")]
    levels = [lg.level for lg in loggers]
    raise_exc = logging.raiseExceptions
    logging.raiseExceptions = False          # no "--- Logging error ---" on a closed stream
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, lvl in zip(loggers, levels):
            lg.setLevel(lvl)
        logging.raiseExceptions = raise_exc


class SweepPlugin(WorkerPlugin):
    """Builds a worker's state once from the sweep's context.

    Parameters
    ----------
    name : str
        The plugin's name (the task finds its state under it).
    context : SweepContext
        What every variant needs (base problem, controller, designer).
    local : bool
        The worker belongs to the driver's own local cluster, so it ignores Ctrl-C (the
        driver stops it; a restarted worker too).  Workers of a running scheduler keep
        their signal handling.
    """

    def __init__(self, name: str, context: SweepContext, local: bool = False) -> None:
        self.name = name
        self.context = context
        self.local = local
        self.state = None

    def setup(self, worker: Worker) -> None:
        """Build the worker's state (Dask calls this once per worker).

        Parameters
        ----------
        worker : distributed.Worker
            The worker starting up.
        """
        if self.local and _main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        self.state = build_state(self.context)


def run_task(name: str, indices: np.ndarray, values: np.ndarray) -> list[dict]:
    """The rows of one chunk, on a worker (its state comes from the plugin ``name``).

    Parameters
    ----------
    name : str
        The plugin's name.
    indices : numpy.ndarray
        The variants' indices.
    values : numpy.ndarray
        Their parameter values, one row per variant.

    Returns
    -------
    list of dict
        One row per variant (:func:`robrst.studies.sweep._evaluate.evaluate_chunk`).
    """
    plugin = get_worker().plugins[name]
    if plugin.state is None:     # defensive: a plugin whose setup has not run yet
        plugin.setup(get_worker())
    return evaluate_chunk(plugin.state, indices, values)


class DaskExecutor:
    """Chunks as Dask tasks; ``next()`` returns ``(task, rows or exception)`` as they finish.

    Parameters
    ----------
    context : SweepContext
        What every variant needs.
    workers : int, optional
        Size of the local cluster (processes, one thread each) when no scheduler is given.
    scheduler : str or distributed.Client, optional
        Address of a running scheduler (``tcp://host:8786``), or a connected client.

    Attributes
    ----------
    workers : int
        Threads available on the cluster's workers.
    pending : int
        Tasks submitted and not yet returned by :meth:`next`.

    Raises
    ------
    RobrstError
        The scheduler cannot be reached, or no worker joins it within 60 s.
    """

    def __init__(self, context: SweepContext, workers: int | None = None,
                 scheduler: str | Client | None = None) -> None:
        self.cluster = None
        self.own_client = not isinstance(scheduler, Client)
        try:
            if isinstance(scheduler, Client):
                self.client = scheduler
            elif scheduler is not None:
                self.client = Client(scheduler, timeout="20s")
            else:
                with sigint_ignored(), warnings.catch_warnings():
                    # the workers start with Ctrl-C ignored; the scheduler's HTTP server moves
                    # to a free port when 8787 is taken (another cluster): no warning for that
                    warnings.filterwarnings("ignore", message="Port .* is already in use",
                                            category=UserWarning)
                    # the workers keep glibc's own malloc trim threshold: Dask's nanny
                    # lowers it to 64 KiB, so every freed response or frequency grid is
                    # returned to the system and mapped again for the next variant
                    # (a variant cost a third more CPU in a worker than in this process)
                    environ = {k: v for k, v in
                               dask.config.get("distributed.nanny.pre-spawn-environ").items()
                               if k != "MALLOC_TRIM_THRESHOLD_"}
                    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
                        self.cluster = LocalCluster(n_workers=workers or default_workers(),
                                                    threads_per_worker=1, processes=True,
                                                    dashboard_address=None,
                                                    silence_logs=logging.CRITICAL)
                    self.client = Client(self.cluster)
        except (OSError, TimeoutError) as exc:
            self.close()
            raise RobrstError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
        try:
            self.client.wait_for_workers(1, timeout=60)
        except (OSError, TimeoutError):
            self.close()
            raise RobrstError(f"no Dask worker joined the scheduler {scheduler} within 60 s;"
                              " start workers with: dask worker ADDRESS --nthreads 1") from None
        self.name = f"robrst-sweep-{context.fingerprint[:16]}"
        self.client.register_plugin(SweepPlugin(self.name, context, self.cluster is not None),
                                    name=self.name)
        self.futures = {}
        self.done = as_completed(loop=self.client.loop)   # this client's loop, not the default's

    @property
    def workers(self):
        """Threads available on the cluster's workers."""
        info = self.client.scheduler_info(n_workers=-1)["workers"]
        return sum(w.get("nthreads", 1) for w in info.values()) or 1

    @property
    def pending(self):
        return len(self.futures)

    def submit(self, task: Any) -> None:
        """Submit one chunk (or one variant of a split chunk) as a Dask task.

        Parameters
        ----------
        task : robrst.studies.sweep.engine.Task
            The variants to evaluate.
        """
        fut = self.client.submit(run_task, self.name, task.indices, task.values, pure=False,
                                 key=f"robrst-chunk-{task.chunk.index}-{task.start}-"
                                     f"{os.urandom(4).hex()}")
        self.futures[fut] = task
        self.done.add(fut)

    def next(self) -> tuple[Any, list[dict] | BaseException]:
        """The next task to finish, with its rows or the exception that ended it.

        Returns
        -------
        (robrst.studies.sweep.engine.Task, list of dict or BaseException)
        """
        fut = next(self.done)
        task = self.futures.pop(fut)
        try:
            return task, fut.result()
        except Exception as exc:   # noqa: BLE001 — the engine decides (split, or a lost row)
            return task, exc
        finally:
            fut.release()

    def close(self) -> None:
        """Release what is pending and close the client (and the local cluster robrst
        started), its loggers silenced (:func:`quiet_shutdown`)."""
        with quiet_shutdown():
            client = getattr(self, "client", None)
            if client is not None:
                for fut in list(getattr(self, "futures", {})):
                    fut.release()                 # nothing left for the closing comms
                try:
                    if getattr(self, "name", None):
                        client.unregister_worker_plugin(self.name)
                except Exception:   # noqa: BLE001 — closing: best effort
                    pass
                if self.own_client:
                    try:
                        client.close()
                    except Exception:   # noqa: BLE001 — closing: best effort
                        pass
            if self.cluster is not None:
                try:
                    self.cluster.close()
                except Exception:   # noqa: BLE001 — closing: best effort
                    pass
