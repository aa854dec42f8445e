"""``robrst convert``: arrays as labs store them -> robrst record files (``.npz`` or CSV).

Handler pair for the CLI: :func:`add_parsers` registers the sub-command,
:func:`run_convert` executes it (prints one line per file written).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from robrst.base.errors import DataError

if TYPE_CHECKING:
    import argparse

__all__ = ["add_parsers", "run_convert"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``convert`` on an argparse sub-parser collection.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parser collection of :func:`robrst.cli.build_parser`.
    """
    c = sub.add_parser(
        "convert", help="convert .npy arrays (e.g. time x channel x realization x period) to"
                        " robrst records")
    c.add_argument("u", metavar="U.npy", help="input array [V unless --u-unit]")
    c.add_argument("y", metavar="Y.npy", help="output array [m unless --y-unit]")
    c.add_argument("--fs", type=float, required=True, help="sampling rate [Hz]")
    c.add_argument("--layout", default="time,channel,realization,period",
                   help="axis names of both arrays, in order (default:"
                        " time,channel,realization,period)")
    c.add_argument("--y-unit", default="m", help="unit of Y: m, mm, um, nm (default m)")
    c.add_argument("--u-unit", default="V", help="unit of U: V, mV, kV (default V)")
    c.add_argument("--temp", type=float, metavar="C", help="add a constant temperature [°C]")
    c.add_argument("--out", required=True, metavar="DIR", help="folder for the records")
    c.add_argument("--name", help="record name prefix (default: Y file stem without 'y_')")
    c.add_argument("--csv", action="store_true", help="write CSV instead of .npz")
    c.add_argument("--overwrite", action="store_true",
                   help="replace existing files of the same names")
    c.add_argument("--quiet", action="store_true", help="no line per record written")
    c.set_defaults(func=run_convert)


def run_convert(args: argparse.Namespace) -> int:
    """Convert lab arrays to records; returns the exit code (0).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.

    Raises
    ------
    DataError
        A ``--name`` with a folder part, or a record file that exists (without
        ``--overwrite``).
    """
    from robrst.data.convert import load_array, records_from_arrays
    from robrst.data.dataset import save_dataset

    name = args.name or Path(args.y).stem.removeprefix("y_")
    if not name or Path(name).name != name or name in (".", ".."):
        raise DataError(f"--name {name!r}: expected a file-name prefix (no folder part);"
                        " the records go into --out")
    for flag, v in (("--fs", args.fs), ("--temp", args.temp)):
        if v is not None and not math.isfinite(v):
            raise DataError(f"{flag}: expected a finite number, got {v}")
    u, y = load_array(args.u), load_array(args.y)
    try:
        recs = records_from_arrays(u, y, args.fs, layout=args.layout, y_unit=args.y_unit,
                                   u_unit=args.u_unit, source=name, temp_C=args.temp)
    except DataError as exc:
        raise DataError(f"{args.u}, {args.y}: {exc}") from None
    out = Path(args.out)
    ext = ".csv" if args.csv else ".npz"
    paths = [out / f"{d.source}{ext}" for d in recs]
    if not args.overwrite:
        for p in paths:
            if p.exists():
                raise DataError(f"{p}: exists; use --overwrite to replace it")
    for d, p in zip(recs, paths):
        save_dataset(d, p)
        if not args.quiet:
            print(f"wrote {p} ({d.n} samples, {d.n_in} input(s), {d.n_out} output(s)"
                  + (f", {d.periods} periods of {d.period}" if d.period else "") + ")")
    return 0
