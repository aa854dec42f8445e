"""The multi-start of the robust program: the problem as asked, then diverse starts in
parallel; the best certified objective wins.

The starts are planned by :mod:`robrst.synthesis.multistart` (analytic designs at other
poles, free placement, PI and roll-off controllers, more degrees); :func:`multistart` runs
each as a :func:`robrst.design.candidate.candidate` on ``MULTISTART_WORKERS`` forked
processes and keeps the best (:func:`robrst.synthesis.objective.objective`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

from robrst.base.interrupt import stop_pool, worker_signals
from robrst.base.threads import one_blas_thread
from robrst.design.candidate import candidate, offer_candidate
from robrst.synthesis.objective import objective
from robrst.synthesis.parametrize import integral_gain

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.problem.records import Problem
    from robrst.synthesis.analytic import AnalyticDesign
    from robrst.synthesis.multistart import StartPlan

__all__ = ["multistart", "run_start", "worst_ratio", "MULTISTART_WORKERS", "MIN_START_BUDGET"]


def worst_ratio(cert: Certificate) -> float:
    """The worst ``value / bound`` of a certificate's violations (0 when none).

    Parameters
    ----------
    cert : Certificate
        A certificate.

    Returns
    -------
    float
    """
    r = [v.ratio for v in cert.violations]
    return max(r) if r else 0.0


def run_start(plan: StartPlan, original: Problem, budget: int | None = None) -> tuple:
    """A multi-start run (in a worker process): its candidate, or the error.

    Parameters
    ----------
    plan : StartPlan
        The start (its problem, and whether its answer is certified on ``original``).
    original : Problem
        The problem the answer must hold on.
    budget : int, optional
        IPOPT iterations the start may spend (and every IPOPT call within it).

    Returns
    -------
    (tuple or None, str or None, float)
        The :func:`~robrst.design.candidate.candidate`, or ``None`` and the error; the
        wall time [s].
    """
    import time

    t0 = time.perf_counter()
    problem = plan.problem
    if budget is not None:    # every IPOPT call within the budget too
        problem = replace(problem, solver=replace(problem.solver, max_iter=min(
            problem.solver.max_iter, int(budget))))
    try:
        with one_blas_thread(problem.needs_scipy):
            return candidate(problem, original, plan.recheck, budget=budget), None, \
                time.perf_counter() - t0
    except Exception as exc:      # noqa: BLE001 — a failed start is an outcome, not a crash
        return None, f"{type(exc).__name__}: {exc}", time.perf_counter() - t0


MULTISTART_WORKERS = 2
MIN_START_BUDGET = 100     # IPOPT iterations an extra start may spend at least


def multistart(problem: Problem, plans: Sequence[StartPlan], start: AnalyticDesign,
               say: Callable[[str], None], templates: dict | None) -> tuple:
    """The design as asked, then the ``plans`` on ``MULTISTART_WORKERS`` processes, each
    with the first run's IPOPT iterations as its budget (at least ``MIN_START_BUDGET``);
    the best certified objective wins (else the smallest worst violation).

    Parameters
    ----------
    problem : Problem
        The problem.
    plans : sequence of StartPlan
        The other starts (:func:`robrst.synthesis.multistart.plans`).
    start : AnalyticDesign
        The problem's analytic design (the first run's start).
    say : callable
        Progress lines.
    templates : dict or None
        Built NLP solvers by structure, for the first run.

    Returns
    -------
    ((SynthesisResult, RSTController, Tracking or None, Certificate), MultiStart)
        The winning candidate and the record of every start.
    """
    import time
    from concurrent.futures import ProcessPoolExecutor
    import multiprocessing

    from robrst.synthesis.multistart import MultiStart, StartOutcome, StartPlan

    t0 = time.perf_counter()
    say(f"multi-start: the problem as asked and {len(plans)} other starts on"
        f" {MULTISTART_WORKERS} processes")
    runs = [StartPlan("as asked", problem)] + list(plans)
    results = [None] * len(runs)
    t1 = time.perf_counter()
    results[0] = (candidate(problem, problem, False, start, say, templates), None,
                  time.perf_counter() - t1)
    offer_candidate(problem, results[0][0][1], results[0][0][3])
    first = results[0][0][0]
    budget = max(MIN_START_BUDGET, sum(r.iterations for r in getattr(first, "rounds", ())))
    try:
        ctx = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(MULTISTART_WORKERS, mp_context=ctx,
                                 initializer=worker_signals) as pool:
            try:
                futs = [pool.submit(run_start, p, problem, budget) for p in runs[1:]]
                for k, f in enumerate(futs, 1):
                    results[k] = f.result()
                    if results[k][0] is not None:
                        offer_candidate(problem, results[k][0][1], results[k][0][3])
            except KeyboardInterrupt:      # a signal: the workers stop now, not at their end
                stop_pool(pool)
                raise
    except (OSError, ValueError, ImportError) as exc:   # no processes here: one at a time
        say(f"multi-start: no worker processes ({exc}); running the starts in turn")
        for k, p in enumerate(runs):
            if results[k] is None:
                results[k] = run_start(p, problem, budget)
    outcomes, best, best_key = [], None, None
    for k, (p, (cand, err, wall)) in enumerate(zip(runs, results)):
        if cand is None:
            outcomes.append(StartOutcome(p.name, "failed", wall_time_s=wall, note=err))
            continue
        stage, ctrl, trk, cert = cand
        obj = objective(problem, ctrl, cert)
        outcomes.append(StartOutcome(
            p.name, "certified" if cert.certified else "not_certified", objective=obj,
            integral_gain=integral_gain(ctrl), worst_ratio=worst_ratio(cert),
            placement=getattr(stage, "placement", None), wall_time_s=wall))
        key = (1, obj, -k) if obj is not None else (0, -worst_ratio(cert), -k)
        if best_key is None or key > best_key:
            best, best_key = (k, cand), key
        say(f"multi-start: {p.name}: {outcomes[-1].status}"
            + (f", objective {obj:.6g}" if obj is not None else ""))
    k, cand = best
    ms = MultiStart(outcomes=tuple(outcomes), winner=runs[k].name,
                    objective=problem.solver.objective, workers=MULTISTART_WORKERS,
                    wall_time_s=time.perf_counter() - t0)
    return cand, ms
