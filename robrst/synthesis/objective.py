"""The certified objective of a controller: the one number every search compares.

:func:`objective` is what the robust synthesis keeps the best of
(:mod:`robrst.synthesis.attempts`), what the multi-start of :mod:`robrst.design` picks the
winner by and what a bound scan (:mod:`robrst.studies.scan`) plots: larger is better, and an
uncertified controller has none.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.synthesis.parametrize import integral_gain

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem

__all__ = ["objective"]


def objective(problem: Problem, ctrl: RSTController, cert: Certificate) -> float | None:
    """The certified objective of ``ctrl`` (larger is better).

    Parameters
    ----------
    problem : Problem
        The problem (its ``solver.objective``).
    ctrl : RSTController
        The controller.
    cert : Certificate
        Its certificate on ``problem``.

    Returns
    -------
    float or None
        ``|integral gain|`` (``max_integral_gain``), ``-worst Ms`` (``min_Ms``) or 0
        (``feasibility``); ``None`` when ``cert`` does not certify (or the integral gain is
        not finite).

    Examples
    --------
    >>> from robrst import load_problem, run_problem
    >>> from robrst.synthesis.objective import objective
    >>> pr = load_problem("paper")
    >>> res = run_problem(pr, analyses=False)
    >>> round(objective(pr, res.controller, res.certificate), 1)
    432.6
    """
    if not cert.certified:
        return None
    obj = problem.solver.objective
    if obj == "max_integral_gain":
        ki = integral_gain(ctrl)
        return abs(ki) if np.isfinite(ki) else None
    if obj == "min_Ms":
        return -cert.worst("Ms")
    return 0.0
