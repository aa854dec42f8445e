"""The design pipeline: problem -> synthesis -> certificate -> analysis -> result.

:func:`run_problem` runs the method the problem asks for (analytic pole placement, the
robust NLP or the convex program; :mod:`robrst.design._single`), or the design for a
fleet of a problem with a ``[spread]`` (:mod:`robrst.design.fleet`), certifies the
controller on the whole family (:mod:`robrst.certificate.proof`), analyses every family
model, checks a synthesised controller against the closed-form Diophantine solution and
compares it with an analytic design.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from dataclasses import replace

import numpy as np

from robrst.base.threads import one_blas_thread
from robrst.design.fleet import fleet_design
from robrst.design._single import design_single
from robrst.design.result import SKIPPED
from robrst.design.tolerance import spread_tolerance
from robrst.problem.records import with_defaults
from robrst.problem.documents import check_problem
from robrst.synthesis.feasibility import (feasibility_verdict, prove_control_infeasible,
                                          prove_infeasible, prove_region_infeasible,
                                          prove_step_infeasible)
from robrst.synthesis.limits import design_limits

if TYPE_CHECKING:
    from robrst.core.rst import RSTController
    from robrst.design.result import DesignResult
    from robrst.problem.records import Problem

__all__ = ["run_problem", "infeasibility", "SKIPPED"]



def run_problem(problem: Problem, progress: Callable[[str], None] | None = None,
                templates: dict | None = None, analyses: bool = True,
                multistart: bool | None = None,
                stop: Callable[[], bool] | None = None,
                incumbent: RSTController | DesignResult | None = None) -> DesignResult:
    """Run the design the problem asks for, certify it, analyse every family model.

    A synthesis always ends with a controller: when the specs cannot be met the result
    is the best controller found, ``status == "not_certified"``, with
    :attr:`DesignResult.best_achievable` and the binding constraints.  The default specs
    of a bounded problem (:func:`robrst.problem.records.with_defaults`) are resolved
    first: the result's problem states them.

    Parameters
    ----------
    problem : Problem
        The problem (a problem file read by :func:`robrst.load_problem`, or built in code).
    progress : callable, optional
        Called with one line of text per stage (certification rounds included).
    templates : dict, optional
        Built NLP solvers by structure, shared between designs of the same structure
        (see :class:`robrst.synthesis.synthesizer.Synthesizer`).
    analyses : bool
        Analyse every family model (exact peaks to 1e-10, margins), assess what the specs
        left unbounded (:func:`robrst.certificate.assessment.assess`: damping, overshoot,
        input disturbances) and state the limits (:func:`robrst.synthesis.limits.design_limits`:
        what any linear controller could reach; infeasible or not found); off: none (a
        sweep reads the certificate's figures and computes only the margins).  Either way
        specs that no linear controller meets are proved so first (milliseconds), the
        synthesis is then skipped and ``feasibility`` holds the proof.
    multistart : bool, optional
        The robust program (``method = "nlp"``) runs its global phase: every controller
        of the structure searched (:mod:`robrst.synthesis.search`), the best distinct
        candidates polished and certified, the best certified answer kept, all in this
        process (default: ``problem.solver.multistart and problem.solver.starts > 0``;
        ``False``: one local run from the problem's start). A problem with a
        ``[spread]`` is designed for the fleet (:mod:`robrst.design.fleet`), each round's
        global phase seeded with the round before.
    stop : callable, optional
        Polled once per generation of the global phase and per certification round
        (default :func:`robrst.base.interrupt.requested`): true ends the design with the
        best point found so far (certified for what it achieves).
    incumbent : RSTController or DesignResult, optional
        A controller to beat (a design's controller: the one in service, or the answer of
        a tighter bound), of the problem's structure, for the robust program
        (``method = "nlp"``). With the global phase it starts the search's first run, is
        certified as it is and polished first: when it meets the specs the answer is never
        below it (a scan of a bound that hands each answer to the next looser one is
        monotone). Without the global phase it starts the local run.

    Returns
    -------
    DesignResult

    Raises
    ------
    SpecError, CoprimeError, DegreeError
        Ill-posed problems (the message names the cause and the key to change), and an
        incumbent the problem cannot take (another structure, another method, a
        ``[spread]``).

    Examples
    --------
    >>> from robrst import load_problem, run_problem
    >>> result = run_problem(load_problem("paper"))
    >>> result.certified, result.status
    (True, 'certified')
    """
    if multistart is None:
        multistart = problem.solver.multistart
    check_problem(problem)        # a problem built or changed in Python: the file's checks
    problem = with_defaults(problem)
    incumbent = _incumbent(problem, incumbent)
    with one_blas_thread(problem.needs_scipy):
        proofs = infeasibility(problem)
        if proofs:     # no linear controller meets the specs: the start design is the answer
            (progress or (lambda msg: None))(
                "infeasible: " + proofs[0].reason + "; the synthesis is skipped, the analytic"
                " start design is reported")
            run = replace(problem, spread=None, solver=replace(
                problem.solver, method="analytic", method_source="infeasible"))
            result = replace(design_single(run, progress, templates, analyses, False),
                             problem=problem, method=problem.solver.method)
        elif problem.spread is not None:
            result = fleet_design(problem, progress, templates, analyses, multistart)
        else:
            result = design_single(problem, progress, templates, analyses, multistart,
                                   stop=stop, incumbent=incumbent)
        if not analyses:
            if proofs:   # the proof stands without the analyses (the limits are not stated)
                return replace(result, feasibility=replace(feasibility_verdict(
                    problem, result.certificate, result.controller), note=SKIPPED))
            return result
        bound, verdict = design_limits(problem, result.controller, result.certificate,
                                       result.certified)
        if proofs and verdict is not None:
            verdict = replace(verdict, note=SKIPPED)
        # the next actuator off the line: a stated spread is the fleet design's own
        tolerance = (spread_tolerance(problem, result.controller)
                     if result.certified and problem.spread is None else None)
        return replace(result, objective_bound=bound, feasibility=verdict,
                       tolerance=tolerance)


def _incumbent(problem, given):
    """The controller of ``given`` (a controller or a design) checked against ``problem``:
    the robust program's, no spread, the problem's structure (a :class:`SpecError` naming
    what differs)."""
    if given is None:
        return None
    from robrst.base.errors import SpecError
    from robrst.design.candidate import analytic_design
    from robrst.synthesis.robust import incumbent_fits

    # a design's feedback law as synthesised (a 2-DOF design's R and S without the
    # reference model's common factor)
    stage = getattr(given, "synthesis", None)
    ctrl = stage.controller if stage is not None else getattr(given, "controller", given)
    if problem.solver.method != "nlp":
        raise SpecError(f"incumbent: the robust program starts from it ([solver] method ="
                        f' "nlp"); this problem\'s method is {problem.solver.method!r}')
    if problem.spread is not None:
        raise SpecError("incumbent: a problem with a [spread] is designed round by round"
                        " for its actuators; design it without an incumbent")
    why = incumbent_fits(problem, analytic_design(problem), ctrl)
    if why is not None:
        raise SpecError(f"incumbent: not a controller of this problem's structure ({why})")
    return ctrl


def infeasibility(problem: Problem) -> tuple:
    """The proofs that no controller meets the problem's specs: a reference-step spec
    beyond causality (:func:`robrst.synthesis.feasibility.prove_step_infeasible`), a decay
    floor beyond a vanishing creep pair
    (:func:`robrst.synthesis.feasibility.prove_region_infeasible`), a ``Mu_max`` below what
    any controller stabilising an unstable plant needs
    (:func:`robrst.synthesis.feasibility.prove_control_infeasible`), or no
    linear controller on some family member
    (:func:`robrst.synthesis.feasibility.prove_infeasible`); none for the analytic method or
    when the proof's arithmetic fails (the synthesis then runs and the verdict says the rest).

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    tuple of Infeasibility
    """
    if problem.solver.method == "analytic":
        return ()
    try:
        members = list(problem.family.models)
        return (prove_step_infeasible(problem) + prove_region_infeasible(problem)
                + prove_control_infeasible(problem, members)
                + tuple(prove_infeasible(problem, members)))
    except (ArithmeticError, ValueError, np.linalg.LinAlgError):
        return ()
