"""``robrst design`` and ``robrst report``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import re
from dataclasses import replace
from pathlib import Path

from robrst.cli._common import design_result, is_saved_design, print_result, progress_printer
from robrst.problem.files import load_problem

if TYPE_CHECKING:
    import argparse

    from robrst.problem.records import Problem

__all__ = ["add_parsers", "run_design", "run_report"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``design`` and ``report``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parser collection of :func:`robrst.cli.build_parser`.
    """
    d = sub.add_parser("design", help="design and certify an RST controller from a problem file")
    d.add_argument("problem", help="problem file (TOML), or a built-in problem by name (a saved"
                                   " design, DESIGN.json: read back, not designed again)")
    d.add_argument("--json", action="store_true", help="print exactly one JSON object (the"
                                                       " design: save it, DESIGN.json, and give"
                                                       " it to export, check, report, simulate,"
                                                       " certify)")
    d.add_argument("--quiet", action="store_true", help="no progress lines")
    d.add_argument("--incumbent", metavar="DESIGN.json",
                   help="a saved design whose controller the answer is to beat (the one in"
                        " service, a tighter bound's answer): it starts the global phase, is"
                        " certified and polished first, and the answer is never below it"
                        " when it meets this problem's specs")
    _method_options(d)
    d.set_defaults(func=run_design)
    r = sub.add_parser("report", help="design, certify and write a report folder (md, html, PNG)")
    r.add_argument("problem", help="problem file (TOML), a built-in problem by name, or a saved"
                                   " design (DESIGN.json, not designed again)")
    r.add_argument("--out", help="output folder (default reports/PROBLEM_NAME)")
    r.add_argument("--force", action="store_true",
                   help="write into an existing folder that is not a robrst report"
                        " (only the report's own files are written; nothing is deleted)")
    r.add_argument("--quiet", action="store_true", help="no progress lines")
    _method_options(r)
    r.set_defaults(func=run_report)


def _method_options(p: argparse.ArgumentParser) -> None:
    """Add ``--method`` and ``--starts`` to a command's parser."""
    p.add_argument("--method", choices=("analytic", "nlp", "convex"),
                   help="override [solver] method (default: the file's, else nlp when [specs]"
                        " bounds anything)")
    p.add_argument("--starts", type=int, metavar="N",
                   help="nlp global phase: N distinct candidates polished beyond the best"
                        " (0: no global phase, a single local run)")


def _problem(args: argparse.Namespace) -> Problem:
    """The problem file with the command line's overrides (``--method``, ``--starts``)."""
    problem = load_problem(args.problem)
    so = problem.solver
    if getattr(args, "method", None):
        so = replace(so, method=args.method, method_source="command line")
    if getattr(args, "starts", None) is not None:
        if args.starts < 0:
            from robrst.base.errors import SpecError

            raise SpecError(f"--starts: expected a whole number >= 0, got {args.starts}")
        so = replace(so, starts=args.starts, multistart=args.starts > 0)
    return replace(problem, solver=so) if so is not problem.solver else problem


def run_design(args: argparse.Namespace) -> int:
    """Design, print the summary (or the JSON); exit 0 certified, 1 not certified.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0 certified, 1 not certified.
    """
    from robrst.cli._mimo import is_mimo_file, run_mimo_design   # multi-axis problems

    if is_mimo_file(args.problem):
        return run_mimo_design(args)
    say = progress_printer(args.quiet or args.json)
    incumbent = None
    if args.incumbent is not None:
        from robrst.controller.artefact import saved_feedback

        incumbent = saved_feedback(args.incumbent)      # a bad file: one line, exit 2
    if is_saved_design(args.problem):
        if incumbent is not None:
            from robrst.base.errors import SpecError

            raise SpecError(f"--incumbent: {args.problem} is a saved design, read back and"
                            " not designed; give a problem file to design")
        result = design_result(args.problem, say, announce=False)
    else:        # an error stays one line
        result = design_result(args.problem, say, _problem(args), announce=False,
                               incumbent=incumbent)
    return print_result(result, args.json)


def run_report(args: argparse.Namespace) -> int:
    """Design, certify and write the report folder.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0 certified, 1 not certified.
    """
    from robrst.report.design import write_design_report
    from robrst.report.doc import check_report_target
    from robrst.studies.design_curves import design_curves

    say = progress_printer(args.quiet)
    if is_saved_design(args.problem):
        from robrst.controller.artefact import read_design

        problem, name = None, str(read_design(args.problem)["problem"])
    else:
        problem = _problem(args)
        name = problem.name
    # the default folder is one component under reports/, whatever the problem's name holds
    out = args.out or "reports/" + (re.sub(r"[^\w.-]+", "_", name).lstrip(".") or "problem")
    check_report_target(Path(out), args.force)     # a bad target fails before the design
    result = design_result(args.problem, say, problem)
    twin = result.problem.plant_name == "paper"
    if twin:
        say("simulating the digital twin for step.png")
    curves = design_curves(result, twin=twin)
    path = write_design_report(result, out, progress=say, force=args.force, curves=curves)
    print(f"wrote {path}/report.md, report.html, result.json and figures"
          f" (certified: {result.certified})")
    return 0 if result.certified else 1
