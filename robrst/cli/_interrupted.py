"""What an interrupted command shows: the best certified answer its design had found.

The design pipeline offers each certified candidate it completes
(:func:`robrst.base.interrupt.offer`: ``(problem, controller, certificate)``); when a
signal stops ``robrst design``, the best one is printed as the design's answer with the
status ``interrupted`` (its JSON with ``--json``): what the run had proved before it
stopped, nothing more (no margins table of the family models, no comparison).  Other
commands write nothing after a signal (a half-done report, export or golden is never
written).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from robrst.base.interrupt import best
from robrst.cli._common import print_json

if TYPE_CHECKING:
    import argparse

    from robrst.base.interrupt import Interrupted

__all__ = ["show_best", "interrupted_dict"]


def interrupted_dict(candidate: tuple, signal_word: str) -> dict:
    """The design JSON of an offered candidate, with ``status = "interrupted"``.

    Parameters
    ----------
    candidate : (Problem, RSTController, Certificate)
        What the pipeline offered.
    signal_word : str
        ``"interrupted"`` or ``"terminated"``.

    Returns
    -------
    dict
        :meth:`robrst.design.DesignResult.as_dict` of the candidate (``models``: none
        analysed) with ``status = "interrupted"`` and an ``interrupted`` object saying so.
    """
    from robrst.controller.artefact import StoredRecord
    from robrst.design import DesignResult

    problem, ctrl, cert = candidate
    note = (f"the run was {signal_word} before the design finished: this is the best"
            " certified answer it had found, with its certificate (the design might have"
            " found a better one)")
    result = DesignResult(problem=problem, method=problem.solver.method, controller=ctrl,
                          target_char_poly=None, analyses=(), certificate=cert,
                          synthesis=StoredRecord({"name": "interrupted",
                                                  "objective": problem.solver.objective,
                                                  "notes": [note]}))
    d = result.as_dict()
    d["status"] = "interrupted"
    d["interrupted"] = {"signal": signal_word, "certified": bool(cert.certified), "note": note}
    return d


def show_best(args: argparse.Namespace, exc: Interrupted) -> None:
    """Print the best certified answer offered before the signal (``robrst design`` only).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    exc : Interrupted
        The signal's exception.
    """
    cand = best()
    if cand is None or getattr(args, "command", None) != "design":
        return
    d = interrupted_dict(cand, exc.word)
    if getattr(args, "json", False):
        print_json(d)
        return
    from robrst.report.text import design_summary

    print(f"INTERRUPTED: {d['interrupted']['note']}")
    print(design_summary(d))
