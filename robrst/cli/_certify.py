"""``robrst certify``: the certificate of a saved design's controller, on its own problem or
another one (another family, a drawn actuator, an identified model), without designing."""

import argparse

from robrst.cli._common import print_result, progress_printer

__all__ = ["add_parsers", "run_certify"]


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``certify``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-command collection of the ``robrst`` parser.
    """
    c = sub.add_parser("certify", help="certify a saved design's controller (DESIGN.json) on"
                                       " its problem or another one, without designing"
                                       " (exit 0 certified, 1 not certified, 2 error)")
    c.add_argument("design", help="a saved design: the JSON of robrst design --json")
    c.add_argument("--problem", metavar="OTHER.toml",
                   help="a problem file or a model file of robrst identify: its plant family"
                        " replaces the design's, and so does every other table it states"
                        " (specs, poles, solver)")
    c.add_argument("--family-only", action="store_true",
                   help="with --problem: take only its plant family; keep the design's specs")
    c.add_argument("--json", action="store_true",
                   help="print exactly one JSON object (a saved design: this controller with"
                        " the problem and the certificate)")
    c.add_argument("--quiet", action="store_true", help="no progress lines")
    c.set_defaults(func=run_certify)


def run_certify(args: argparse.Namespace) -> int:
    """Certify; print the summary (or the JSON).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 certified, 1 not certified.

    Raises
    ------
    SpecError
        ``--family-only`` without ``--problem`` (and the files' own errors).
    """
    from robrst.base.errors import SpecError
    from robrst.base.schema import load_toml
    from robrst.controller.artefact import read_design, recertify
    from robrst.problem.files import resolve_problem_path

    say = progress_printer(args.quiet or args.json)
    if args.family_only and args.problem is None:
        raise SpecError("--family-only: needs --problem OTHER.toml")
    design = read_design(args.design)      # a bad file fails before any progress line
    other, path = None, "<problem>"
    if args.problem is not None:
        path = resolve_problem_path(args.problem)
        other = load_toml(path, "problem or model file")
    say(f"certifying the controller of {args.design} on"
        f" {'its own problem' if other is None else path} (no design)")
    result = recertify(design, other, str(path), args.family_only, progress=say,
                       name=args.design)
    return print_result(result, args.json)
