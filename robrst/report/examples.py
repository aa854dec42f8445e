"""Regenerate the committed example reports: ``python -m robrst.report.examples [OUT]``.

Writes ``OUT/paper``, ``OUT/paper_robust`` (design reports of the two problem files)
and ``OUT/diagnosis_twin`` (a gap diagnosis of twin data with a hidden effect, case
``hysteresis`` seed 100 of the withheld-effect suite).  ``OUT`` defaults to
``reports``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

from robrst.design import run_problem
from robrst.diagnose import diagnose
from robrst.diagnose.validation import make_case
from robrst.report.design import write_design_report
from robrst.report.diagnosis import write_diagnosis_report
from robrst.problem.files import load_problem

__all__ = ["write_examples", "DIAGNOSIS_CASE"]

DIAGNOSIS_CASE = ("hysteresis", 100)


def write_examples(out: str | Path = "reports",
                   progress: Callable[[str], None] | None = None) -> list[Path]:
    """Write the three example report folders under ``out``; returns their paths.

    Parameters
    ----------
    out : str or pathlib.Path
        The parent folder (``paper``, ``paper_robust`` and ``diagnosis_twin`` are written
        in it).
    progress : callable, optional
        Called with one line of text per stage.

    Returns
    -------
    list of pathlib.Path
    """
    say = progress or (lambda m: None)
    out = Path(out)
    paths = []
    for name in ("paper", "paper_robust"):
        say(f"report {name}")
        res = run_problem(load_problem(name))
        paths.append(write_design_report(res, out / name, progress=say))
    say("diagnosis of twin data with a hidden effect")
    train, test, _ = make_case(*DIAGNOSIS_CASE)
    diag = diagnose(train, test, progress=say)
    paths.append(write_diagnosis_report(diag, out / "diagnosis_twin", progress=say))
    return paths


if __name__ == "__main__":
    for p in write_examples(sys.argv[1] if len(sys.argv) > 1 else "reports",
                            progress=lambda m: print(m, file=sys.stderr)):
        print(p)
