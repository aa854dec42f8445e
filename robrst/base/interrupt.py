"""Ctrl-C and ``kill``: a run that stops within a second, and the best answer it had.

A design spends most of its time inside IPOPT (C++), where a Python signal handler cannot
raise: CasADi caught the ``KeyboardInterrupt`` raised in its callbacks, printed
``KeyboardInterruptException`` and let the design run on to its end.  Here a signal is a
*request*:

* :func:`interruptible` (entered by the command line) installs handlers of SIGINT and
  SIGTERM in the main thread; a signal records its number and raises :class:`Interrupted`
  at once, unless the main thread is inside a solver (:func:`solver_call`), where it only
  records it;
* the solver polls :func:`requested` once per iteration (IPOPT's iteration callback,
  :mod:`robrst.synthesis.template`) and stops; on leaving :func:`solver_call`,
  :func:`check` raises :class:`Interrupted`; long loops may call :func:`check` too;
* while it runs, the pipeline :func:`offer` s each certified answer it completes; the
  command line prints the best one (:func:`best`) with the status ``interrupted``.

:class:`Interrupted` is a ``KeyboardInterrupt`` (code that catches Ctrl-C catches it) with
the exit code ``128 + signum``: 130 for SIGINT, 143 for SIGTERM.  Without
:func:`interruptible` (a user's script, a worker process) nothing changes: :func:`requested`
is false and Python's own handlers apply.

The state is the process's, as the signals are: one watch at a time, installed and
removed by :func:`interruptible`.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

__all__ = ["Interrupted", "interruptible", "requested", "check", "solver_call", "offer", "best",
           "worker_signals", "stop_pool"]


class Interrupted(KeyboardInterrupt):
    """A stop asked for by a signal.

    Parameters
    ----------
    signum : int
        The signal (``signal.SIGINT``, ``signal.SIGTERM``).

    Attributes
    ----------
    exit_code : int
        ``128 + signum`` (130 for SIGINT, 143 for SIGTERM).
    word : str
        ``"interrupted"`` (SIGINT) or ``"terminated"``.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    @property
    def word(self) -> str:
        return "interrupted" if self.signum == signal.SIGINT else "terminated"


@dataclass
class _Watch:
    """What :func:`interruptible` watches: the first signal, how deep in solvers the main
    thread is, and the best answer offered (``(score, value)``)."""

    signum: int = None
    solving: int = 0
    best: tuple = None


_WATCH = [None]     # the process's watch (signals are per process); None outside the block
SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _handler(signum, frame):
    w = _WATCH[0]
    if w is None:
        raise Interrupted(signum)
    if w.signum is None:
        w.signum = signum
    if not w.solving:
        raise Interrupted(w.signum)


@contextmanager
def interruptible() -> Iterator[None]:
    """SIGINT and SIGTERM turned into :class:`Interrupted` (at once, or when a solver
    returns: :func:`solver_call`) in this block; the previous handlers restored after it.

    A no-op outside the main thread (signals are delivered to the main thread only).

    Yields
    ------
    None
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    outer = _WATCH[0]
    _WATCH[0] = _Watch()
    for s in SIGNALS:
        signal.signal(s, _handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        _WATCH[0] = outer


def requested() -> bool:
    """Whether a signal asked the run to stop.

    Returns
    -------
    bool
        ``False`` outside :func:`interruptible`.
    """
    w = _WATCH[0]
    return w is not None and w.signum is not None


def check() -> None:
    """Raise :class:`Interrupted` when a signal asked the run to stop (a long loop's poll).

    Raises
    ------
    Interrupted
    """
    w = _WATCH[0]
    if w is not None and w.signum is not None:
        raise Interrupted(w.signum)


@contextmanager
def solver_call() -> Iterator[None]:
    """A call into a solver whose Python callbacks must not raise: a signal inside it is
    only recorded (the solver polls :func:`requested` and stops), then raised on leaving.

    Yields
    ------
    None

    Raises
    ------
    Interrupted
        On leaving, when a signal came.
    """
    w = _WATCH[0]
    if w is None or threading.current_thread() is not threading.main_thread():
        yield
        return
    w.solving += 1
    try:
        yield
    finally:
        w.solving -= 1
    check()


def offer(score: float, value: object) -> None:
    """Keep ``value`` as the answer to give if the run is interrupted, when its ``score`` is
    the best offered (larger is better).

    Parameters
    ----------
    score : float
        The certified objective (larger is better).
    value : object
        What the command line shows (a certified candidate).
    """
    w = _WATCH[0]
    if w is not None and (w.best is None or score > w.best[0]):
        w.best = (float(score), value)


def best() -> object:
    """The best answer offered in the current :func:`interruptible` block.

    Returns
    -------
    object or None
    """
    w = _WATCH[0]
    return None if w is None or w.best is None else w.best[1]


def worker_signals() -> None:
    """In a worker process (a pool's initializer): Ctrl-C in the terminal reaches the whole
    process group, but only the parent answers it (it stops the workers, :func:`stop_pool`):
    SIGINT ignored, SIGTERM's default (end at once, no traceback), no watch inherited."""
    _WATCH[0] = None
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def stop_pool(pool: object) -> None:
    """Stop a ``concurrent.futures.ProcessPoolExecutor`` now: its pending work cancelled, its
    worker processes terminated (what an interrupted run must not wait for).

    Parameters
    ----------
    pool : concurrent.futures.ProcessPoolExecutor
    """
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for p in procs:
        try:
            p.terminate()
        except (OSError, AttributeError):
            pass
    pool.shutdown(wait=False, cancel_futures=True)
