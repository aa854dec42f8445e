"""Helpers shared by the commands: progress lines, JSON output."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from robrst.base.fileio import json_text

__all__ = ["progress_printer", "print_json", "is_saved_design", "design_result",
           "certified_exit", "print_result"]


def progress_printer(quiet: bool) -> Callable[[str], None]:
    """A progress callback printing to stderr, or a silent one.

    Parameters
    ----------
    quiet : bool
        Print nothing.

    Returns
    -------
    callable
        ``progress(message)``.
    """
    if quiet:
        return lambda msg: None
    return lambda msg: print(msg, file=sys.stderr, flush=True)


def print_json(obj: Any, indent: int | None = None) -> None:
    """Print exactly one JSON object on stdout (robrst's contract).

    Parameters
    ----------
    obj : object
        The object (see :func:`robrst.base.fileio.jsonable`).
    indent : int, optional
        Indentation (``None``: one line).
    """
    print(json_text(obj, indent=indent))


def is_saved_design(arg: str) -> bool:
    """True when the command-line argument names a saved design (a JSON file).

    Parameters
    ----------
    arg : str
        A command's ``PROBLEM`` argument.

    Returns
    -------
    bool
    """
    from robrst.controller.artefact import is_design_file

    return is_design_file(arg)


def design_result(arg: str, say: Callable[[str], None], problem: object = None,
                  announce: bool = True, incumbent: object = None) -> object:
    """The design result of a command's ``PROBLEM`` argument.

    Parameters
    ----------
    arg : str
        A saved design (read back: its controller as saved, certified again; never
        designed) or a problem file or built-in name (designed now).
    say : callable
        Progress lines.
    problem : Problem, optional
        The problem already loaded from ``arg``.
    announce : bool, optional
        Say "designing NAME (method)" before a design (``robrst design`` does not: a
        problem that fails before its design must print one line only).
    incumbent : RSTController, optional
        A controller the design is to beat (:func:`robrst.design.run_problem`).

    Returns
    -------
    DesignResult
    """
    if is_saved_design(arg):
        from robrst.controller.artefact import design_from_dict, read_design

        doc = read_design(arg)             # a bad file fails before any progress line
        say(f"reading the saved design {arg} (its controller as saved; no design)")
        return design_from_dict(doc, str(arg), progress=say)
    from robrst.design import run_problem
    from robrst.problem.files import load_problem

    problem = problem or load_problem(arg)
    if announce:
        say(f"designing {problem.name} ({problem.solver.method})")
    return run_problem(problem, progress=say, incumbent=incumbent)


def certified_exit(certified: bool, certificate: object) -> int:
    """The exit code of a certified or not certified answer, the first violations on stderr.

    Parameters
    ----------
    certified : bool
        Whether the answer is certified.
    certificate : Certificate
        Its certificate (:class:`~robrst.certificate.proof.Certificate`): up to five of its
        violations are printed, one line each, when not certified.

    Returns
    -------
    int
        0 certified, 1 not certified.
    """
    if certified:
        return 0
    for v in certificate.violations[:5]:
        print(f"robrst: not certified: {v.describe()}", file=sys.stderr)
    return 1


def print_result(result: object, as_json: bool) -> int:
    """Print a design's result (one JSON object, or the text summary); its exit code.

    Parameters
    ----------
    result : DesignResult
        The design (or re-certified saved design).
    as_json : bool
        Print the design's JSON (:func:`robrst.design.contract.design_json`) as exactly one
        object instead of the summary (:func:`robrst.report.text.design_summary`).

    Returns
    -------
    int
        0 certified, 1 not certified (:func:`certified_exit`).
    """
    if as_json:
        from robrst.design.contract import design_json

        print_json(design_json(result))
    else:
        from robrst.report.text import design_summary

        print(design_summary(result))
    return certified_exit(result.certified, result.certificate)
