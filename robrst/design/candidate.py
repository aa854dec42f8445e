"""One candidate design: synthesis -> feedback -> reference path -> certificate.

:func:`candidate` runs the synthesis the problem asks for (the robust NLP or the convex
program) from the analytic design (:func:`analytic_design`), adds the two-degree-of-freedom
reference path and completes the certificate by the time-domain specs
(:mod:`robrst.certificate.completion`).  :func:`analytic_check` and :func:`comparison` are
the two checks reported beside a synthesised design.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from robrst.base.errors import CoprimeError, SpecError
from robrst.base.interrupt import offer
from robrst.certificate.proof import certify
from robrst.core import poly
from robrst.design.achieved import AnalyticCheck, Comparison
from robrst.synthesis import analytic
from robrst.synthesis.objective import objective
from robrst.synthesis.parametrize import integral_gain

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import PoleSpec, Problem
    from robrst.synthesis.analytic import AnalyticDesign

__all__ = ["candidate", "analytic_design", "analytic_check", "comparison", "offer_candidate",
           "LOCAL_RUN_NOTE"]

#: the note of a robust design without the global phase (``[solver] starts = 0``,
#: ``multistart = false``, ``--starts 0``): local runs from the problem's own design, whose
#: answer depends on where they start (``paper_robust``: 751.8 against 861,623 with the
#: phase, docs/background/benchmarks.md)
LOCAL_RUN_NOTE = ("no global phase: the robust program's local runs from the problem's own"
                  " design, whose answer depends on where they start (the default,"
                  " [solver] multistart = true with starts > 0, searches every controller"
                  " of the structure first)")


def analytic_design(problem: Problem, poles: PoleSpec | None = None) -> AnalyticDesign:
    """Pole placement on the reference model of ``problem`` (the paper's method).

    Parameters
    ----------
    problem : Problem
        The problem (its reference model and controller structure).
    poles : PoleSpec, optional
        Other poles than the problem's.

    Returns
    -------
    AnalyticDesign

    Raises
    ------
    SpecError, CoprimeError
        The message starts with the problem file's path (when it has one).
    """
    try:
        return analytic.pole_placement(problem.family.reference_model, poles or problem.poles,
                                       problem.controller)
    except (SpecError, CoprimeError) as exc:     # DegreeError is a SpecError
        if problem.path and not str(problem.path).startswith("<") and str(problem.path) not in str(exc):
            exc.args = (f"{problem.path}: {exc}",) + exc.args[1:]
        raise

def analytic_check(problem: Problem, ctrl: RSTController, Am: ArrayLike) -> AnalyticCheck:
    """Compare a synthesised controller with the Sylvester solution for the same ``Am``.

    With no free degree (``extra_degree = 0``) the Diophantine solution is unique and
    the synthesis must reproduce it coefficient by coefficient; with free degrees the
    check is the Diophantine residual at the nominal model.

    Parameters
    ----------
    problem : Problem
        The problem.
    ctrl : RSTController
        The synthesised controller.
    Am : array_like
        Its nominal characteristic polynomial.

    Returns
    -------
    AnalyticCheck
    """
    ref = problem.family.reference_model
    c = problem.controller
    if c.extra_degree == 0:
        sol = analytic.solve_diophantine(ref.A, ref.B, Am, c.S_fixed, c.R_fixed)
        err = max(poly.rel_coef_error(ctrl.R, sol.R), poly.rel_coef_error(ctrl.S, sol.S))
        kind = "sylvester_coefficients"
    else:
        err = analytic.diophantine_residual(ref.A, ref.B, ctrl.R, ctrl.S, Am)
        kind = "diophantine_residual"
    return AnalyticCheck(kind=kind, max_rel_coef_error=float(err), passed=bool(err <= 1e-8))


def _worst(cert, ctrl, sampled):
    row = {"worst_Ms": cert.worst("Ms"), "worst_Mt": cert.worst("Mt"),
           "worst_Mu": cert.worst("Mu"), "min_modulus_margin": 1 / cert.worst("Ms"),
           "max_spectral_abscissa": cert.worst("spectral_abscissa"),
           "integral_gain": integral_gain(ctrl), "certified": cert.certified}
    if sampled:
        row.update({f"worst_{k}_sampled": cert.worst(k, loop="sampled") for k in ("Ms", "Mt", "Mu")})
    return row


def comparison(problem: Problem, ctrl: RSTController, cert: Certificate) -> Comparison | None:
    """Worst-case margins over the family: this controller vs ``compare_with``'s analytic design.

    This controller's figures come from its certificate (reused, not recomputed); the
    analytic design's are computed on the family members only (both loops), which is
    what the comparison shows — a certificate of the analytic design is not the point.

    Parameters
    ----------
    problem : Problem
        The problem (its ``compare_with``).
    ctrl : RSTController
        This controller.
    cert : Certificate
        This controller's certificate.

    Returns
    -------
    Comparison or None
        ``None`` when the problem names no ``compare_with`` file.
    """
    from robrst.problem.files import load_problem

    other = problem.solver.compare_with
    if not other:
        return None
    path = Path(problem.path).parent / other
    ctrl_a = analytic_design(load_problem(path)).controller
    # the members only: no sweep, no refinement (an interval whose figures change too fast
    # between members is unresolved, so "certified" stays a conservative verdict)
    cert_a = certify(problem.family, ctrl_a, problem.specs, n_sweep=0,
                     rtol=problem.solver.cert_tol, max_refine=0)
    rows = {"robust": _worst(cert, ctrl, problem.specs.sampled),
            f"analytic ({path.name})": _worst(cert_a, ctrl_a, problem.specs.sampled)}
    lo, hi = problem.family.range_C
    names = list(rows)
    w = max(len(n) for n in names) + 2
    lines = [f"worst case over the family ({lo:g}..{hi:g} °C; robust: certificate sweep,"
             " analytic: family members):",
             f"{'':<22}" + "".join(f"{n:>{w}}" for n in names)]
    for k in rows["robust"]:
        lines.append(f"{k:<22}" + "".join(
            f"{(str(rows[n][k]) if isinstance(rows[n][k], bool) else format(rows[n][k], '.4g')):>{w}}"
            for n in names))
    return Comparison(rows=rows, table="\n".join(lines), range_C=(lo, hi))


def candidate(problem: Problem, original: Problem, recheck: bool = False,
              start: AnalyticDesign | None = None, say: Callable[[str], None] | None = None,
              templates: dict | None = None, budget: int | None = None,
              warm: object = None, global_phase: bool = False,
              stop: Callable[[], bool] | None = None,
              incumbent: RSTController | None = None) -> tuple:
    """One synthesis of ``problem`` judged on ``original``, its reference path and its
    certificate completed by the time-domain figures.

    Parameters
    ----------
    problem : Problem
        The problem synthesised.
    original : Problem
        The problem judged on: the same one, or (``recheck``) the problem whose answer a
        neighbouring one (a multi-start plan) is a candidate for.
    recheck : bool
        Certify the answer on ``original`` (its frequency-domain certificate,
        :func:`robrst.synthesis.attempts.frequency_certificate`).
    start : AnalyticDesign, optional
        The analytic design of ``problem`` (computed when not given).
    say : callable, optional
        Progress lines.
    templates : dict, optional
        Built NLP solvers by structure (:class:`robrst.synthesis.synthesizer.Synthesizer`).
    budget : int, optional
        IPOPT iterations the whole synthesis may spend.
    warm : SynthesisResult, optional
        A previous design's synthesis record: the robust synthesis's preferred start (the
        rounds of a fleet design).
    global_phase : bool
        The robust synthesis searches every controller of the structure first
        (:mod:`robrst.synthesis.search`) and polishes its best distinct candidates.
    stop : callable, optional
        Polled once per generation of the global phase and per certification round
        (default :func:`robrst.base.interrupt.requested`): true ends the synthesis with
        the best point found so far.
    incumbent : RSTController, optional
        A controller of the problem's structure the answer is to beat
        (:func:`robrst.synthesis.robust.robust_synthesis`).

    Returns
    -------
    (SynthesisResult, RSTController, Tracking or None, Certificate)
        The synthesis record, the controller (with its reference path), the reference
        path's record and the certificate.
    """
    from robrst.synthesis.robust import robust_synthesis
    from robrst.synthesis.tracking import with_steps

    start = start if start is not None else analytic_design(problem)
    if problem.solver.method == "convex":
        from robrst.synthesis.convex import convex_synthesis   # cvxpy: only for this method

        stage = convex_synthesis(problem, start, say)
    else:
        stage = robust_synthesis(problem, start, say, templates, warm=warm, budget=budget,
                                 global_phase=global_phase, stop=stop, incumbent=incumbent)
    ctrl, cert = stage.controller, stage.certificate
    if recheck:
        from robrst.synthesis.attempts import frequency_certificate

        cert = frequency_certificate(original, ctrl)
    ctrl, trk, cert = with_steps(original, ctrl, cert)
    return stage, ctrl, trk, cert


def offer_candidate(problem: Problem, ctrl: RSTController, cert: Certificate) -> None:
    """Offer a certified candidate as the answer of a run a signal stops
    (:func:`robrst.base.interrupt.offer`, scored by :func:`robrst.synthesis.objective.objective`).

    Parameters
    ----------
    problem : Problem
        The problem the candidate was judged on.
    ctrl : RSTController
        The controller.
    cert : Certificate
        Its complete certificate (time-domain figures included).
    """
    obj = objective(problem, ctrl, cert)
    if obj is not None:
        offer(obj, (problem, ctrl, cert))
