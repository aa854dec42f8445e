"""What a design is measured against: the estimate of what any linear controller could
reach (:mod:`robrst.synthesis.bound`) and, when it is not certified, whether the specs are
infeasible (:mod:`robrst.synthesis.feasibility`).  One call for the design pipeline."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.synthesis.bound import ObjectiveBound, objective_bound
from robrst.synthesis.feasibility import feasibility_verdict

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem
    from robrst.synthesis.feasibility import FeasibilityVerdict

__all__ = ["design_limits", "design_value"]


def design_value(problem: Problem, controller: RSTController, cert: Certificate) -> float | None:
    """The design's figure of the problem's objective: ``|ki|`` [V/(µm s)] or the worst
    ``Ms`` over both loops (``None`` for ``feasibility`` or an infinite gain).

    Parameters
    ----------
    problem : Problem
    controller : RSTController
    cert : Certificate

    Returns
    -------
    float or None
    """
    from robrst.synthesis.parametrize import integral_gain

    obj = problem.solver.objective
    if obj == "max_integral_gain":
        ki = integral_gain(controller)
        return abs(ki) if np.isfinite(ki) else None
    if obj == "min_Ms":
        vals = [v for v in (cert.worst("Ms"), cert.worst("Ms", loop="sampled")) if v is not None]
        return max(vals) if vals else None
    return None


def design_limits(problem: Problem, controller: RSTController, cert: Certificate,
                  certified: bool) -> tuple[ObjectiveBound | None, FeasibilityVerdict | None]:
    """The objective's estimate (when ``[solver] bound`` is on, and always for a design that
    is not certified) and, for a design that is not certified, the feasibility verdict.

    Parameters
    ----------
    problem : Problem
        The problem designed.
    controller : RSTController
        The design (its own ``Q`` joins the estimate's programs when certified).
    cert : Certificate
        Its certificate.
    certified : bool
        The design is certified.

    Returns
    -------
    (ObjectiveBound or None, FeasibilityVerdict or None)
    """
    try:
        return _limits(problem, controller, cert, certified)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        # the design stands without them: say so instead of failing it
        why = f"the estimate could not be computed ({type(exc).__name__}: {exc})"
        return ObjectiveBound(objective=problem.solver.objective, status="no_estimate",
                              reason=why), None


def _limits(problem, controller, cert, certified):
    """:func:`design_limits` (unguarded)."""
    bound = verdict = None
    if not certified:
        verdict = feasibility_verdict(problem, cert, controller)
        if verdict.status == "infeasible":
            p = verdict.proofs[0]
            bound = ObjectiveBound(
                objective=problem.solver.objective, status="infeasible", model=p.model,
                temperature_C=p.temperature_C, loop=p.loop, specs=verdict.expressed,
                left_out=verdict.not_expressed,
                reason="no linear controller meets the specs (the proof above)")
            return bound, verdict
        verdict, probe = _with_evidence(problem, cert, verdict)
        if problem.solver.objective == "feasibility" and probe is not None:
            return probe, verdict
    if certified and problem.solver.objective == "feasibility":
        return None, verdict       # the certified design answers the question itself
    if problem.solver.bound or not certified:
        value = design_value(problem, controller, cert) if certified else None
        bound = objective_bound(problem, controller, certified=certified, design_value=value)
    return bound, verdict


def _with_evidence(problem, cert, verdict):
    """A "not found" whose violations are all peaks the discs express or a pole region:
    the Youla feasibility programs per model and loop (with the region's interpolation
    conditions; evidence, not a proof) in its suggestion; ``(verdict, their
    ObjectiveBound or None)``."""
    from dataclasses import replace

    region = any(v.kind == "below" and v.quantity in _REGION for v in cert.violations)
    if any(not (v.kind == "exceeds" and v.quantity in _PEAKS + ("spectral_abscissa",))
           and not (v.kind == "below" and v.quantity in _REGION) for v in cert.violations):
        return verdict, None
    probe = replace(problem, solver=replace(problem.solver, objective="feasibility"))
    b = objective_bound(probe, region=problem.specs.pole_region(problem.family)
                        if region else None)
    what = ("the expressed specs with every closed-loop pole in the pole region (Q's poles"
            " inside it, the plant's modes outside it moved)" if region else
            "the expressed specs")
    if b.status == "feasible_on_grid":
        more = (f"on every model alone some linear controller meets {what} on the grid (Youla"
                f" programs, {len(b.per_loop)} loops; evidence, not a proof): a higher order"
                " or another start may reach them")
    elif b.status == "infeasible_on_grid":
        more = (f"no Q of the programs' basis meets {what} on the grid of model {b.model}"
                f" ({b.loop} loop) even alone (evidence, not a proof): loosen them")
    else:
        return verdict, b
    return replace(verdict, suggestion=(verdict.suggestion + "; " if verdict.suggestion
                                        else "") + more), b


_REGION = ("closed-loop damping", "closed-loop decay rate [rad/s]")
_PEAKS = ("|S| peak", "|T| peak", "|U| peak", "|T| in resonance band", "|U| above corner",
          "|B S/Delta| peak")
