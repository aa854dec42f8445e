"""``robrst identify``: a continuous-time linear model from records, written as a file.

Handler pair for the CLI: :func:`add_parsers` registers the sub-command,
:func:`run_identify` executes it.  ``--json -`` prints the result as one JSON object.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from robrst.cli._common import progress_printer
from robrst.base.errors import SpecError
from robrst.base.fileio import WRITTEN_BY, atomic_write_text, check_json_target, json_text

if TYPE_CHECKING:
    import argparse

__all__ = ["add_parsers", "run_identify"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``identify`` on an argparse sub-parser collection.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parser collection of :func:`robrst.cli.build_parser`.
    """
    g = sub.add_parser("identify", help="fit a continuous-time linear model to records")
    g.add_argument("--train", nargs="+", required=True, metavar="FILE",
                   help="records (CSV or .npz; steps, multisines or any input)")
    g.add_argument("--validate", nargs="+", metavar="FILE",
                   help="held-out records for the order selection (default: part of --train)")
    g.add_argument("--out", required=True, metavar="MODEL.toml",
                   help="problem file (one input and output, or --channel) or model file")
    g.add_argument("--order", default="auto", help="number of poles, or auto (default)")
    g.add_argument("--max-order", type=int, help="largest order tried by --order auto")
    g.add_argument("--feedthrough", action="store_true", help="allow a direct term D")
    g.add_argument("--channel", metavar="I,J",
                   help="write a problem file for output I from input J (1-based)")
    g.add_argument("--modal", action="store_true",
                   help="write the model file (modal form, any order) also for one input and"
                        " output")
    g.add_argument("--name", help="problem name (default: the output file stem)")
    g.add_argument("--report", metavar="DIR", help="write a report folder (md, html, figures)")
    g.add_argument("--json", metavar="OUT.json", help="write the result as JSON ('-' = stdout)")
    g.add_argument("--quiet", action="store_true", help="no progress lines")
    g.set_defaults(func=run_identify)


def _order(text):
    if text == "auto":
        return "auto"
    try:
        n = int(text)
    except ValueError:
        n = 0
    from robrst.identify.identification import MAX_ORDER

    if not 1 <= n <= MAX_ORDER:
        raise SpecError(f"--order: expected 'auto' or an integer 1..{MAX_ORDER}, got {text!r}")
    return n


def _channel(text):
    if text is None:
        return None
    try:
        i, j = (int(x) for x in text.split(","))
    except ValueError:
        i = j = 0
    if i < 1 or j < 1:
        raise SpecError(f"--channel: expected I,J (1-based output, input), got {text!r}")
    return i - 1, j - 1


def _problem_readable(ident):
    """``check`` for :func:`write_identified`: the problem file's text must be one
    ``robrst.problem.files`` accepts, as ``diagnose --model`` reads it (and ``design`` once
    ``[poles]`` is added)."""
    fastest = max(float(abs(m.all_poles()).max(initial=0.0)) for m in ident.models)

    def check(text, path):
        import tomllib

        from robrst.studies.linear_model import family_of_data
        from robrst.problem.files import MAX_RATE

        try:
            family_of_data(tomllib.loads(text), path)
        except SpecError as exc:
            hint = (f"; poles up to {fastest:.3g} rad/s from records sampled at"
                    f" {ident.fs:.6g} Hz: is the time column in seconds?"
                    if fastest > MAX_RATE else "")
            raise SpecError(f"order {ident.order}: the problem file would not be readable,"
                            f" nothing written: {exc}{hint}") from None
    return check


def run_identify(args: argparse.Namespace) -> int:
    """Identify and write; returns the exit code (0).

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
    SpecError
        A ``--max-order`` below 1 (and the reader's errors: ``--order``, ``--channel``,
        a problem file robrst could not read back).
    """
    from robrst.data.dataset import load_dataset
    from robrst.identify.identification import identify
    from robrst.identify.modelfile import check_target, write_identified
    from robrst.report.doc import check_report_target

    to_stdout = args.json == "-"
    quiet = args.quiet or to_stdout
    say = progress_printer(quiet)
    order, channel = _order(args.order), _channel(args.channel)
    from robrst.identify.identification import MAX_AUTO_ORDER

    if args.max_order is not None and not 1 <= args.max_order <= MAX_AUTO_ORDER:
        raise SpecError(f"--max-order: expected an integer 1..{MAX_AUTO_ORDER}, got"
                        f" {args.max_order}")
    check_target(args.out)                        # bad targets fail before any work or write
    if args.json and not to_stdout:
        check_json_target(args.json, [args.out])
    if args.report:
        check_report_target(args.report, option="--report", can_force=False)
    train = [load_dataset(f) for f in args.train]
    val = [load_dataset(f) for f in args.validate] if args.validate else None
    ident = identify(train, validate=val, order=order, max_order=args.max_order,
                     feedthrough=args.feedthrough, progress=say)
    path = write_identified(ident, args.out, [d.source for d in train], channel=channel,
                            name=args.name, modal=args.modal,
                            check=_problem_readable(ident))
    d = {**ident.as_dict(), "out": str(path), WRITTEN_BY: "robrst identify"}
    if args.report:
        from robrst.report.identification import write_identification_report

        folder = write_identification_report(ident, train, args.report, progress=say)
        say(f"wrote the identification report to {folder}")
    text = json_text(d)
    if to_stdout:
        print(text)
    else:
        if args.json:
            atomic_write_text(args.json, text + "\n")
        m = ident.models[0]
        score = ("held-out NRMSE" if not ident.heldout[0].startswith("none") else
                 "whole-record NRMSE (no excited held-out part)")
        print(f"identified order {ident.order} ({m.n_out} output(s) x {m.n_in} input(s),"
              f" {len(ident.models)} temperature(s)); {score} {ident.heldout_nrmse:.4g};"
              f" wrote {path}")
    return 0
