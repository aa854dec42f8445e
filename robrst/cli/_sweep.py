"""``robrst sweep``: Monte Carlo analyses, trade-off and fleet sweeps, on Dask."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, TextIO

import sys
import time
from pathlib import Path

from robrst.cli._common import print_json
from robrst.base.errors import SpecError

if TYPE_CHECKING:
    import argparse

    from robrst.studies.sweep.engine import Progress

__all__ = ["add_parsers", "run_sweep_command", "progress_bar", "with_notes"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``sweep``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parser collection of :func:`robrst.cli.build_parser`.
    """
    s = sub.add_parser("sweep", help="run a sweep file: Monte Carlo analysis, design trade-off"
                                     " or fleet, on a Dask cluster; resumes an interrupted run")
    s.add_argument("sweep", help="sweep file (TOML), or a built-in sweep by name")
    s.add_argument("--out", help="output folder (default sweeps/SWEEP_NAME); an earlier run of"
                                 " the same sweep there is resumed")
    s.add_argument("--workers", type=int, help="processes of the local Dask cluster (default:"
                                               " one per core), started when the work pays"
                                               " their start-up; 0: run in this process")
    s.add_argument("--cluster", action="store_true",
                   help="start the local cluster whatever the work (default: the first chunks"
                        " run in this process, and a sweep too small to pay the cluster's"
                        " start-up finishes here)")
    s.add_argument("--progress", action="store_true",
                   help="draw the progress bar also when stderr is no terminal (a CI log:"
                        " one line per 10 %%)")
    s.add_argument("--scheduler", help="address of a running Dask scheduler"
                                       " (tcp://host:8786) instead of a local cluster")
    s.add_argument("--restart", action="store_true",
                   help="discard robrst's earlier results in --out instead of resuming")
    s.add_argument("--min-yield", type=float, default=1.0,
                   help="exit 0 when at least this share of the variants is certified"
                        " (default 1.0: all)")
    s.add_argument("--force", action="store_true",
                   help="write the report into an existing OUT/report folder that robrst did"
                        " not write (only the report's own files; nothing is deleted)")
    s.add_argument("--json", action="store_true", help="print summary.json on stdout")
    s.add_argument("--quiet", action="store_true", help="no progress bar (it is drawn on a"
                                                         " terminal once a run lasts 2 s, or"
                                                         " with --progress)")
    s.set_defaults(func=run_sweep_command)


LONG_RUN_S = 2.0    # the bar appears once a run has lasted this long (short runs: none)


def progress_bar(name: str, stream: TextIO = sys.stderr, width: int = 30, tty: bool = True,
                 after_s: float = LONG_RUN_S) -> Callable[[Progress], None]:
    """A progress callback drawing one line.

    Parameters
    ----------
    name : str
        The sweep's name, first on the line.
    stream : file-like
        Where to draw.
    width : int
        Characters of the bar.
    tty : bool
        Redraw in place (a terminal); else one line per 10 % (a CI log).
    after_s : float
        Nothing before a run has lasted this long [s].

    Returns
    -------
    callable
        ``draw(progress)`` for :func:`robrst.run_sweep`'s ``progress``.
    """
    state = {"t": 0.0, "shown": False, "tenth": -1}

    def draw(p):
        now = time.monotonic()
        if p.elapsed_s < after_s and not (state["shown"] and p.done >= p.total):
            return
        frac = p.done / p.total if p.total else 1.0
        if tty:
            if p.done < p.total and now - state["t"] < 0.2:
                return
        elif int(10 * frac) == state["tenth"]:
            return
        state.update(t=now, shown=True, tenth=int(10 * frac))
        bar = "#" * int(round(width * frac))
        rate = p.done / p.elapsed_s if p.elapsed_s > 0 else 0.0
        cert = f"{p.certified / p.done:.1%} certified" if p.done else ""
        line = (f"{name} [{bar:<{width}}] {p.done}/{p.total} {cert}"
                f" · {rate:.1f}/s · {p.workers} workers · {p.elapsed_s:.0f} s ")
        stream.write(("\r" + line) if tty else line.rstrip() + "\n")
        if tty and p.done >= p.total:
            stream.write("\n")
        stream.flush()

    return draw


def with_notes(bar: Callable[[Progress], None] | None, out: str | Path,
               stream: TextIO | None = None) -> Callable[[Progress], None]:
    """A progress callback that first notes, once, the chunks computed again because their
    part file in ``out`` did not hold their variants, then draws ``bar`` (if any).

    Parameters
    ----------
    bar : callable or None
        A progress bar (:func:`progress_bar`), or ``None``.
    out : str or pathlib.Path
        The sweep's output folder (named in the note).
    stream : file-like, optional
        Where the note goes (default ``sys.stderr``).

    Returns
    -------
    callable
        ``progress(p)`` for :func:`robrst.run_sweep`.
    """
    state = {"noted": False}

    def progress(p):
        if p.recomputed and not state["noted"]:
            state["noted"] = True
            names = ", ".join(f"part-{c:06d}.parquet" for c in p.recomputed[:5])
            more = f" and {len(p.recomputed) - 5} more" if len(p.recomputed) > 5 else ""
            err = stream or sys.stderr
            err.write(f"robrst: note: {out}/chunks: {names}{more} did not hold their own"
                      " variants (a copied or damaged part); computing them again\n")
            err.flush()
        if bar is not None:
            bar(p)

    return progress


def run_sweep_command(args: argparse.Namespace) -> int:
    """Run the sweep, write the report; exit 0 when the yield reaches --min-yield, else 1.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0 complete with yield >= ``--min-yield``, else 1.

    Raises
    ------
    SpecError
        A ``--min-yield`` outside [0, 1].
    """
    from robrst.report.doc import check_report_target
    from robrst.report.sweep import sweep_text, write_sweep_report
    from robrst.studies.sweep import load_sweep, run_sweep
    from robrst.studies.sweep.engine import check_scheduler

    if not 0.0 <= args.min_yield <= 1.0:
        raise SpecError(f"--min-yield: expected a share between 0 and 1, got {args.min_yield}")
    if args.scheduler is not None:
        check_scheduler(args.scheduler, "--scheduler")
    quiet = args.quiet or args.json
    sweep = load_sweep(args.sweep)
    out = args.out or f"sweeps/{sweep.name}"
    check_report_target(Path(out) / "report", args.force)   # before any work or write
    tty = sys.stderr.isatty()
    bar = progress_bar(sweep.name, tty=tty) if not quiet and (tty or args.progress) else None
    result = run_sweep(sweep, out, workers=args.workers, scheduler=args.scheduler,
                       progress=None if quiet else with_notes(bar, out), restart=args.restart,
                       adaptive=not args.cluster)
    write_sweep_report(result, force=args.force)
    s = result.summary
    if args.json:
        print_json(s)
    else:
        print(sweep_text(s))
        print(f"wrote {out}/results.parquet, {out}/summary.json and {out}/report/")
    ok = s["complete"] and s["yield"] is not None and s["yield"] >= args.min_yield
    return 0 if ok else 1
