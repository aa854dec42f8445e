"""The design of one problem (no spread): method -> candidate -> certificate -> analyses.

:func:`design_single` runs the analytic design, or the robust program (multi-started when
asked: its global phase, :mod:`robrst.synthesis.search`) or the convex one
(:func:`robrst.design.candidate.candidate`), then the analytic check, the comparison and
the analyses of every family model, into one :class:`~robrst.design.result.DesignResult`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

from robrst.certificate.proof import certify_problem
from robrst.core.analysis import analyze_many
from robrst.design.candidate import (LOCAL_RUN_NOTE, analytic_check, analytic_design,
                                     candidate, comparison, offer_candidate)
from robrst.design.result import DesignResult
from robrst.synthesis.multistart import multistart_record
from robrst.synthesis.tracking import design_tracking

if TYPE_CHECKING:
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem
    from robrst.synthesis.outcome import SynthesisResult

__all__ = ["design_single", "analyse"]


def analyse(problem: Problem, ctrl: RSTController) -> tuple:
    """The analyses of every family model and the assessment of what the specs left
    unbounded (:func:`robrst.certificate.assessment.assess`).

    Parameters
    ----------
    problem : Problem
        The problem.
    ctrl : RSTController
        The controller.

    Returns
    -------
    (tuple of Analysis, Assessment)
    """
    from robrst.certificate.assessment import assess

    return analyze_many(problem.family.models, ctrl), assess(problem, ctrl)


def design_single(problem: Problem, progress: Callable[[str], None] | None = None,
                  templates: dict | None = None, analyses: bool = True,
                  multistart: bool = False, warm: SynthesisResult | None = None,
                  compare: bool = True, stop: Callable[[], bool] | None = None,
                  incumbent: RSTController | None = None) -> DesignResult:
    """:func:`robrst.design.run_problem` of a problem without a spread (its BLAS limited
    by the caller).

    Parameters
    ----------
    problem : Problem
        The problem.
    progress : callable, optional
        Called with one line of text per stage.
    templates : dict, optional
        Built NLP solvers by structure.
    analyses : bool
        Analyse every family model and assess the design.
    multistart : bool
        Run the robust program's global phase (:mod:`robrst.synthesis.search`: every
        controller of the structure searched in this process, ``1 + problem.solver.starts``
        distinct candidates polished; ``starts = 0``: one local run).
    warm : SynthesisResult, optional
        A previous design's synthesis record: the robust synthesis's preferred start.
    compare : bool
        Compare with ``compare_with``'s analytic design.
    stop : callable, optional
        Polled once per generation of the global phase and per certification round
        (default :func:`robrst.base.interrupt.requested`).
    incumbent : RSTController, optional
        A controller of the problem's structure the answer is to beat (``method = "nlp"``;
        :func:`robrst.design.run_problem` checks it).

    Returns
    -------
    DesignResult
    """
    say = progress or (lambda msg: None)
    method = problem.solver.method
    start = analytic_design(problem)          # an ill-posed problem fails before any line
    say(f"method {problem.solver.method_reason}")
    two_dof = problem.controller.T_mode == "reference_model"
    starts = None
    if method == "analytic":
        say(f"analytic pole placement: cond(scaled Sylvester) = {start.cond:.3g}"
            f" (unscaled {start.cond_unscaled:.3g})")
        stage, check = start, None
        ctrl, trk = (design_tracking(problem, start.controller) if two_dof
                     else (start.controller, None))
        cert = certify_problem(problem, ctrl)
    else:
        glob = method == "nlp" and multistart and problem.solver.starts > 0
        t0 = time.perf_counter()
        stage, ctrl, trk, cert = candidate(problem, problem, False, start, say, templates,
                                           warm=warm, global_phase=glob, stop=stop,
                                           incumbent=incumbent)
        if glob:
            starts = multistart_record(stage, time.perf_counter() - t0)
        elif method == "nlp":       # the answer of a local method: said so
            stage = replace(stage, notes=(*stage.notes, LOCAL_RUN_NOTE))
        offer_candidate(problem, ctrl, cert)
        check = analytic_check(problem, stage.controller, stage.Am)
    comp = None if method == "analytic" or not compare else comparison(problem, ctrl, cert)
    found, assessment = analyse(problem, ctrl) if analyses else ((), None)
    return DesignResult(problem=problem, method=method, controller=ctrl,
                        target_char_poly=stage.Am, analyses=found, certificate=cert,
                        synthesis=stage, analytic_check=check, comparison=comp, tracking=trk,
                        assessment=assessment, starts=starts)
