"""``robrst design`` of a multi-axis problem file (a ``[mimo]`` table).

The design command hands such a file here (:func:`robrst.cli._design.run_design`): the
joint program, the certificate, the comparison; the text summary or one JSON object; exit
code 0 certified, 1 not certified, 2 error (as for one loop).
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from robrst.cli._common import print_json, progress_printer
from robrst.problem.mimo_files import is_mimo_file

if TYPE_CHECKING:
    import argparse

__all__ = ["run_mimo_design", "is_mimo_file"]


def run_mimo_design(args: argparse.Namespace) -> int:
    """Design a multi-axis problem file; print its summary (or JSON); the exit code.

    Parameters
    ----------
    args : argparse.Namespace
        ``design``'s arguments (``problem``, ``json``, ``quiet``; ``--method`` picks
        ``nlp`` or ``analytic`` = the per-axis designs).

    Returns
    -------
    int
        0 certified, 1 not certified.
    """
    from dataclasses import replace

    from robrst.problem.mimo_files import load_mimo_problem
    from robrst.report.mimo import mimo_summary
    from robrst.design.mimo import design_mimo

    problem = load_mimo_problem(args.problem)
    method = getattr(args, "method", None)
    if method:
        problem = replace(problem, solver=replace(
            problem.solver, method="nlp" if method == "nlp" else "per_axis"))
    say = progress_printer(args.quiet or args.json)
    result = design_mimo(problem, progress=say)
    if args.json:
        print_json(result.as_dict())
    else:
        print(mimo_summary(result))
    if not result.certified:
        for v in result.certificate.violations[:5]:
            print(f"robrst: not certified: {v.describe()}", file=sys.stderr)
        return 1
    return 0
