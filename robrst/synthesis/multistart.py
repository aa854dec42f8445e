"""Multi-start of the robust program: diverse starts, the best certified answer, the spread.

The robust program is non-convex: one start ends at one local optimum, and a slightly
different problem may end at a much better one.  :func:`plans` lists the other runs a
design tries besides the one the problem asks for, most useful first:

* **free placement** (every controller coefficient free, from the analytic design and the
  integral/PI roll-off starts of :mod:`robrst.synthesis.starts`) when the problem asks for
  placed poles first;
* **neighbouring problems**: every peak bound tightened and loosened by
  ``NEIGHBOUR_STEP``; the answer of the tighter one meets this problem's bounds, the
  looser one's may (both are certified on *this* problem before they count), so loosening
  a spec does not end at a worse certified objective than a tighter one found;
* **other poles**: the analytic design and the fixed-pole program at ``wn`` halved and
  doubled, and at another damping;
* **degree homotopy**: every ``extra_degree`` from 0 up, each seeded with the one below.

Every run is a full robust synthesis (:func:`robrst.synthesis.robust.robust_synthesis`);
:mod:`robrst.design` runs them in parallel (2 processes) and keeps the best certified
objective.  :class:`MultiStart` reports every start, its outcome and the spread of the
optima (how global the answer is).

By default a design no longer runs these plans: its global phase
(:mod:`robrst.synthesis.search`, run by :func:`robrst.synthesis.robust.robust_synthesis`)
searches every controller of the structure in the design's own process, certifies its best
distinct candidates as they are and polishes them by the program, and solves the problem's
own pole placement too; :func:`multistart_record` reports each of them as a start
(``design --json`` key ``starts``) with the global search itself
(``starts.global_search``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.problem.specs import SPEC_TABLE, SPECS_BY_KEY

if TYPE_CHECKING:
    from robrst.problem.records import Problem
    from robrst.synthesis.outcome import SynthesisResult
    from robrst.synthesis.search import GlobalSearch

__all__ = ["StartPlan", "StartOutcome", "MultiStart", "plans", "multistart_record",
           "NEIGHBOUR_STEP", "PEAK_BOUNDS"]

NEIGHBOUR_STEP = 0.03
PEAK_BOUNDS = tuple(s.key for s in SPEC_TABLE if s.scaled)   # robrst.problem.specs


@dataclass(frozen=True, eq=False)
class StartPlan:
    """One run of a multi-start.

    Parameters
    ----------
    name : str
        What the start is.
    problem : Problem
        The problem it solves.
    recheck : bool
        Its answer must be certified on the original problem (a neighbouring problem's).
    """

    name: str
    problem: Problem
    recheck: bool = False


@dataclass(frozen=True)
class StartOutcome:
    """What one start ended with, judged on the original problem.

    Parameters
    ----------
    name : str
        The start.
    status : {"certified", "not_certified", "failed"}
        ``"failed"``: an error, named in ``note``.
    objective : float, optional
        The certified objective, larger is better (``min_Ms``: minus the worst Ms;
        ``None`` when not certified, or for an integral gain bought with a controller
        pole outside the program's strip, said in ``note``).
    integral_gain : float, optional
        Its controller's integral gain [V/(µm s)].
    worst_ratio : float, optional
        Its worst violation ratio (0 when certified).
    placement : str, optional
        The nominal pole placement it ended with.
    wall_time_s : float, optional
        Its wall time [s].
    note : str, optional
        Why it failed, or why a certified start has no objective.
    """

    name: str
    status: str
    objective: float = None
    integral_gain: float = None
    worst_ratio: float = None
    placement: str = None
    wall_time_s: float = None
    note: str = None

    def as_dict(self) -> dict:
        """The JSON form.

        Returns
        -------
        dict
        """
        return dict(self.__dict__)


@dataclass(frozen=True)
class MultiStart:
    """Every start of a design and which won (``design --json`` key ``starts``).

    Parameters
    ----------
    outcomes : tuple of StartOutcome
        The problem as asked first, then the other starts.
    winner : str
        The start whose answer is returned.
    objective : str
        The objective compared.
    workers : int
        Processes used (1: everything runs in the design's process).
    wall_time_s : float
        Wall time of the multi-start [s].
    search : GlobalSearch, optional
        The global phase (:class:`~robrst.synthesis.search.GlobalSearch`).
    """

    outcomes: tuple
    winner: str
    objective: str
    workers: int
    wall_time_s: float
    search: GlobalSearch | None = None

    def spread(self) -> dict:
        """The certified optima: best, median and worst, and ``(best - worst) / |best|``.

        Returns
        -------
        dict
        """
        vals = [o.objective for o in self.outcomes if o.objective is not None]
        if not vals:
            return {"certified": 0}
        best, worst = max(vals), min(vals)
        return {"certified": len(vals), "best": best, "median": float(np.median(vals)),
                "worst": worst,
                "relative_spread": (best - worst) / abs(best) if best else 0.0}

    def as_dict(self) -> dict:
        """The JSON form.

        Returns
        -------
        dict
        """
        out = {"winner": self.winner, "objective": self.objective, "workers": self.workers,
               "wall_time_s": self.wall_time_s, "spread": self.spread(),
               "starts": [o.as_dict() for o in self.outcomes]}
        if self.search is not None:
            out["global_search"] = self.search.as_dict()
        return out


def _scaled_bounds(specs, factor):
    """``specs`` with every peak bound times ``factor`` (each at least its row's ``floor``:
    ``Ms_max`` at least 1)."""
    changes = {}
    for k in PEAK_BOUNDS:
        v, floor = getattr(specs, k), SPECS_BY_KEY[k].floor
        if v is not None:
            changes[k] = v * factor if floor is None else max(floor, v * factor)
    return replace(specs, **changes) if changes else None


def plans(problem: Problem, count: int) -> list[StartPlan]:
    """The other runs of a multi-start of ``problem``, most useful first (module
    docstring).

    Parameters
    ----------
    problem : Problem
        The problem as asked.
    count : int
        At most this many.

    Returns
    -------
    list of StartPlan
    """
    so, sp, po = problem.solver, problem.specs, problem.poles
    poles = []
    if po.dominant_roots is None and po.wn is not None:
        lo, hi = so.wn_bounds or (0.0, np.inf)
        for f, z in ((2.0, po.zeta), (0.5, po.zeta), (1.0, 0.7 if po.zeta != 0.7 else 1.0)):
            wn = min(max(po.wn * f, lo), hi)
            if (wn, z) != (po.wn, po.zeta):
                poles.append(StartPlan(f"poles wn = {wn:.4g} rad/s, zeta = {z:g}",
                                       replace(problem, poles=replace(po, wn=wn, zeta=z))))
    neighbours = []
    for name, f in (("looser bounds (neighbour)", 1 + NEIGHBOUR_STEP),
                    ("tighter bounds (neighbour)", 1 - NEIGHBOUR_STEP)):
        s2 = _scaled_bounds(sp, f)
        if s2 is not None:
            neighbours.append(StartPlan(name, replace(problem, specs=s2), recheck=True))
    free = ([StartPlan("free placement", replace(problem, solver=replace(so, placement="free")))]
            if so.placement != "free" else [])
    homotopy = ([StartPlan("degree homotopy", replace(problem, solver=replace(
        so, homotopy="always")))] if problem.controller.extra_degree > 0
        and so.homotopy != "always" else [])
    out = poles[:1] + neighbours[1:] + poles[2:] + neighbours[:1] + free + poles[1:2] + homotopy
    return out[:max(0, int(count))]


def multistart_record(stage: SynthesisResult, wall_time_s: float) -> MultiStart:
    """The :class:`MultiStart` of a synthesis with the global phase.

    Parameters
    ----------
    stage : SynthesisResult
        The synthesis (its ``tried`` and ``search``).
    wall_time_s : float
        Wall time of the synthesis [s].

    Returns
    -------
    MultiStart
        The winner is the certified outcome with the best objective (else the one with the
        smallest worst violation).
    """
    outs = tuple(StartOutcome(name, status, objective=obj, integral_gain=ki,
                              worst_ratio=ratio, placement=placement, note=note)
                 for name, status, obj, ki, ratio, placement, note in stage.tried)
    winner = None
    if outs:
        ok = [o for o in outs if o.objective is not None]
        win = (max(ok, key=lambda o: o.objective) if ok
               else min(outs, key=lambda o: (o.worst_ratio is None,    # None: unstable
                                             o.worst_ratio or 0.0)))
        winner = win.name
    return MultiStart(outcomes=outs, winner=winner, objective=stage.objective, workers=1,
                      wall_time_s=wall_time_s, search=stage.search)
