"""A scan of one bound: designs whose certified objective never gets worse as the bound loosens.

Each design of a scan is a local optimum of a non-convex program: designed one by one, a
looser bound may end at a worse optimum than a tighter one, and a tighter bound may miss a
design of a looser one that meets it too.  :func:`bound_scan` designs the values from the
tightest to the loosest and hands every answer to the next one (the tighter problem's
answer meets the looser bound: the robust program's incumbent, a start of its design, and
a candidate certified on the looser problem), then
walks back from the loosest and keeps, for every tighter bound, the best answer of a
looser one that it certifies there.  So:

* the certified objective never decreases as the bound loosens;
* no design of a looser bound certifies on a tighter one with a better objective.

Every answer kept is certified on its own problem (:func:`robrst.design.run_problem`'s
certificate, or :func:`robrst.certificate.proof.certify_problem` with the time-domain
figures for a handed-over controller).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING


from robrst.certificate.proof import certify_problem
from robrst.certificate.completion import with_time_domain
from robrst.design import DesignResult, run_problem
from robrst.synthesis.objective import objective

if TYPE_CHECKING:
    from robrst.problem.records import Problem

__all__ = ["ScanPoint", "bound_scan"]


@dataclass(frozen=True, eq=False)
class ScanPoint:
    """One value of a scan.

    Parameters
    ----------
    value : float
        The bound.
    result : DesignResult
        The design kept (its certificate on this bound).
    objective : float or None
        Its certified objective (``None`` when not certified).
    source : str
        Where the kept controller came from: ``"designed"``, or the scan value whose
        answer it is.
    """

    value: float
    result: DesignResult
    objective: float
    source: str


def _on(problem, result):
    """``result``'s controller certified on ``problem`` (a :class:`DesignResult`)."""
    ctrl = result.controller
    cert = certify_problem(problem, ctrl)
    if problem.specs.time_domain and result.tracking is None:
        cert = with_time_domain(problem, cert, ctrl)
    return replace(result, problem=problem, certificate=cert, analyses=(), comparison=None,
                   assessment=None, starts=None)


def bound_scan(problem: Problem, key: str, values: Sequence[float],
               progress: Callable[[str], None] | None = None,
               multistart: bool = False) -> list[ScanPoint]:
    """Designs of ``problem`` with ``specs.<key>`` at each of ``values`` (module docstring).

    Parameters
    ----------
    problem : Problem
    key : str
        An upper bound of :class:`~robrst.problem.records.Specs` (``"Ms_max"``, ...).
    values : sequence of float
        The bounds; designed from the tightest (smallest) to the loosest.
    progress : callable, optional
    multistart : bool
        Multi-start each design (default off: the scan is its own search).

    Returns
    -------
    list of ScanPoint
        In increasing bound.
    """
    say = progress or (lambda m: None)
    vals = sorted(float(v) for v in values)
    probs = [replace(problem, specs=replace(problem.specs, **{key: v})) for v in vals]
    points = []
    for i, (v, p) in enumerate(zip(vals, probs)):      # tight -> loose
        given = (points[-1].result if points and points[-1].objective is not None
                 and p.solver.method == "nlp" and p.spread is None else None)
        res = run_problem(p, analyses=False, multistart=multistart, incumbent=given)
        best = ScanPoint(v, res, objective(p, res.controller, res.certificate), "designed")
        if points and points[-1].objective is not None:
            prev = _on(p, points[-1].result)
            obj = objective(p, prev.controller, prev.certificate)
            if obj is not None and (best.objective is None or obj > best.objective):
                best = ScanPoint(v, prev, obj, f"{key} = {points[-1].value:g}")
        say(f"scan {key} = {v:g}: objective {best.objective} ({best.source})")
        points.append(best)
    for i in range(len(points) - 2, -1, -1):           # loose -> tight
        for j in range(len(points) - 1, i, -1):
            if points[j].objective is None or (points[i].objective is not None
                                               and points[j].objective <= points[i].objective):
                continue
            cand = _on(probs[i], points[j].result)
            obj = objective(probs[i], cand.controller, cand.certificate)
            if obj is not None and (points[i].objective is None or obj > points[i].objective):
                points[i] = ScanPoint(vals[i], cand, obj, points[j].source if
                                      points[j].source != "designed" else
                                      f"{key} = {vals[j]:g}")
    return points
