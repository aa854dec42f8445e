"""The design for a fleet: the scenario loop over actuators of a problem with a ``[spread]``.

:func:`fleet_design` is :func:`robrst.design.run_problem` of such a problem:
:func:`scenario_design` runs the constraint exchange over drawn actuators (or the box's
corners) described in :mod:`robrst.synthesis.scenario` (the scenario bounds, the
actuator checks and the :class:`~robrst.synthesis.scenario.FleetDesign` record live
there), every round one design of :func:`robrst.design._single.design_single`; then the
comparison and the analyses of the final controller.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.design.candidate import comparison
from robrst.design.result import DesignResult
from robrst.design._single import analyse, design_single
from robrst.synthesis.scenario import (ADD_PER_ROUND, MAX_ROUNDS, FleetDesign, check_actuators,
                                       convex_scenario_count, gain_edges, scenario_count)

if TYPE_CHECKING:
    from robrst.core.family import PlantFamily
    from robrst.problem.records import Problem

__all__ = ["fleet_design", "scenario_design"]


def fleet_design(problem: Problem, progress: Callable[[str], None] | None = None,
                 templates: dict | None = None, analyses: bool = True,
                 multistart: bool = False) -> DesignResult:
    """The design of a problem with a ``[spread]`` (its BLAS limited by the caller).

    Parameters
    ----------
    problem : Problem
        With ``spread``.
    progress : callable, optional
        Called with one line of text per round (and, indented, per stage of a round).
    templates : dict, optional
        Built NLP solvers by structure.
    analyses : bool
        Analyse every family model and assess the design.
    multistart : bool
        Every round runs the global phase (:func:`scenario_design`).

    Returns
    -------
    DesignResult
        The last round's design with its ``fleet`` record (``problem.scenarios``: the
        actuators the program held on).
    """
    result, fleet = scenario_design(problem, progress, templates, multistart=multistart)
    comp = comparison(result.problem, result.controller, result.certificate)
    found, assessment = analyse(result.problem, result.controller) if analyses else ((), None)
    return replace(result, analyses=found, comparison=comp, fleet=fleet,
                   assessment=assessment)


def scenario_design(problem: Problem, progress: Callable[[str], None] | None = None,
                    templates: dict | None = None,
                    families: Sequence[PlantFamily] | None = None,
                    values: np.ndarray | None = None,
                    n_scenarios: int | None = None,
                    multistart: bool = False) -> tuple[DesignResult, FleetDesign]:
    """Design ``problem`` for its spread (:mod:`robrst.synthesis.scenario`): an exchange over
    actuators, every round one design (:func:`robrst.design._single.design_single`) of a
    problem whose ``scenarios`` are the actuators handed to the program, warm-started from
    the previous round's synthesis record, without comparison.

    Parameters
    ----------
    problem : Problem
        With ``spread`` (its method, yield target, confidence and seed).
    progress : callable, optional
        Called with one line of text per round.
    templates : dict, optional
        Built NLP solvers by structure, shared by the rounds.
    families, values : optional
        The actuators (and their parameter rows) to design for, instead of the spread's
        draws (tests; the box method's corners).
    n_scenarios : int, optional
        Drawn actuators (default: ``spread.scenarios``, else :func:`scenario_count`).
    multistart : bool
        Every round runs the global phase (:mod:`robrst.synthesis.search`) over the
        family and the actuators it holds, the round before's controller among its seeds
        (a deterministic function of those actuators, as the compression argument needs).
        Without it each round is a local run from the round before, and the exchange can
        end far below what the actuators allow (a 900 Hz stage: 4,850 against 1.35 M).

    Returns
    -------
    (DesignResult, FleetDesign)
        The last round's design (its certificate covers the nominal actuator and the
        actuators handed to the program) and the fleet record.
    """
    from robrst.synthesis.analytic import pole_placement
    from robrst.synthesis.context import Context

    say = progress or (lambda m: None)
    templates = {} if templates is None else templates

    def design(p, warm):
        return design_single(p, lambda msg: say("  " + msg), templates, False, multistart,
                             warm, compare=False)

    t0 = time.perf_counter()
    spread = problem.spread
    beta = 1.0 - spread.confidence
    eps = 1.0 - spread.yield_target
    start = pole_placement(problem.family.reference_model, problem.poles, problem.controller)
    ctx = Context.of(problem, start)
    d = ctx.param.n_x + (2 if problem.solver.free_poles else 0)
    n_convex = convex_scenario_count(eps, beta, d)
    if families is None:
        if spread.method == "box":
            values = spread.corners()
        else:
            n = n_scenarios or spread.scenarios or scenario_count(eps, beta, d)
            values = spread.draws(n)
        families = spread.actuators(problem.family, values)
    N = len(families)
    say(f"fleet design ({spread.method}): {N} actuators, {d} decision variables"
        + (f", yield {spread.yield_target:g} at confidence {spread.confidence:g}"
           if spread.method == "scenario" else ""))
    base = replace(problem, scenarios=())
    support, discarded, added = [], [], []
    warm, result, nominal_ki, checks, last = None, None, None, [], None
    spent = {"design": 0.0, "check": 0.0}

    def timed(kind, f, *args, **kw):
        t = time.perf_counter()
        try:
            return f(*args, **kw)
        finally:
            spent[kind] += time.perf_counter() - t

    for rnd in range(1, MAX_ROUNDS + 1):
        p = replace(base, scenarios=tuple(families[i] for i in support))
        out = timed("design", design, p, warm)
        if nominal_ki is None:
            nominal_ki = out.integral_gain
        if not out.certified and last is not None:
            # the program cannot meet the actuators just added together with the others:
            # the most violated of them is discarded (it counts in the guarantee), the
            # previous controller stands, and the others are tried without it
            worst = added[0]
            discarded.append(worst)
            support.remove(worst)
            added = added[1:]
            say(f"round {rnd}: design {out.status} with {len(support) + 1} actuators in the"
                f" program: actuator {worst} discarded")
            if added:
                continue
            result, checks = last
        else:
            result = out
            warm = out.synthesis
            checks = timed("check", check_actuators, problem, result.controller, families,
                           full=False)
            stage = "members"
            if all(c.certified for c in checks):
                checks = timed("check", check_actuators, problem, result.controller, families,
                               full=True)
                stage = "certificate"
            last = (result, checks)
            say(f"round {rnd}: {len(support)} actuators in the program, integral gain"
                f" {result.integral_gain:.5g}, design {result.status};"
                f" {sum(not c.certified for c in checks)} of {N} violated ({stage})")
        bad = sorted((c for c in checks if not c.certified and c.index not in support
                      and c.index not in discarded), key=lambda c: (-c.ratio, c.index))
        if not bad:
            break
        say(f"  worst: actuator {bad[0].index}: {bad[0].violation}")
        added = [c.index for c in bad[:ADD_PER_ROUND]]
        support += added
    edges = None
    if spread.method == "box":
        edges = gain_edges(problem, result.controller, spread.names, values,
                           families)
        if edges is not None:
            say(f"box: stability along {edges['edges']} gain edges"
                f" {'proved' if edges['proved'] else 'NOT proved'}"
                f" ({edges['segments']} segments, {len(edges['crossings'])} crossings)")
    fleet = FleetDesign(method=spread.method, edges=edges, names=spread.names, values=np.asarray(values),
                        n_scenarios=N, decision_variables=d, yield_target=spread.yield_target,
                        confidence=spread.confidence, support=tuple(support),
                        discarded=tuple(discarded),
                        checks=tuple(checks), rounds=rnd, nominal_integral_gain=nominal_ki,
                        integral_gain=result.integral_gain,
                        wall_time_s=time.perf_counter() - t0, seed=spread.seed,
                        design_time_s=spent["design"], check_time_s=spent["check"],
                        n_convex=n_convex if spread.method == "scenario" else None)
    return result, fleet
