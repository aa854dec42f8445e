"""Command-line interface: ``robrst design | report | simulate | diagnose | identify | convert |
export | check | sweep``.

A thin layer: parse arguments, call the library, print.  Every robrst error becomes
one line ``robrst: error: ...`` on stderr and exit code 2 (1 for a design that is not
certified, 0 otherwise); never a traceback.
"""

import argparse
import os
import sys

# robrst's matrices are small (< 30 x 30): BLAS threads only add wake-up latency (scipy's
# expm is ~300x slower with two OpenBLAS threads on a 2-core machine).  The command line
# is robrst's own process, so it sets the default before numpy loads; users' scripts keep
# their own settings.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from robrst import __version__
from robrst.cli import check, convert, design, diagnose, export, identify, simulate, sweep
from robrst.errors import RobrstError

__all__ = ["main", "build_parser"]

COMMANDS = (design, simulate, diagnose, identify, convert, export, check, sweep)


class _Parser(argparse.ArgumentParser):
    """argparse with robrst's one-line error and exit code 2."""

    def error(self, message):
        print(f"robrst: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def build_parser():
    """The argument parser of every command."""
    p = _Parser(prog="robrst", description="Robust RST control of piezo actuators")
    p.add_argument("--version", action="version", version=f"robrst {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for module in COMMANDS:
        module.add_parsers(sub)
    return p


def main(argv=None):
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except RobrstError as exc:
        print(f"robrst: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("robrst: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:    # the reader left (`robrst ... --json - | head`)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())     # no second error when Python flushes
        print("robrst: error: the output was closed before robrst finished writing it",
              file=sys.stderr)
        return 2
    except Exception as exc:   # noqa: BLE001 — the CLI never ends in a traceback
        if os.environ.get("ROBRST_DEBUG"):
            raise
        where = next((str(getattr(args, k)) for k in ("problem", "file", "sweep", "scenario")
                      if isinstance(getattr(args, k, None), (str, os.PathLike))), "")
        msg = " ".join(str(exc).split()) or "no message"
        print(f"robrst: error: {where + ': ' if where else ''}computation failed"
              f" ({type(exc).__name__}: {msg}); the input is outside what robrst can compute"
              " (set ROBRST_DEBUG=1 for the traceback and please report it)", file=sys.stderr)
        return 2
