"""``run_sweep``: plan the chunks, run them (Dask or in process), write, summarise.

The driver prepares the context (:mod:`robrst.studies.sweep._prepare`), opens the output folder
(:mod:`robrst.studies.sweep._store`: a folder of the same sweep is resumed), and hands the chunks
not yet finished to an executor — a Dask cluster (:mod:`robrst.studies.sweep._cluster`; local
processes by default, or a running scheduler) or, with ``workers=0``, this process.  A
bounded window of chunks is in flight; each finished chunk is written at once.  A chunk
that fails as a whole (its worker died repeatedly) is split into single variants, so only
the variant that kills its worker is lost — as a row with status ``worker_lost``.  On any
stop (done, error, Ctrl-C) the finished rows are gathered into ``results.parquet`` and
``summary.json``; a finished design sweep over spec bounds gets its monotone envelope there
(:mod:`robrst.studies.sweep.envelope`: a variant keeps a tighter variant's better design,
certified on its own problem).
"""

from __future__ import annotations

import os
import re
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.base.fileio import output_lock
from robrst.base.threads import available_cores
import robrst.studies.sweep._store as store
from robrst.studies.sweep._prepare import prepare
from robrst.studies.sweep.envelope import monotone_envelope
from robrst.studies.sweep._evaluate import build_state, evaluate_chunk, failed_row, status_of
from robrst.studies.sweep.files import Sweep, load_sweep
from robrst.studies.sweep.summary import summarise
from robrst.studies.sweep._variants import chunks

if TYPE_CHECKING:
    from robrst.studies.sweep._cluster import DaskExecutor
    from robrst.studies.sweep._evaluate import SweepContext
    from robrst.studies.sweep._variants import Chunk
    import pyarrow as pa

__all__ = ["Task", "Progress", "SweepResult", "SequentialExecutor", "execute", "run_sweep",
           "check_scheduler", "ADDRESS"]


@dataclass(frozen=True, eq=False)
class Task:
    """Variants ``indices`` (parameter ``values``) of ``chunk``; ``single``: split off it.

    Parameters
    ----------
    chunk : Chunk
        The chunk the variants belong to.
    indices : numpy.ndarray
        The variants' indices.
    values : numpy.ndarray
        Their parameter values, one row per variant.
    single : bool
        A single variant split off a chunk that failed as a whole.

    Attributes
    ----------
    start : int
        The first variant's index.
    """

    chunk: Chunk
    indices: np.ndarray
    values: np.ndarray
    single: bool = False

    @property
    def start(self):
        return int(self.indices[0])


@dataclass(frozen=True)
class Progress:
    """Where a sweep stands: variants finished (of ``total``), certified, failed.

    Parameters
    ----------
    done : int
        Variants finished (this run and resumed).
    total : int
        Variants of the sweep.
    certified : int
        Variants certified so far.
    failed : int
        Variants that failed (no evaluation).
    elapsed_s : float
        Wall time of this run [s].
    workers : int
        Workers computing.
    recomputed : tuple of int
        The chunks whose part file in the output folder did not hold their own variants
        (e.g. a part copied over another), computed again by this run.
    """

    done: int
    total: int
    certified: int
    failed: int
    elapsed_s: float
    workers: int
    recomputed: tuple = ()


@dataclass(frozen=True, eq=False)
class SweepResult:
    """A sweep's results: the Arrow ``table`` (one row per finished variant), the summary.

    Parameters
    ----------
    sweep : Sweep
        The sweep run.
    out : pathlib.Path
        Its output folder.
    context : SweepContext
        What every variant needed (base problem, controller).
    table : pyarrow.Table
        One row per finished variant, ordered by ``index``.
    summary : dict
        The ``summary.json`` object.

    Attributes
    ----------
    complete : bool
        Every variant finished.
    yield_ : float
        Share of the finished variants that are certified.
    """

    sweep: Sweep
    out: Path
    context: SweepContext
    table: pa.Table
    summary: dict

    @property
    def complete(self):
        return self.summary["complete"]

    @property
    def yield_(self):
        """Share of the finished variants that are certified."""
        return self.summary["yield"]


class SequentialExecutor:
    """Chunks run one after the other in this process (``workers=0``).

    Parameters
    ----------
    context : SweepContext
        What every variant needs (the state is built once, here).

    Attributes
    ----------
    workers : int
        1.
    pending : int
        Tasks submitted and not yet returned by :meth:`next`.
    """

    workers = 1

    def __init__(self, context: SweepContext) -> None:
        self.state = build_state(context)
        self.queue = deque()

    @property
    def pending(self):
        return len(self.queue)

    def submit(self, task: Task) -> None:
        """Queue one task.

        Parameters
        ----------
        task : Task
            The variants to evaluate.
        """
        self.queue.append(task)

    def next(self) -> tuple[Task, list[dict] | BaseException]:
        """Evaluate the oldest queued task.

        Returns
        -------
        (Task, list of dict or BaseException)
            Its rows, or the exception that ended it.
        """
        task = self.queue.popleft()
        try:
            return task, evaluate_chunk(self.state, task.indices, task.values)
        except Exception as exc:   # noqa: BLE001 — the engine splits the chunk
            return task, exc

    def close(self) -> None:
        """Nothing to release (in process)."""
        pass


def _lost(task, exc):
    from_worker = type(exc).__name__ == "KilledWorker"
    row = failed_row("worker_lost" if from_worker else status_of(exc), exc)
    row.update(index=task.start, seconds=None, cpu_s=None)
    return [row]


def execute(tasks: Iterable[Task], executor: SequentialExecutor | DaskExecutor,
            on_rows: Callable[[Chunk, list[dict]], None], window: int) -> None:
    """Run ``tasks`` on ``executor``, ``window`` at a time; ``on_rows(chunk, rows)`` per chunk.

    A task that fails as a whole is split into single variants; a single variant that fails
    becomes a row with its status (``worker_lost`` when its worker died).

    Parameters
    ----------
    tasks : iterable of Task
        Consumed as the window frees.
    executor : SequentialExecutor or DaskExecutor
        Where the tasks run.
    on_rows : callable
        Called once per chunk with all its rows, in index order.
    window : int
        Tasks in flight at most.
    """
    queue, source = deque(), iter(tasks)     # queue: the singles of split chunks, first
    split = {}

    def refill():
        while executor.pending < window:
            task = queue.popleft() if queue else next(source, None)
            if task is None:
                return
            executor.submit(task)

    refill()
    while executor.pending:
        task, res = executor.next()
        if isinstance(res, BaseException):
            if len(task.indices) > 1:
                singles = [Task(task.chunk, task.indices[i:i + 1], task.values[i:i + 1], True)
                           for i in range(len(task.indices))]
                split[task.chunk.index] = {"rows": [], "left": len(singles)}
                queue.extendleft(reversed(singles))
                refill()
                continue
            res = _lost(task, res)
        if task.single:
            part = split[task.chunk.index]
            part["rows"] += res
            part["left"] -= 1
            if part["left"]:
                refill()
                continue
            res = sorted(split.pop(task.chunk.index)["rows"], key=lambda r: r["index"])
        on_rows(task.chunk, res)
        refill()


ADDRESS = re.compile(r"((tcp|tls|ws|wss|ucx)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)"
                     r":(\d{1,5})/?|inproc://\S+")


def check_scheduler(address: str, name: str = "scheduler") -> str:
    """``address`` if it is a Dask scheduler address (``tcp://host:8786``, ``host:8786``,
    ``tls://``, ``ws://``, ``wss://``, ``ucx://``, ``inproc://``).

    Parameters
    ----------
    address : str
        The address given.
    name : str
        What to call it in the message (``--scheduler`` on the command line).

    Returns
    -------
    str
        ``address`` without surrounding blanks.

    Raises
    ------
    SpecError
        Naming ``name`` and what is expected.

    Examples
    --------
    >>> from robrst.studies.sweep.engine import check_scheduler
    >>> check_scheduler(" tcp://10.0.0.5:8786 ")
    'tcp://10.0.0.5:8786'
    """
    m = ADDRESS.fullmatch(address.strip())
    if m is None or (m.group(4) is not None and not 0 < int(m.group(4)) < 65536):
        raise SpecError(f"{name}: expected the address of a running Dask scheduler, e.g."
                        f" tcp://host:8786 (protocol tcp, tls, ws, wss or ucx; a port in"
                        f" 1..65535), got {address!r}")
    return address.strip()


#: what a local cluster's start-up costs at most here [s] (processes, imports, state: 0.9 s
#: quiet, 7 s on a 2-core machine under a load of 11), and what it may cost beyond the
#: in-process run (the number the sweep must keep)
STARTUP_S, MARGIN_S = 4.0, 2.0
PROBE_S = 1.0       # the first chunks run in this process for at least this long


def startup_estimate() -> float:
    """What a local cluster's start-up costs now [s].

    Returns
    -------
    float
        :data:`STARTUP_S`, times the machine's load per core when it is above 1 (spawning
        and importing compete with that load).
    """
    try:
        load = os.getloadavg()[0] / available_cores()
    except (AttributeError, OSError):     # no load average on this platform
        load = 1.0
    return STARTUP_S * max(1.0, load)


def cluster_pays(remaining_s: float, workers: int, startup_s: float = STARTUP_S) -> bool:
    """Whether a local cluster of ``workers`` processes beats this process on work of
    ``remaining_s`` seconds in this process: ``startup_s + remaining/workers`` below
    ``remaining - MARGIN_S``, i.e. remaining above ``(startup_s + MARGIN_S) w / (w - 1)``
    (12 s for 2 workers on an idle machine).  When it is chosen, a cluster whose start-up
    takes up to ``startup_s + MARGIN_S`` finishes at most ``MARGIN_S`` after this process
    would have.

    Parameters
    ----------
    remaining_s : float
        The work left, as it would take in this process [s].
    workers : int
    startup_s : float
        The cluster's start-up [s] (:func:`startup_estimate`).

    Returns
    -------
    bool
    """
    return workers > 1 and remaining_s > (startup_s + MARGIN_S) * workers / (workers - 1)


def _executor(context, workers, scheduler, pending):
    if workers == 0:
        return SequentialExecutor(context)
    from robrst.studies.sweep._cluster import DaskExecutor, default_workers

    if scheduler is None:
        workers = min(workers or default_workers(), pending)
    return DaskExecutor(context, workers=workers, scheduler=scheduler)


def run_sweep(sweep: Sweep | str | os.PathLike, out: str | os.PathLike,
              workers: int | None = None, scheduler: object = None,
              progress: Callable[[Progress], None] | None = None,
              restart: bool = False, adaptive: bool = True) -> SweepResult:
    """Run a sweep (or resume it) and write its results to ``out``.

    Parameters
    ----------
    sweep : Sweep, str or Path
        A sweep record, a sweep file, or the name of a built-in sweep.
    out : str or Path
        Output folder: new, empty, or an earlier run of the same sweep (resumed).
    workers : int, optional
        Processes of the local Dask cluster (default: the cores available, at most one per
        chunk); ``0`` runs every chunk in this process, without Dask.  With ``adaptive``
        the first chunks run in this process (at least :data:`PROBE_S`), and the cluster is
        started only when the rest of the work pays its start-up (:func:`cluster_pays`,
        :func:`startup_estimate`);
        otherwise the sweep finishes here (``summary["executor"]`` says which).
    scheduler : str or distributed.Client, optional
        A running Dask scheduler (``"tcp://host:8786"``) or client, instead of a local cluster.
    progress : callable, optional
        Called with a :class:`Progress` after every finished chunk.
    restart : bool
        Discard earlier results in ``out`` (robrst's own files only).
    adaptive : bool
        Start a local cluster only when the work pays for it (above); ``False``: always
        (the cluster itself is what is wanted, e.g. to measure it).

    Returns
    -------
    SweepResult

    Raises
    ------
    SpecError, OutputError, SolverError
        A bad sweep file or base problem, an output folder robrst must not write, a base
        design that failed.

    Examples
    --------
    >>> import tempfile
    >>> from robrst import run_sweep
    >>> from robrst.studies.sweep import parse_sweep
    >>> sweep = parse_sweep({"sweep": {"kind": "analysis", "problem": "paper", "n": 8},
    ...                      "param": [{"name": "gain", "dist": "normal", "mean": 1.0,
    ...                                 "std": 0.1}]})
    >>> result = run_sweep(sweep, tempfile.mkdtemp() + "/mc", workers=0)
    >>> result.summary["done"], result.complete, result.summary["certified"]
    (8, True, 8)
    """
    t0 = time.perf_counter()
    if not isinstance(sweep, Sweep):
        sweep = load_sweep(sweep)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 0):
        raise SpecError(f"workers: expected an integer >= 0, got {workers!r}")
    if workers is not None and scheduler is not None:
        raise SpecError("give either workers (a local cluster) or scheduler, not both")
    if isinstance(scheduler, (str, os.PathLike)):
        scheduler = check_scheduler(os.fspath(scheduler))
    context, table = prepare(sweep)
    out = Path(out)
    plan = chunks(table.n, sweep.chunk_size)
    meta = {"sweep": sweep.name, "kind": sweep.kind, "n": table.n,
            "chunk_size": sweep.chunk_size, "fingerprint": context.fingerprint}
    with output_lock(out, what="sweep folder"):   # one run at a time writes a folder's parts
        return _run_locked(sweep, out, workers, scheduler, progress, restart, t0, context,
                           table, plan, meta, adaptive)


def _run_locked(sweep, out, workers, scheduler, progress, restart, t0, context, table, plan,
                meta, adaptive):
    """The rest of :func:`run_sweep`, with the output folder's lock held."""
    resumed = store.prepare_folder(out, meta, restart)
    runs = store.previous_runs(out) if resumed else []
    schema = store.arrow_schema(context)
    done, foreign = store.checked_chunks(out, plan, schema)
    prior = store.read_results(out, [c for c in plan if c.index in done], schema)
    count = {"done": prior.num_rows, "cert": sum(bool(c) for c in prior.column("certified")
                                                  .to_pylist()),
             "failed": sum(s != "ok" for s in prior.column("status").to_pylist())}
    pending = [c for c in plan if c.index not in done]
    done_before = set(done)
    executor, n_workers, t_ready = None, 0, time.perf_counter()
    before = count["done"]
    how = {"executor": "in_process" if workers == 0 else
           "scheduler" if scheduler is not None else "local_cluster", "estimated_s": None}

    def report():
        if progress is not None:
            progress(Progress(count["done"], table.n, count["cert"], count["failed"],
                              time.perf_counter() - t0, n_workers, tuple(sorted(foreign))))

    def on_rows(chunk, rows):
        store.write_part(out, chunk.index, store.rows_table(rows, chunk.index, context, table))
        done.add(chunk.index)
        count["done"] += len(rows)
        count["cert"] += sum(bool(r.get("certified")) for r in rows)
        count["failed"] += sum(r["status"] != "ok" for r in rows)
        report()

    def task(c):
        return Task(c, np.arange(c.start, c.stop), table.values[c.start:c.stop])

    try:
        if pending and workers != 0 and scheduler is None and adaptive:
            # the first chunks in this process: what the rest would cost here decides
            executor = SequentialExecutor(context)
            n_workers, t_ready = 1, time.perf_counter()
            report()
            t_probe, k = time.perf_counter(), 0
            while k < len(pending) and (k == 0 or time.perf_counter() - t_probe < PROBE_S):
                execute([task(pending[k])], executor, on_rows, window=1)
                k += 1
            per = (time.perf_counter() - t_probe) / k
            pending = pending[k:]
            how["estimated_s"] = per * len(pending)
            want = min(workers or available_cores(), len(pending))
            if pending and cluster_pays(how["estimated_s"], want, startup_estimate()):
                executor.close()
                executor = None
            else:
                how["executor"] = "in_process"
        if pending:
            if executor is None:
                executor = _executor(context, workers, scheduler, len(pending))
                n_workers, t_ready = executor.workers, time.perf_counter()
                report()
            execute((task(c) for c in pending),      # made as they are submitted
                    executor, on_rows, window=2 * n_workers + 1)
    finally:
        if executor is not None:
            executor.close()
        results = store.read_results(out, [c for c in plan if c.index in done], schema)
        if context.sweep.kind == "design" and not context.mimo:
            results = monotone_envelope(context, results, complete=len(done) == len(plan))
        store.write_results(out, results)
        runs = (runs + [{"workers": n_workers, "wall_s": time.perf_counter() - t0,
                         "startup_s": t_ready - t0, "computed": count["done"] - before}])[-100:]
        busy = [r for r in runs if r["computed"]] or runs[-1:]
        summary = summarise(context, results, table.n, busy[-1]["workers"],
                            sum(r["wall_s"] for r in busy), complete=len(done) == len(plan))
        summary.update(startup_s=busy[-1]["startup_s"],
                       resumed_chunks=len(done_before),
                       runs=runs, recomputed_chunks=sorted(foreign), executor=how["executor"],
                       estimated_in_process_s=how["estimated_s"])
        store.write_summary(out, summary)
    return SweepResult(sweep=sweep, out=out, context=context, table=results, summary=summary)
