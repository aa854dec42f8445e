"""Robust synthesis driver: the objective under hard specs, soft goals when that fails.

:func:`robust_synthesis` always returns a controller (:mod:`robrst.synthesis.attempts`
runs one placement):

1. **Starts** (:mod:`robrst.synthesis.starts`): the analytic pole placement (and, when
   the nominal poles may move, other ``(wn, zeta)``), points handed down (a previous
   attempt, the lower degree, a previous variant), integral and PI controllers when
   every coefficient is free; each rated on the grid before anything is solved.
2. **Hard phase**: from the preferred start (the boldest one meeting the specs on the
   grid, else a seed, else the analytic design) the objective with the specs as
   constraints; every result is certified exactly (:mod:`robrst.certificate.proof`), offending
   frequencies and temperatures join the program and it is solved again.
3. **Soft phase** (systune's soft goals): when that fails, minimise ``gamma``, the worst
   normalised spec ratio ``|N|/(M |Delta|)`` over every model, grid point and spec, from
   the best starts; from a point that meets the specs, the hard phase again.
4. **Placement**: with ``solver.placement = "auto"`` the nominal closed-loop poles are
   those of the [poles] table (or ``(wn, zeta)`` within bounds with ``free_poles``);
   when that cannot meet the specs, or meets them only at a start or soft-goal point
   whose objective could not be optimised, every controller coefficient is freed
   (trust-region solves) and 1–3 run again, seeded with the best point found; the better
   certified objective is returned.
5. **Homotopy**: when a degree does not certify (or its objective could not be
   optimised), ``extra_degree - 1`` is solved first and its controller, raised by a
   common factor (the same controller), seeds the program; ``homotopy = "always"``
   solves every degree from 0 up, so more degrees never give a worse objective.

When the specs cannot be met, the result is the best controller found (smallest worst
violation ratio, certified for what it achieves), status ``"not_certified"`` with a
``best_achievable`` summary and the binding constraints from the soft phase's IPOPT
multipliers.  A raw solver status is never the only answer.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.base.errors import RobrstError
from robrst.synthesis.attempts import (INCUMBENT, WARM_START, Outcome, Run, objective_value,
                                       program_models, merged_notes, refine)
from robrst.synthesis.context import BOUND_MARGIN, Context, strip_note
from robrst.synthesis._nlp import objective_rows
from robrst.synthesis.outcome import SynthesisResult, best_achievable, worst_violation
from robrst.synthesis.parametrize import integral_gain
from robrst.synthesis._screen import Screen
from robrst.synthesis.search import EDGE_ROOTS, SEARCH, PoleSpace, global_search, move_inside
from robrst.synthesis.starts import integral_seeds
from robrst.synthesis._timesamples import TIME_MARGIN, TimeSpecs, time_specs
from robrst.synthesis.tracking import (CANCEL_FLOOR, meets_time_specs, time_spec_ratio,
                                      with_steps)

if TYPE_CHECKING:
    from robrst.problem.records import Problem
    from robrst.core.rst import RSTController
    from robrst.synthesis.analytic import AnalyticDesign

__all__ = ["robust_synthesis", "incumbent_fits", "a_priori_note", "BOUND_MARGIN", "worst_violation",
           "best_achievable", "PolishOptions", "POLISH"]

NEAR_MISS = 1.5   # on failure, lower degrees are tried when the specs are missed by <= 50 %


def a_priori_note(problem: Problem) -> str | None:
    """Specs no controller with an integrator can meet (``|T(0)| = 1``, ``|U(0)| = 1/|D(0)|``).

    Parameters
    ----------
    problem : Problem
        The problem.

    Returns
    -------
    str or None
        The reason as text, or ``None``.
    """
    sp = problem.specs
    for m in problem.family.models:
        checks = (("T", sp.Mt_max, 1.0), ("U", sp.Mu_max, abs(1.0 / m.dc_gain)))
        for name, bound, at_zero in checks:
            if bound is not None and at_zero > bound:
                return (f"specs infeasible: |{name}(0)| = {at_zero:.4g} > {bound:.4g} for model"
                        f" {m.label} ({m.temperature_C:g} °C) with any controller that has an"
                        " integrator")
    return None


def _embedded(ctx, lower):
    """The lower-degree outcome raised to this context's degree (same controller)."""
    p = ctx.problem
    dom = np.abs(p.poles.dominant())
    root = -p.poles.aux_factor * float(np.max(dom))
    xc = ctx.param.embed(lower.ctrl, root)
    if xc is None:
        return None
    setup = ctx.setup(list(p.family.models), ctx.nu, lower.placement)
    wz = ()
    if lower.placement == "dominant":   # (wn, zeta), wn rescaled to this context's w0
        k = lower.setup.n_x
        wz = (lower.x[k] * lower.setup.w0 / ctx.w0, lower.x[k + 1])
    x = ctx.full(xc, setup, *wz)
    return Outcome(ctrl=ctx.controller(x), cert=lower.cert, res=lower.res, phase=lower.phase,
                    placement=lower.placement, x=x, setup=setup)


_ORDER = {"fixed": 0, "dominant": 1, "free": 2}


def _synthesize(problem, start, run, extra, lower=None):
    """Every placement the problem allows, seeded with the embedded ``lower`` outcome.

    With the global phase (``run.global_phase``, the requested degree) the freely placed
    poles are searched by :func:`_global`, and with ``placement = "auto"`` both the
    problem's own placement and the global phase always run: the better certified
    objective is the answer, whatever the bounds (a bound-independent search space)."""
    ctx = Context.of(problem, start, extra)
    so = problem.solver
    default = ctx.default_placement()
    placements = {"fixed": [default], "free": ["free"], "auto": [default, "free"]}[so.placement]
    emb = _embedded(ctx, lower) if lower is not None and lower.certified else None
    best, seeds = None, []
    warm = _warm_seed(ctx, run.warm) if extra == problem.controller.extra_degree else None
    glob = run.global_phase and extra == problem.controller.extra_degree
    for placement in placements:
        if best is not None and run.strict and run.spent():
            break          # an extra start of a multi-start: its budget is spent
        seeded = seeds + ([("lower-degree optimum", emb.x[:ctx.param.n_x])]
                          if emb is not None and _ORDER[emb.placement] <= _ORDER[placement]
                          else [])
        if warm is not None and _ORDER[warm[0]] <= _ORDER[placement]:
            seeded = [warm[1]] + seeded
        given = _incumbent_x(ctx, run.incumbent) if placement == "free" and not glob else None
        if given is not None:
            seeded = [(INCUMBENT, given)] + seeded
        if glob and placement == "free":
            out = _global(ctx, run, seeded, best, start)
        else:
            # with the global phase to follow, the problem's own placement gets no soft phase
            out = run.attempt(ctx, placement, seeded,
                              soft=not (glob and "free" in placements))
            if given is not None:
                out = _kept(ctx, run, given, out)
            if glob and out is not None:
                run.tried.append((f"the problem's poles ({placement})", out))
        if out is None:
            continue
        if out.certified:
            if best is None or not best.certified or (
                    _rank(problem, out, glob) > _rank(problem, best, glob)):
                best = out
            searched = glob and "free" in placements      # a global phase follows
            # every certified controller answers a feasibility problem: no global phase
            # once one meets every spec (its time-domain ones included)
            answered = so.objective == "feasibility" and _rank(problem, out, glob)[0]
            # a warm start from a later placement (a fleet's round after the global phase)
            # is still to be polished in its own placement
            pending = (warm is not None and _ORDER[warm[0]] > _ORDER[placement]
                       and placement != placements[-1])
            if answered or ((out.phase == "hard" or so.objective == "feasibility")
                            and not searched and not pending):
                if answered and searched and placement != "free":
                    run.notes.append(f"feasibility: the problem's poles ({placement})"
                                     " certify; no global phase (nothing to optimise)")
                break          # optimised under the specs (or nothing to optimise)
            seeds = [("best point so far", best.x[:ctx.param.n_x])]
            if out.phase != "hard" and glob and placement == "free":
                name = next((n for n, o in run.tried if o is out), "a candidate")
                run.notes.append(f"global phase: its answer is {name} (certified as the"
                                 " global phase left it: no polish improved on it)")
            elif out.phase != "hard":
                run.notes.append(f"the objective could not be optimised with {placement}"
                                 " nominal poles (a certified start or soft-goal point)")
            continue
        if best is None or (not best.certified and out.badness < best.badness):
            best = out
        seeds = [("best point so far", best.x[:ctx.param.n_x])]
        run.notes.append(f"specs not met with {placement} nominal poles"
                         f" ({best_achievable(out.cert)})")
    if emb is not None and objective_value(problem, emb) > objective_value(problem, best):
        run.notes.append(f"extra_degree {extra}: the lower-degree controller is better; returned"
                         " with a common factor (the same controller)")
        return emb
    return best


def _meets_specs(problem, out):
    """The outcome ``out`` is certified and its reference step meets the time-domain specs."""
    return out.certified and meets_time_specs(problem, out.ctrl)


def _answers(problem, out):
    """The outcome ``out`` meets the specs (:func:`_meets_specs`) and its reference step is
    proved between the samples too (:func:`with_steps`): an answer."""
    return _meets_specs(problem, out) and with_steps(problem, out.ctrl, out.cert)[2].certified


def _counts(problem, out):
    """The outcome ``out`` meets the specs (:func:`_meets_specs`) and its objective counts:
    with ``max_integral_gain`` every controller pole but the integrators inside the
    program's strip (:func:`~robrst.synthesis.context.strip_note`)."""
    return _meets_specs(problem, out) and strip_note(problem, out.ctrl) is None


def _rank(problem, out, timed):
    """Sort key of a certified outcome: (meets the time-domain specs, when ``timed``;
    objective)."""
    ok = meets_time_specs(problem, out.ctrl) if timed else True
    return (ok, objective_value(problem, out))


@dataclass(frozen=True)
class PolishOptions:
    """The global phase's polish and its safeguards (:func:`_global`), each with why.

    Attributes
    ----------
    rescale : bool
        Each polish's program is scaled at its candidate (``Context.around``): the
        candidate's coefficients, not the analytic design's, set the scales.
    iterations : int
        IPOPT iterations of one polish, then its best certified point.
    screen_slack : float
        Candidates screened this close to the specs are certified too (the screen's grid
        is coarser than the certificate's).
    search_margin : float
        The search screens this far inside the peaks' bounds (the steps as the program).
    inside_margin : float
        A candidate the certificate refuses is moved this far inside the specs.
    backoff_near : float
        A polish missing the certificate by less than this ratio ...
    backoffs : int
        ... is solved again this many times, its violated bounds tightened by the miss ...
    backoff_iter : int
        ... within this many IPOPT iterations each.
    distinct : float
        A further candidate nearer than this (box units) to one polished is not polished ...
    share : float
        ... nor one screened below this share of the best screened objective.  Between
        those the screened objective does not decide: on the seeded stages a run's best
        screened at 0.79 of another's polished to 1.30 of it (455 k -> 818 k against
        578 k -> 627 k); no polish gained 2x.
    soft_seeds : int
        With no candidate inside the specs, the soft phase starts from this many of the
        best.
    walk_steps : int
        A polish that ends outside the specs is walked back towards its certified start
        by this many bisection steps (:func:`_walked_back`).
    floor_slack : float
        A polish keeps its start's integral gain but for this share (rounding).
    again : int
        The best answer of each of the best ``again_basins`` basins is polished again from
        where it ended (the program rescaled there, a fresh trust region and iteration
        budget), then the best answer's basin again from where that ended, up to this many
        polishes in all ...
    again_gain : float
        ... while each polish gains at least this share of the objective and ends inside
        the specs by itself (a point walked back into them answers but is never a
        chain's next start: where the polish before it stopped turns on rounding).  Each
        polish stops short (its iteration limit, its trust region, a grid it left), and
        a chain climbs on: measured with ``again = 4`` and the edge runs (the defaults
        since 2026-12-07, at twice the CPU), ``paper_robust`` 861,623 -> 879,000 on two
        OpenBLAS kernel sets (114-122 s CPU against 62 s), stage 102 at ``Ms_max`` 2.5
        324,038 -> 337,784 (2.25: 337,849).
    again_basins : int
        The basins (the outcomes of one candidate of the search) polished again, best
        first.  Which basin ends best after its first polish does not tell which ends best
        polished again: on the seeded 4th-order stage 722 at ``Ms_max`` 2.0 the best
        basin polished again reached 459 k, the third (204 k after its first polish) 788 k.
    """

    rescale: bool = True
    iterations: int = 500
    screen_slack: float = 0.02
    search_margin: float = 0.995
    inside_margin: float = 0.99
    backoff_near: float = 1.05
    backoffs: int = 2
    backoff_iter: int = 150
    distinct: float = 0.1
    share: float = 0.5
    soft_seeds: int = 3
    walk_steps: int = 6
    floor_slack: float = 1e-3
    again: int = 4
    again_gain: float = 0.01
    again_basins: int = 3


POLISH = PolishOptions()


def _global(ctx, run, seeds, best, start):
    """The global phase (:mod:`robrst.synthesis.search`) with every coefficient free
    (settings: :class:`PolishOptions`): the search (on a screen ``search_margin`` inside
    the peaks' bounds, the steps at the program's ``TIME_MARGIN ** 2``: its best candidates
    certify as they are and start the polish inside the program), then its best distinct
    candidates (those screened within ``screen_slack`` of the specs) certified as they are
    (one the certificate refuses, a peak or a step sample between the screen's points,
    moved inside the specs by :func:`~robrst.synthesis.search.move_inside`:
    ``inside_margin`` on the peaks, ``TIME_MARGIN ** 2`` on the steps, as the program's
    rows) and polished by the program (the best ``1 + solver.starts`` of them and each
    run's best: each within ``iterations`` IPOPT iterations, from the program rescaled at
    the candidate with the certificate's bounds, keeping its integral gain, backed off by
    its miss when it ends just outside the specs, walked back into them when it ends
    farther out, and polished again from the candidate moved inside the specs when it
    gained nothing; not one within ``distinct`` of one polished or screened below ``share``
    of the best: which basin polishes best, the screened objective does not tell); the best
    certified outcome whose reference step meets the time-domain specs on every model of
    its certificate, else the best certified one, else the least violating one. Falls back
    to :meth:`Run.attempt` when the space cannot be parametrised or nothing screened
    feasible."""
    p = ctx.problem
    ctx = replace(ctx, free_margin=BOUND_MARGIN)   # the certificate's bounds, not 2 % inside
    setup = ctx.setup(program_models(p), ctx.nu, "free")
    space = PoleSpace.of(ctx, setup)
    if space is None:
        run.notes.append("global phase skipped: the nominal closed loop's leading"
                         " coefficient depends on the controller")
        return run.attempt(ctx, "free", seeds)
    steps, two_dof = _screened_steps(p, ctx.w0)
    searched = replace(ctx, free_margin=POLISH.search_margin).setup(program_models(p), ctx.nu,
                                                                    "free")
    screen = Screen(searched, _inside(steps, TIME_MARGIN ** 2), two_dof)
    inside = []           # the screen inside the specs, built once needed
    named = [(sd[0], sd[1]) for sd in seeds if sd[1] is not None]
    try:
        named.append(("analytic", ctx.param.vector(start.controller)))
    except RobrstError:
        pass
    if best is not None:
        named.append((f"the problem's poles ({best.placement})", best.x[:ctx.param.n_x]))
    named += integral_seeds(ctx)     # the classical loops: a PI may sit on the optimum
    given = _incumbent_x(ctx, run.incumbent)
    if given is not None:      # the caller's controller: the first run may start from it
        named.insert(0, (INCUMBENT, given))
    options = replace(SEARCH, edge_roots=EDGE_ROOTS if p.solver.edge_runs else ())
    res = global_search(screen, space, named, options, stop=run.stop, say=run.say)
    run.search = res
    run.say(f"global phase: {res.evaluations} candidates in {res.generations} generations"
            f" ({res.cpu_s:.2g} s CPU), {len(res.candidates)} distinct")
    # within the search's own margins of the specs (a start that meets them exactly, the
    # problem's PI) the certificate decides too
    feasible = [c for c in res.candidates if c.violation <= POLISH.screen_slack]
    outs, polished, polishes = [], [], []
    bases = []            # the outcomes a polish started from
    if given is not None:      # certified as it is and polished first: never lost
        _from_incumbent(ctx, run, setup, given, outs, polishes, bases)
        theta = space.point(given)
        if theta is not None:  # the search's candidate at the same point: not polished again
            polished.append(theta)
    if not feasible and not any(o.certified for o in outs):
        run.notes.append("global phase: no candidate met the specs on the grid; the soft"
                         " phase from its best points")
        return run.attempt(ctx, "free", seeds + [(c.name, c.xc) for c in
                                                 res.candidates[:POLISH.soft_seeds]])
    n_top = 1 + max(0, p.solver.starts)
    # the best few, then each run's best, each screened within share of the best (an
    # objective that is a positive size)
    least = (POLISH.share * _screened_value(p, ctx, feasible[0])
             if feasible and p.solver.objective == "max_integral_gain" else -np.inf)
    chosen = [(i < n_top, c) for i, c in enumerate(feasible) if i == 0 or (
        (i < n_top or c.run) and _screened_value(p, ctx, c) >= least)]
    n_given = len(outs)
    for first, c in chosen:
        if run.spent("free") and len(outs) > n_given:
            break
        seen = bool(polished) and min(np.max(np.abs(c.theta - t)) for t in polished) \
            < POLISH.distinct
        if not first and seen:
            continue          # a run's best in a basin already polished
        x = ctx.full(c.xc, setup)
        as_is = run.outcome(ctx, setup, None, "start", x=x)
        run.tried.append((f"{c.name}, as screened", as_is))
        outs.append(as_is)
        base = as_is          # the polish starts from a point that meets the specs
        if not _meets_specs(p, as_is) and not run.stop():
            moved = _moved_inside(ctx, run, setup, space, inside, c, steps, two_dof, as_is)
            if moved is not None:
                run.tried.append((f"{c.name}, moved inside", moved))
                outs.append(moved)
                base = moved
        if p.solver.objective == "feasibility" and _answers(p, base):
            run.notes.append(f"feasibility: {c.name} certifies as the search found it"
                             + (" and moved inside the specs" if base is not as_is else "")
                             + "; not polished (nothing to optimise)")
            break             # every certified controller answers a feasibility problem
        if seen:
            continue          # a basin already polished
        polished.append(c.theta)
        bases.append(base)
        out, label, notes = _polished(ctx, run, base, c.name)
        gained = _gained(p, base, out)
        if not gained and base is as_is and as_is.certified and not run.stop():
            # a polish from the screen's boundary that gained nothing: again from inside
            # (not when the candidate is inside already: the move finds no better point,
            # and a polish from the same point would repeat the first)
            moved = _moved_inside(ctx, run, setup, space, inside, c, steps, two_dof, as_is)
            if moved is not None and not np.array_equal(moved.x, as_is.x):
                run.tried.append((f"{c.name}, moved inside", moved))
                outs.append(moved)
                if out is not None:
                    run.tried.append((f"{c.name}, {label}", out))
                    outs.append(out)
                bases.append(moved)
                out, label, notes = _polished(ctx, run, moved, c.name, "moved inside, polished")
                gained = _gained(p, base, out)
        polishes.append((c.name, gained, notes))
        lag = strip_note(p, out.ctrl) if out is not None and out.certified else None
        if lag:
            run.notes.append(f"global phase: the polish of {c.name} ended with {lag}")
        if out is not None:
            run.tried.append((f"{c.name}, {label}", out))
            outs.append(out)
    _polish_again(ctx, run, outs, bases)
    run.notes += _polish_notes(polishes)
    certified = sorted((o for o in outs if o.certified),
                       key=lambda o: -objective_value(p, o))
    for o in certified:        # the best whose reference step meets the time specs
        if _answers(p, o):
            return o
    if certified:
        run.notes.append("global phase: no certified candidate met the time-domain specs")
        return certified[0]
    return min(outs, key=lambda o: o.badness)


def _polished(ctx, run, base, name, how="polished", grid=None):
    """The polish of a candidate from its outcome ``base`` (as screened, or moved inside the
    specs): the program rescaled at it (``POLISH.rescale``), keeping its integral gain when
    it is certified (:func:`_floor`), backed off by its miss (:func:`_polish`), and walked
    back into the specs when it ends outside them (:func:`_rescued`), from each end of the
    polish near the specs (:func:`_backoff`), the best walk kept; ``grid``: the models
    and frequencies to start from besides the rescaled program's own (an earlier polish's
    :attr:`~robrst.synthesis.attempts.Outcome.grid`).  Returns the outcome (``None``:
    nothing solved, or the candidate's controller does not map to the rescaled program:
    noted, never the design's end), its label in ``tried`` (``how``, and how it ended) and
    the polish's notes."""
    p = ctx.problem
    near = ctx.around(base.ctrl) if POLISH.rescale else ctx     # scaled at the candidate
    polished_setup = near.setup(program_models(p), near.nu, "free")
    try:
        xr = near.full(near.param.vector(base.ctrl), polished_setup)
    except RobrstError as e:   # never the design's end: the other outcomes still answer
        run.notes.append(f"global phase: {name} not polished ({how}): its controller does"
                         f" not map to the program rescaled at it ({e})")
        return None, how, []
    floor = _floor(p, polished_setup, xr) if base.certified else None
    if grid is not None:
        grid = (grid[0], np.union1d(near.nu, grid[1]))
    ends, notes, poles = _polish(near, run, xr, name, floor, grid)
    out, label = (ends[0] if ends else None), how
    if base.certified and out is not None and not _counts(p, out):
        best, at = None, None
        for end in ends:         # walked back from each end near the specs: the best kept
            if run.stop():
                break
            walked = _rescued(near, run, polished_setup, xr, end, name, poles)
            above = base if best is None else best
            if walked is not None and objective_value(p, walked) > objective_value(p, above):
                best, at = walked, end
        if best is not None:
            run.tried.append((f"{name}, {label}", out))
            run.notes.append(_walk_note(p, name, at, best, base))
            out, label = best, f"{how}, walked back into the specs"
    return out, label, notes


def _incumbent_x(ctx, ctrl):
    """The coefficients of the caller's controller ``ctrl`` in this structure; ``None``
    without an incumbent, and at a lower degree of the homotopy (the caller checked that it
    fits the problem's own structure, :func:`incumbent_fits`)."""
    if ctrl is None:
        return None
    try:
        return ctx.param.vector(ctrl)
    except RobrstError:
        return None


def incumbent_fits(problem: Problem, start: AnalyticDesign, ctrl: RSTController) -> str | None:
    """Why the controller ``ctrl`` cannot be an incumbent of ``problem``'s robust synthesis
    (its structure: degrees, fixed parts), or ``None`` when it can.

    Parameters
    ----------
    problem : Problem
    start : AnalyticDesign
        The analytic design at the problem's poles.
    ctrl : RSTController

    Returns
    -------
    str or None
    """
    try:
        Context.of(problem, start).param.vector(ctrl)
    except RobrstError as exc:
        deg = lambda c: (len(np.trim_zeros(np.asarray(c.R, float), "f")) - 1,  # noqa: E731
                         len(np.trim_zeros(np.asarray(c.S, float), "f")) - 1)
        (rg, sg), (rw, sw) = deg(ctrl), deg(start.controller)
        return (f"{exc}: R of degree {rg} and S of degree {sg}, where this problem's"
                f" [controller] gives R of degree {rw} and S of degree {sw} with its fixed"
                " factors")
    return None


def _from_incumbent(ctx, run, setup, given, outs, polishes, bases):
    """The caller's controller (coefficients ``given``) certified as it is and, when it
    meets the specs, polished first (its objective kept, :func:`_polished`): both join
    ``outs``, so the global phase never answers below a given controller that meets them;
    the outcome polished from joins ``bases``."""
    p = ctx.problem
    as_is = _as_given(ctx, run, setup, given)
    outs.append(as_is)
    if not _meets_specs(p, as_is) or run.stop():
        run.notes.append(f"global phase: {INCUMBENT} does not meet the specs as given"
                         f" ({best_achievable(as_is.cert) or 'its reference step'});"
                         " it is a start of the search only")
        return
    bases.append(as_is)
    out, label, notes = _polished(ctx, run, as_is, INCUMBENT)
    polishes.append((INCUMBENT, _gained(p, as_is, out), notes))
    if out is not None:
        run.tried.append((f"{INCUMBENT}, {label}", out))
        outs.append(out)


def _as_given(ctx, run, setup, given):
    """The caller's controller (coefficients ``given``) certified as it is, on ``setup``'s
    program; it joins ``run.tried``."""
    as_is = run.outcome(ctx, setup, None, "start", x=ctx.full(given, setup))
    run.tried.append((f"{INCUMBENT}, as given", as_is))
    return as_is


def _kept(ctx, run, given, out):
    """Without the global phase: the caller's controller (coefficients ``given``) certified
    as it is, the answer when it meets the specs and the program's ``out`` is not certified
    or worse (the program only started from it)."""
    p = ctx.problem
    as_is = _as_given(ctx, run, ctx.setup(program_models(p), ctx.nu, "free"), given)
    if not _meets_specs(p, as_is):
        return out
    if out is None or not out.certified or _rank(p, as_is, True) > _rank(p, out, True):
        run.notes.append(f"{INCUMBENT} as given is the answer: the program started from it"
                         " ended below it or outside the specs")
        return as_is
    return out


def _polish_again(ctx, run, outs, bases):
    """The best answer of each of the ``POLISH.again_basins`` best basins (the certified
    outcomes of one candidate, their objective counted, :func:`_basins`) polished again
    from where it ended, with a fresh iteration budget (:meth:`Run.grant`); then the basin
    of the best answer polished again from where that ended, while each polish gains
    ``POLISH.again_gain``, up to ``POLISH.again`` polishes in all; each outcome joins
    ``outs``.  A polish ends at its iteration limit, its trust region's edge or a point
    the exchange's grid no longer holds; from its end, rescaled there, the program often
    goes far on, and how far differs from basin to basin.  Not when a basin's best is a
    start a polish already began from (one of ``bases``, no grid of its own: every polish
    of it gained nothing): that polish would be the same program from the same point,
    solved again to the same end."""
    p = ctx.problem
    if p.solver.objective == "feasibility" or run.strict:
        return
    live = {}             # each basin's answer whose last polish gained
    for name, best in _basins(p, run, outs)[:POLISH.again_basins]:
        if run.stop():
            return
        if best.grid is None and any(best is b for b in bases):
            continue
        out = _again(ctx, run, outs, name, best, 0)
        if out is not None:
            live[name] = out
    for k in range(1, POLISH.again):     # the best answer's basin goes on while it gains
        basins = _basins(p, run, outs)
        if not basins or run.stop():
            return
        name, best = basins[0]
        if live.get(name) is not best:
            return
        out = _again(ctx, run, outs, name, best, k)
        if out is None:
            return
        live[name] = out


def _again(ctx, run, outs, name, best, k):
    """Polish ``k`` (from 0) again of the basin ``name`` from its answer ``best``; its
    outcome joins ``run.tried`` and ``outs``.  Returns it when it gained
    ``POLISH.again_gain`` of the objective (counted) and ended inside the specs by
    itself, else ``None``: a point walked back from a polish that ended outside them
    answers, but a chain never goes on from it (where that polish ended, and so the
    point, turns on rounding: on another BLAS build the next polish from it converged
    elsewhere, ``tests/synthesis/test_search_builds.py``)."""
    p = ctx.problem
    run.grant("free")
    how = "polished again" + (f" ({k + 1})" if k else "")
    out, label, _ = _polished(ctx, run, best, name, how, best.grid)
    if out is None:
        return None
    run.tried.append((f"{name}, {label}", out))
    outs.append(out)
    before, after = objective_value(p, best), objective_value(p, out)
    if not (_counts(p, out) and after - before >= POLISH.again_gain * abs(before)):
        return None
    run.notes.append(f"global phase: {name} polished again from where its polish"
                     f" ended: {abs(before):.6g} -> {abs(after):.6g}")
    return out if label == how else None


def _basins(problem, run, outs):
    """The best outcome of each candidate in ``outs`` whose objective counts
    (:func:`_counts`), as ``(candidate, outcome)``, best first: the candidate is the name
    its outcomes carry in ``run.tried`` before their first comma."""
    named = {id(o): n.split(", ")[0] for n, o in run.tried}
    best = {}
    for o in outs:
        if _counts(problem, o):
            name = named.get(id(o), "the best answer")
            if name not in best or objective_value(problem, o) > objective_value(problem,
                                                                                 best[name]):
                best[name] = o
    return sorted(best.items(), key=lambda item: -objective_value(problem, item[1]))


def _gained(problem, base, out):
    """The polish's outcome ``out`` is certified and, from a certified ``base``, better."""
    return out is not None and out.certified and (
        not base.certified or objective_value(problem, out) > objective_value(problem, base))


def _walk_note(problem, name, out, walked, base):
    """The note of a polish that ended outside the specs and was walked back."""
    v = worst_violation(out.cert)
    if v is not None:
        miss = v.describe()
    elif _meets_specs(problem, out):
        miss = strip_note(problem, out.ctrl)
    else:
        miss = "outside the reference-step specs"
    what = problem.solver.objective.replace("_", " ")
    return (f"global phase: the polish of {name} ended outside the specs ({miss});"
            " walked back to its last certified point and solved again from there:"
            f" {what} {objective_value(problem, walked):.6g} (its start"
            f" {objective_value(problem, base):.6g})")


def _rescued(ctx, run, setup, x0, out, name, poles_first=False):
    """A polish ``out`` from the certified point ``x0`` that ended outside the specs, or
    certified with a controller pole outside the program's strip (IPOPT's acceptable level:
    its integral gain does not count, :func:`_counts`): walked back (:func:`_walked_back`),
    solved again from there with its floor at the walked-back gain on the grid the polish
    reached (the certificate's offending frequencies and temperatures kept,
    ``POLISH.backoff_iter`` IPOPT iterations), and that solve walked back in turn when it
    ends outside the specs too (over the poles first when the polish needed them,
    ``poles_first``); the better certified point (``None``: the walk found none).
    A polish that missed by more than the back-off's 5 % (on stage 204 at ``Ms_max`` 2.25
    its |T| peak 1.46 against 1.3 at a resonance between its grid's frequencies, integral
    gain 614 k) is walked back to 537 k, solved again to 593 k 1.9 % outside, and walked
    back to 585 k. On stage 11 at ``Ms_max`` 2.0 a polish that ended at 627 k with a
    controller pole 10 % outside the strip (not counted; the answer was another polish's
    818 k) is walked back and solved again to 825 k."""
    p = ctx.problem
    walked = _walked_back(ctx, run, setup, x0, out)
    if walked is None or run.stop():
        return walked
    floor = _floor(p, setup, walked.x)
    again, _, _ = _hard_from(ctx, run, walked.x, f"{name}, from its walk back",
                             POLISH.backoff_iter, floor, out.grid, poles_first)
    if again is not None and not _counts(p, again):
        again = _walked_back(ctx, run, setup, walked.x, again)
    if again is None or objective_value(p, again) <= objective_value(p, walked):
        return walked
    return again


def _walked_back(ctx, run, setup, x0, out):
    """The point where the segment from a polish's certified start ``x0`` to where it
    ended outside the specs (``out``, back-offs included) leaves the specs, by bisection
    (``POLISH.walk_steps`` certificates, to ``2 ** -walk_steps`` of the segment): the
    farthest point found that meets every spec, frequency and reference step, with every
    controller pole inside the program's strip (:func:`_counts`; ``None``: none met them).

    The integral gain ``r_0 / q_0`` is a ratio of two linear functions of the controller's
    coefficients, so along a segment it is monotone: when the points that meet the specs
    form one interval from the start, the farthest is the best on the segment (the caller
    keeps it only above its start), and a polish that gained on its start but ended
    outside the specs keeps most of its gain instead of being lost (on a 4th-order stage,
    polishes from starts of 399-501 k kept 449-537 k)."""
    p = ctx.problem
    n = ctx.param.n_x
    a = np.asarray(x0, float)
    b = np.asarray(out.x, float)[:n]
    lo, hi, best = 0.0, 1.0, None
    said = len(run.notes)      # the probes are points of a segment, not solves to note
    for _ in range(POLISH.walk_steps):
        if run.stop():
            break
        t = 0.5 * (lo + hi)
        x = a.copy()
        x[:n] = a[:n] + t * (b - a[:n])
        o = run.outcome(ctx, setup, None, "start", x=x)
        if _counts(p, o):
            lo, best = t, o
        else:
            hi = t
    del run.notes[said:]
    # a point of the polish that ended at ``out``: its phase (a hard-phase polish's answer
    # is optimised under the specs, as far as its budget went) and the grid it reached
    # (where it found the specs bind: a polish from this point starts there)
    return None if best is None else replace(best, phase=out.phase, grid=out.grid)


def _polish_notes(polishes):
    """The polishes' notes: those of a polish that improved on its candidate as they are,
    the others in one line (their solver statuses counted: a polish that does not improve
    leaves its candidate as the search found it, which is an answer, not a failure)."""
    notes = [n for _, gained, ns in polishes if gained for n in ns]
    idle = [(name, ns) for name, gained, ns in polishes if not gained]
    if idle:
        ended = {}
        for _, ns in idle:
            for n in ns:
                if " ended with IPOPT " in n:
                    st = n.rsplit(" ended with IPOPT ", 1)[1]
                    ended[st] = ended.get(st, 0) + 1
        how = ", ".join(f"{st} x{k}" if k > 1 else st for st, k in sorted(ended.items()))
        notes.append(f"global phase: {len(idle)} of {len(polishes)} polishes did not improve"
                     f" on their candidate" + (f" (IPOPT: {how})" if how else ""))
    return notes


def _screened_value(problem, ctx, cand):
    """A candidate's screened objective in the units of :func:`objective_value`."""
    if problem.solver.objective == "max_integral_gain":
        ki = integral_gain(ctx.controller(cand.xc))
        return abs(ki) if np.isfinite(ki) else -np.inf
    return cand.objective


def _floor(problem, setup, x):
    """The polish's objective floor at ``x`` (``setup``'s scaling): its scaled integral
    gain less ``POLISH.floor_slack`` (``None`` for another objective or a non-positive gain)."""
    if problem.solver.objective != "max_integral_gain":
        return None
    r0, q0, q0c = objective_rows(setup)
    num, den = float(r0 @ x[:r0.size]), float(q0 @ x[:q0.size] + q0c)
    return (1.0 - POLISH.floor_slack) * num / den if num > 0 and den > 0 else None


def _polish(ctx, run, xa, name, floor=None, grid=None):
    """One polish of a candidate (its vector ``xa`` in ``ctx``'s scaling): the program from
    it within ``POLISH.iterations`` iterations, its reference-step rows and floored roots
    linearised from the first solve on, backed off when it ends just outside the
    certificate; with a ``floor`` (:func:`_floor` of a certified start) every solve keeps
    the start's integral gain (:attr:`~robrst.synthesis.attempts.Run.floor`): a polish is
    an improvement or nothing, never a worse basin reached through IPOPT's restoration;
    ``grid``: the models and frequencies to start from (:func:`_hard_from`).
    Returns the polish's ends near the specs, nearest first (:func:`_backoff`; empty:
    nothing solved), its notes and whether a solve needed the poles (the back-off's solves
    then start over them)."""
    out, notes, poles = _hard_from(ctx, run, xa, name, POLISH.iterations, floor, grid)
    return _backoff(ctx, run, out, name, floor, poles), notes, poles


def _hard_from(ctx, run, x, name, budget, floor=None, grid=None, poles_first=False):
    """The objective phase with every coefficient free from the near-optimal point ``x``,
    in a run of its own with ``budget`` IPOPT iterations (its reference-step rows and
    floored roots linearised from the first solve on; ``floor``: the scaled integral gain
    it keeps, :attr:`Run.floor`; ``grid``: the models and frequencies to start from,
    :attr:`~robrst.synthesis.attempts.Outcome.grid`; ``poles_first``: an earlier solve of
    the same polish needed the poles, so its solves start over them,
    :attr:`~robrst.synthesis.attempts.Run.poles_first`); its rounds join ``run``'s.
    Returns the outcome, the run's notes and whether a solve's answer came from the
    poles (:attr:`~robrst.synthesis.attempts.Run.over_poles`)."""
    sub = Run(ctx.problem, run.say, run.templates, None, budget, run.stop)
    sub.rows_first = True
    sub.pole_space = PoleSpace.of     # a failed trust region: over the poles
    sub.floor = floor
    sub.poles_first = poles_first
    out = sub.hard(ctx, "free", x, name, grid)
    run.rounds += sub.rounds
    return out, sub.notes, sub.over_poles


def _backoff(ctx, run, out, name, floor=None, poles_first=False):
    """A polish that ends just outside the specs solved again from where it ended with the
    program tightened by the miss (constraint back-off, ``POLISH.backoffs`` times,
    ``POLISH.backoff_iter`` IPOPT iterations each): outside the certificate (its last round's
    peaks between the exchange's frequencies, its budget spent) the program's bounds, or
    certified but outside the reference-step specs (its linearised step samples missed the
    sampled loop's peak) the time-domain specs the program holds.  The optimum moves
    inside by the miss instead of the polish being lost (``poles_first``: the polish's
    first solve needed the poles, and its back-offs start over them).  It stops at the
    first outcome that meets every spec; else the nearest to them of the polish's end and
    its back-offs (:func:`_miss`) comes first: a back-off that runs away (on stage 722 at
    ``Ms_max`` 2.5 from a polish 0.8 % outside to an unstable loop) never replaces the end
    it started from, which the walk back (:func:`_rescued`) then brings inside.

    Returns the ends near the specs, nearest first: the nearest, then each other end
    certified (outside the reference-step specs) or within ``POLISH.backoff_near`` of the
    certificate; the caller walks back from each.  Their two misses have no common scale
    (a step's against a peak's), and the nearest by :func:`_miss` is not always the one
    the walk back takes farthest: on ``paper_robust`` the polish again (2) ended 0.13 %
    outside the peaks at 1,020 k and its back-off certified at 1,129 k outside the step
    specs; walked back from the certified one the design answers 879 k, from the 0.13 %
    miss 1,034 k."""
    margin, problem = ctx.free_margin, ctx.problem
    ends = []
    for k in range(POLISH.backoffs + 1):
        if out is None:
            break
        miss = _miss(problem, out)       # each outcome's miss once: a step response each
        ends.append((miss, out))
        if k == POLISH.backoffs or run.stop():
            break
        certified, ratio = miss[0] == 0, miss[1]
        if not 1.0 < ratio <= POLISH.backoff_near:
            break
        if certified:
            ctx = replace(ctx, problem=_tightened(ctx.problem, ratio ** 2))
        else:
            margin /= ratio ** 2
        out = _solved_again(replace(ctx, free_margin=margin), run, out, f"{name}, backed off",
                            floor, poles_first)
    ends.sort(key=lambda e: e[0])
    return [o for i, (m, o) in enumerate(ends)
            if i == 0 or m[0] == 0 or m[1] <= POLISH.backoff_near]


def _miss(problem, out):
    """How far the outcome ``out`` is from every spec, as a key (lower is nearer): a
    certified one by its reference-step miss
    (:func:`~robrst.synthesis.tracking.time_spec_ratio`, at most 1 inside), before any
    uncertified one, those by their certificate's badness."""
    if out.certified:
        return (0, time_spec_ratio(problem, out.ctrl))
    return (1, out.badness)


def _solved_again(ctx, run, out, name, floor, poles_first=False):
    """The polish's program solved again from its outcome ``out`` (``ctx``: the backed-off
    program) on the program's own grid, and when that does not certify, on the grid the
    polish's rounds reached (:attr:`~robrst.synthesis.attempts.Outcome.grid`: the
    certificate's offending frequencies and temperatures kept, so a peak the budget left
    between the exchange's frequencies is not missed again; a larger program, which the
    back-off's few iterations do not always solve); the better of the two (``None``:
    nothing solved)."""
    plain, _, _ = _hard_from(ctx, run, out.x, name, POLISH.backoff_iter, floor,
                             poles_first=poles_first)
    if (plain is not None and plain.certified) or out.grid is None or run.stop():
        return plain
    kept, _, _ = _hard_from(ctx, run, out.x, name, POLISH.backoff_iter, floor, out.grid,
                            poles_first)
    done = [o for o in (plain, kept) if o is not None]
    return min(done, key=lambda o: o.badness, default=None)


def _tightened(problem, factor):
    """``problem`` with its reference-step specs divided by ``factor``."""
    sp = problem.specs
    tight = {k: getattr(sp, k) / factor for k in ("overshoot_max_pct", "settling_time_max_s",
                                                 "step_u_max_V") if getattr(sp, k) is not None}
    return replace(problem, specs=replace(sp, **tight))


def _moved_inside(ctx, run, setup, space, inside, cand, steps, two_dof, refused):
    """The candidate ``cand``, which the certificate (or the time-domain check) refused
    or whose polish gained nothing (``refused``: its outcome as screened), moved inside
    the specs by the screen
    (:func:`~robrst.synthesis.search.move_inside`) and certified; ``None`` when nothing
    inside was found or it does not certify either.  ``inside`` memoises the inner screen
    on the program's grid; a refusal at frequencies or temperatures of its own adds them
    to that candidate's inner screen (the exchange's :func:`refine`): the peak the screen
    did not see is the one to move away from."""
    p = ctx.problem
    own = refused.cert is not None and bool(refused.cert.violations)
    if own or not inside:
        models, nu = program_models(p), ctx.nu
        if own:
            models, nu = refine(p, refused.cert, models, nu)
        tight = replace(ctx, free_margin=POLISH.inside_margin).setup(models, nu, "free")
        screen = Screen(tight, _inside(steps, TIME_MARGIN ** 2), two_dof)
        if not own:
            inside.append(screen)
    else:
        screen = inside[0]
    moved = move_inside(screen, space, cand)
    if moved is None:
        return None
    out = run.outcome(ctx, setup, None, "start", x=ctx.full(moved.xc, setup))
    return out if _meets_specs(p, out) else None


def _screened_steps(problem, w0):
    """``(time specs, two_dof)`` the screen checks: the program's own time specs, or with a
    reference model designed afterwards its specs and ``(bandwidth, damping, cancel)``
    (scaled; :mod:`robrst.synthesis.tracking`)."""
    sp, c = problem.specs, problem.controller
    if c.T_mode != "reference_model" or not sp.time_domain:
        return time_specs(problem, w0), None
    ts = TimeSpecs(overshoot=None if sp.overshoot_max_pct is None else sp.overshoot_max_pct / 100,
                   settling=None if sp.settling_time_max_s is None else sp.settling_time_max_s * w0,
                   u_max=sp.step_u_max_V, step_um=sp.step_um, w0=w0)
    return ts, (c.reference_wn / w0, c.reference_zeta, CANCEL_FLOOR)


def _inside(ts, margin):
    """The time specs ``ts`` tightened by ``margin`` (``None`` stays ``None``)."""
    if ts is None:
        return None
    tight = {k: getattr(ts, k) * margin for k in ("overshoot", "settling", "u_max")
             if getattr(ts, k) is not None}
    return replace(ts, **tight)


def _warm_seed(ctx, warm):
    """``(placement, seed)`` of a previous result of the same structure, or ``None``."""
    if warm is None:
        return None
    try:
        xc = ctx.param.vector(warm.controller)
    except RobrstError:
        return None
    wn = None if warm.wn_rad_s is None else warm.wn_rad_s / ctx.w0
    return warm.placement or "fixed", (WARM_START, xc, wn, warm.zeta)


def _at_degree(problem, extra):
    from robrst.synthesis.analytic import pole_placement

    pe = replace(problem, controller=replace(problem.controller, extra_degree=extra))
    return pe, pole_placement(pe.family.reference_model, pe.poles, pe.controller)


def _homotopy(problem, start, run):
    """Degrees ``0..extra_degree`` in turn, each seeded with the one below."""
    extra = problem.controller.extra_degree
    if problem.solver.homotopy == "always":
        out = None
        for e in range(extra + 1):
            pe, se = (problem, start) if e == extra else _at_degree(problem, e)
            run.say(f"homotopy: extra_degree {e}")
            out = _synthesize(pe, se, run, e, out)
        return out
    out = _synthesize(problem, start, run, extra)
    # with the global phase a certified answer is the search's: no lower degree to try
    optimised = out.certified and (out.phase == "hard" or run.global_phase)
    if optimised or extra == 0 or out.badness > NEAR_MISS or a_priori_note(problem) or run.spent() \
            or problem.scenarios:   # a fleet design's round: the exchange over actuators decides
        return out      # done, or far from the specs: fewer degrees will not meet them either
    run.say(f"extra_degree {extra}: {'objective not optimised' if out.certified else 'not certified'}"
            f"; solving with {extra - 1} first")
    pl, sl = _at_degree(problem, extra - 1)
    lower = _homotopy(pl, sl, run)
    if not lower.certified:
        return out
    again = _synthesize(problem, start, run, extra, lower)
    return again if objective_value(problem, again) >= objective_value(problem, out) else out


def robust_synthesis(problem: Problem, start: AnalyticDesign,
                     progress: Callable[[str], None] | None = None, templates: dict | None = None,
                     warm: SynthesisResult | None = None,
                     budget: int | None = None, global_phase: bool = False,
                     stop: Callable[[], bool] | None = None,
                     incumbent: RSTController | None = None) -> SynthesisResult:
    """Synthesise, certify and always return a controller; see the module docstring.

    Parameters
    ----------
    problem : Problem
        The problem.
    start : AnalyticDesign
        The analytic design at the problem's poles (start point, fixed ``Am``).
    progress : callable, optional
        Called with one line of text per solve.
    templates : dict, optional
        Built solvers by structure (:class:`~robrst.synthesis.synthesizer.Synthesizer`
        shares them between variants).
    warm : SynthesisResult, optional
        A previous result of the same controller structure: its controller is the
        preferred start (a batch of nearby variants converges in a few iterations).
    budget : int, optional
        IPOPT iterations this synthesis may spend before it returns the best point found
        (default ``RUN.iter_budget``, :class:`~robrst.synthesis.attempts.RunOptions`; the
        extra starts of a multi-start get the first's).
    global_phase : bool
        Search every controller of the requested degree globally before polishing
        (:mod:`robrst.synthesis.search`); with ``placement = "auto"`` the problem's own
        placement is solved too and the better certified objective kept.
    stop : callable, optional
        Checked once per generation of the global phase and per certification round:
        true returns the best point found so far.
    incumbent : RSTController, optional
        A controller of the problem's structure (:func:`incumbent_fits`) the answer is to
        beat: with the global phase it starts the search's first run, is certified as it
        is and polished first, and the answer is never below it when it meets the specs;
        without, it is a start of the freely placed poles' local run.

    Returns
    -------
    SynthesisResult
        ``status`` ``"certified"`` or ``"not_certified"`` (then ``best_achievable``).
    """
    say = progress or (lambda m: None)
    run = Run(problem, say, {} if templates is None else templates, warm, budget, stop)
    run.global_phase = global_phase
    run.incumbent = incumbent
    t0 = time.perf_counter()
    note = a_priori_note(problem)
    if note:
        run.notes.append(note)
        run.hopeless = True
    out = _homotopy(problem, start, run)
    ctrl, cert = out.ctrl, out.cert
    Am, wn, zeta = start.Am, None, None
    if out.placement != "fixed":   # the nominal closed-loop polynomial reached
        ref = problem.family.reference_model
        Am = poly.monic(poly.padd(poly.pmul(ref.A, ctrl.S), poly.pmul(ref.B, ctrl.R)))
    if out.placement == "dominant":
        k = out.setup.n_x
        wn, zeta = float(out.x[k] * out.setup.w0), float(out.x[k + 1])
    status = "certified" if cert.certified else "not_certified"
    return SynthesisResult(controller=ctrl, Am=Am, certificate=cert, status=status,
                           objective=problem.solver.objective, w0=out.setup.w0,
                           rounds=tuple(run.rounds), solve=out.res,
                           wall_time_s=time.perf_counter() - t0, wn_rad_s=wn, zeta=zeta,
                           placement=out.placement, phase=out.phase,
                           best_achievable=best_achievable(cert), notes=merged_notes(run.notes),
                           search=run.search, tried=tuple(_tried(problem, run.tried)))


def _tried(problem, tried):
    """``(name, status, objective, integral gain, worst ratio, placement, note)`` of what
    the global phase tried: ``"certified"`` (with its objective) only when the reference
    step also meets the time-domain specs, as the answer must; a certified one outside the
    controller-pole strip has no objective, and its note says why."""
    out = []
    for name, o in tried:
        ok = _meets_specs(problem, o)
        obj = objective_value(problem, o) if ok else np.nan
        note = strip_note(problem, o.ctrl) if ok else None
        out.append((name, "certified" if ok else "not_certified",
                    float(obj) if np.isfinite(obj) else None, integral_gain(o.ctrl),
                    float(o.badness) if np.isfinite(o.badness) else None, o.placement, note))
    return out
