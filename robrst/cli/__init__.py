"""Command-line interface: ``robrst design | report | simulate | diagnose | identify | convert |
export | check | certify | sweep``.

A thin layer: parse arguments, call the library, print.  Every robrst error becomes
one line ``robrst: error: ...`` on stderr and exit code 2 (1 for a design that is not
certified, 0 otherwise); never a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Sequence

# robrst's matrices are small (< 30 x 30): BLAS threads only add wake-up latency (scipy's
# expm is ~300x slower with two OpenBLAS threads on a 2-core machine).  The command line
# is robrst's own process, so it sets the default before numpy loads; users' scripts keep
# their own settings.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from robrst import __version__
import robrst.cli._certify as certify
import robrst.cli._check as check
import robrst.cli._convert as convert
import robrst.cli._design as design
import robrst.cli._diagnose as diagnose
import robrst.cli._export as export
import robrst.cli._identify as identify
import robrst.cli._simulate as simulate
import robrst.cli._sweep as sweep
from robrst.base.errors import RobrstError
from robrst.base.interrupt import Interrupted, interruptible, check as check_signal

__all__ = ["main", "build_parser", "Terminated", "LAST_RESORT"]

# the start of the line of an unexpected exception: a crash with a readable face, never
# reached by a known input (the random-problem and bad-input suites fail if it is)
LAST_RESORT = "computation failed ("

COMMANDS = (design, simulate, diagnose, identify, convert, export, check, certify, sweep)


class _Parser(argparse.ArgumentParser):
    """argparse with robrst's one-line error and exit code 2."""

    def error(self, message):
        print(f"robrst: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every command.

    Returns
    -------
    argparse.ArgumentParser
        ``robrst`` with one sub-command per module of :mod:`robrst.cli`.
    """
    p = _Parser(prog="robrst", description="Robust RST control of piezo actuators")
    p.add_argument("--version", action="version", version=f"robrst {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for module in COMMANDS:
        module.add_parsers(sub)
    return p


def _negative_numbers(argv):
    """``argv`` with every negative number in exponent form (``-1e9``, ``-2E-3``) given a
    leading space: argparse reads only ``-1``, ``-1.5`` as numbers and would take ``-1e9``
    for an option (``export --u-range -1e9 1e9``); ``float`` ignores the space."""
    out = []
    for a in argv:
        a = str(a)
        if a.startswith("-") and not a.startswith("--") and any(c in a for c in "eE"):
            try:
                float(a)
                a = " " + a
            except ValueError:
                pass
        out.append(a)
    return out


class Terminated(BaseException):
    """SIGTERM, raised in the main thread like Ctrl-C's KeyboardInterrupt: every cleanup
    (temporary report folders, partial files, a sweep's Dask cluster) runs.  Kept for
    code that catches it; the command line now raises
    :class:`robrst.base.interrupt.Interrupted` (a ``KeyboardInterrupt``) for SIGINT and
    SIGTERM alike."""


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit code.

    numpy's floating-point warnings (overflow, invalid value) are not printed raw: every
    result is judged by its certificate (exact checks), so a warning inside a computation
    either ends in a clear error or in a not-certified answer.  When one was raised and
    the run did not end in an error, one line ``robrst: note: ...`` says how many
    (``ROBRST_DEBUG=1`` prints them as Python does).

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (without the program name).

    Returns
    -------
    int
        0 certified (or nothing worse), 1 not certified (or something worse), 2 error
        (one line on stderr, never a traceback), 130 interrupted (SIGINT, Ctrl-C), 143
        terminated (SIGTERM): the run stops within a second; ``robrst design`` prints the
        best certified answer found so far with the status ``interrupted``.
    """
    parser = build_parser()
    args = parser.parse_args(_negative_numbers(sys.argv[1:] if argv is None else argv))
    with interruptible():      # SIGINT, SIGTERM: stop within a second (robrst.base.interrupt)
        return _main(args)


def _main(args):
    if os.environ.get("ROBRST_DEBUG"):
        return _run(args)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", RuntimeWarning)
        rc = _run(args)
    numeric = [w for w in seen if issubclass(w.category, RuntimeWarning)]
    for w in seen:
        if not issubclass(w.category, RuntimeWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if numeric and rc != 2:
        print(f"robrst: note: {len(numeric)} floating-point warning(s) inside the computation"
              " (the certificate judges the result; ROBRST_DEBUG=1 shows them)", file=sys.stderr)
    return rc


def _input_named(args):
    """The input file the command line names (problem, design, sweep, scenario), or ``""``."""
    return next((str(getattr(args, k)) for k in ("problem", "design", "file", "sweep", "scenario")
                 if isinstance(getattr(args, k, None), (str, os.PathLike))), "")


def _run(args):
    """``args.func(args)`` with every failure turned into one line and an exit code."""
    try:
        try:
            return args.func(args)
        except Exception:
            # a signal whose Interrupted a library wrapped in an error of its own (a C
            # extension's import stopped by SIGTERM ends in pybind11's "ImportError:
            # initialization failed"): the run was stopped, it did not fail
            check_signal()
            raise
    except RobrstError as exc:
        print(f"robrst: error: {exc}", file=sys.stderr)
        return 2
    except Interrupted as exc:      # a signal: the best answer so far, one line, 130 / 143
        from robrst.cli._interrupted import show_best

        show_best(args, exc)
        print(f"robrst: {exc.word}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("robrst: interrupted", file=sys.stderr)
        return 130
    except Terminated:
        print("robrst: terminated", file=sys.stderr)
        return 143
    except BrokenPipeError:    # the reader left (`robrst ... --json - | head`)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())     # no second error when Python flushes
        print("robrst: error: the output was closed before robrst finished writing it",
              file=sys.stderr)
        return 2
    except OSError as exc:     # the system refused a file: a name too long, no permission, full disk
        if os.environ.get("ROBRST_DEBUG"):
            raise
        name = str(exc.filename) if exc.filename is not None else ""
        name = name if len(name) <= 80 else name[:60] + f"... ({len(name)} characters)"
        reason = exc.strerror or " ".join(str(exc).split()) or type(exc).__name__
        where = _input_named(args)
        print(f"robrst: error: {where + ': ' if where and where != name else ''}"
              f"{name + ': ' if name else ''}{reason}", file=sys.stderr)
        return 2
    except Exception as exc:   # noqa: BLE001 — the CLI never ends in a traceback
        if os.environ.get("ROBRST_DEBUG"):
            raise
        where = _input_named(args)
        msg = " ".join(str(exc).split()) or "no message"
        print(f"robrst: error: {where + ': ' if where else ''}{LAST_RESORT}"
              f"{type(exc).__name__}: {msg}); the input is outside what robrst can compute"
              " (set ROBRST_DEBUG=1 for the traceback and please report it)", file=sys.stderr)
        return 2
