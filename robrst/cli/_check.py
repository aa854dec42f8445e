"""``robrst check``: margins of a design against a golden file (users' regression tests)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from robrst.cli._common import design_result, is_saved_design, progress_printer
from robrst.cli._mimo import is_mimo_file
from robrst.problem.files import load_problem
from robrst.testing import (check_golden_fits, check_golden_target, compare_golden,
                            count_figures, figures_line, golden_figures, read_golden,
                            write_golden)

if TYPE_CHECKING:
    import argparse

__all__ = ["add_parsers", "run_check"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``check``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parser collection of :func:`robrst.cli.build_parser`.
    """
    c = sub.add_parser("check", help="compare a design's margins with a golden file"
                                     " (exit 0 nothing worse, 1 something worse, 2 error)")
    c.add_argument("problem", help="problem file (TOML; a multi-axis [mimo] problem too), a"
                                   " built-in problem by name, or a saved design (DESIGN.json:"
                                   " its controller, not designed again)")
    c.add_argument("--golden", required=True, metavar="FILE", help="golden margins (TOML)")
    c.add_argument("--update", action="store_true",
                   help="write the golden from this design instead of comparing (exit 0"
                        " certified, 1 not certified)")
    c.add_argument("--quiet", action="store_true", help="no progress lines")
    c.set_defaults(func=run_check)


def run_check(args: argparse.Namespace) -> int:
    """Design, then write the golden (``--update``) or print every figure that got worse.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 nothing worse (``--update``: certified), 1 something worse
        (``--update``: not certified).
    """
    say = progress_printer(args.quiet)
    golden = None if args.update else read_golden(args.golden)   # a bad golden fails first
    if args.update:
        check_golden_target(args.golden)      # a file in the way fails before the design
    problem = None
    if is_mimo_file(args.problem):                  # a multi-axis problem: its joint design
        from robrst.design.mimo import design_mimo
        from robrst.problem.mimo_files import load_mimo_problem

        problem = load_mimo_problem(args.problem)
        if golden is not None:
            check_golden_fits(golden, problem)
        say(f"designing {problem.name} ({problem.solver.method}, {len(problem.axes)} axes)")
        result = design_mimo(problem, progress=say)
    else:
        if not is_saved_design(args.problem):
            problem = load_problem(args.problem)
            if golden is not None:
                check_golden_fits(golden, problem)      # before the design
        result = design_result(args.problem, say, problem)
    if problem is None and golden is not None:
        check_golden_fits(golden, result.problem)
    if args.update:                                 # exit code as `design`: 1 not certified
        write_golden(result, args.golden)
        g = golden_figures(result)
        # the count the next check reads: the file as written (a peak of inf is not written)
        print(f"wrote {args.golden}: {figures_line(read_golden(args.golden))}"
              f" (certified: {g['certified']})")
        return 0 if g["certified"] else 1
    worse = compare_golden(result, golden)
    for w in worse:
        print(w.describe())
    n = count_figures(golden)
    print(f"robrst check: {len(worse)} of {n} figures worse than {args.golden}"
          if worse else f"robrst check: no figure worse than {args.golden}"
          f" ({figures_line(golden)})")
    return 1 if worse else 0
