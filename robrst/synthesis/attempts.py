"""One attempt of the robust synthesis: a placement, its starts, phases and rounds.

:class:`Run` holds what the attempts of one synthesis share (the built solvers, the
progress lines, the rounds and notes); :meth:`Run.attempt` runs, for one nominal pole
placement, the objective under hard specs from the preferred start and, when that
fails, the soft-goal phase from the best starts followed by the objective again, each
result certified and refined round by round (see :mod:`robrst.synthesis.robust`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.interrupt import offer, requested
from robrst.certificate.proof import actuator_of, certify_families
from robrst.synthesis.context import strip_note
from robrst.synthesis.exchange import Phase, solve_exchange
from robrst.synthesis._nlp import grid_blocks, objective_rows
from robrst.synthesis.outcome import Round, worst_violation
from robrst.synthesis.parametrize import integral_gain
from robrst.synthesis.objective import objective
from robrst.synthesis.starts import ON_SLOW_POLE, candidates, integral_seeds, score, score_many
from robrst.synthesis._polerows import pole_rows, worst_damping_ratio
from robrst.synthesis.template import MappedTemplates
from robrst.synthesis.tracking import meets_time_specs
from robrst.synthesis._timesamples import (TIME_MARGIN, TimeRows, time_rows, time_specs,
                                           worst_time_ratio)

if TYPE_CHECKING:
    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem
    from robrst.synthesis.context import Context
    from robrst.synthesis._nlp import NLPSetup
    from robrst.synthesis.outcome import SolveResult, SynthesisResult
    from robrst.synthesis._timesamples import TimeSpecs

__all__ = ["Outcome", "Run", "worst_violation", "frequency_certificate", "refine",
           "objective_value", "program_models", "RunOptions", "RUN", "merged_notes"]

_LINEARISED = ("linearised rows (reference-step samples, damping floors): the worst is {} x"
               " its bound after the rounds (the certificate decides)")
_LINEARISED_HEAD, _LINEARISED_TAIL = _LINEARISED.split("{}")


def merged_notes(notes: Sequence[str]) -> tuple[str, ...]:
    """A run's notes for the reader: each once, in the order first given, and the
    linearised rows' worst ratios of every solve that left them above their bound in one
    note (a polish and its back-offs each add theirs).

    Parameters
    ----------
    notes : sequence of str
        The notes as the run's solves added them.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> from robrst.synthesis.attempts import merged_notes
    >>> merged_notes(["a", "b", "a"])
    ('a', 'b')
    """
    out, ratios, at = [], [], None
    for n in notes:
        if n.startswith(_LINEARISED_HEAD) and n.endswith(_LINEARISED_TAIL):
            ratios.append(n[len(_LINEARISED_HEAD):len(n) - len(_LINEARISED_TAIL)])
            if at is None:
                at = len(out)
                out.append("")
        elif n not in out:
            out.append(n)
    if at is not None:
        out[at] = (_LINEARISED.format(ratios[0]) if len(ratios) == 1 else
                   f"{_LINEARISED_HEAD.rsplit(': ', 1)[0]}: the worst is {', '.join(ratios)}"
                   f" x its bound after the rounds of {len(ratios)} solves (the certificate"
                   " decides)")
    return tuple(out)


WARM_START = "previous design"   # the name of that start (robrst.synthesis.robust hands it down)
GLOBAL_START = "global run"      # the global phase's candidates (near-optimal starts)
INCUMBENT = "the incumbent"      # a controller the caller asks the answer to beat


@dataclass(frozen=True)
class RunOptions:
    """The synthesis's tuning constants, each with why (:class:`Run`).

    Attributes
    ----------
    gamma_floor : float
        The soft phase stops once every spec holds with 3 % to spare.
    soft_starts : int
        Soft-phase attempts (the best starts first).
    free_box : float
        The first trust region with freely placed poles, relative to the coefficients
        (free coefficients move resonances and slow poles far in one step) ...
    free_boxes : int
        ... re-centred or halved at most this many times ...
    free_max_iter : int
        ... each solve within this many IPOPT iterations ...
    free_exchange_rounds : int
        ... and this many exchange rounds (the solves over the poles and the linearised
        rounds' too: uncapped, one linearised round of a 4th-order polish ran 50 rounds,
        4,207 iterations) ...
    free_iter_budget : int
        ... all of them within this many IPOPT iterations.
    iter_budget : int
        IPOPT iterations of one synthesis: then the best certified point found.
    far_start : float
        A start missing the specs this many times on the grid gets no objective phase.
    near_start : float
        A start within this ratio of the specs on the grid: the certificate judges it.
    bold_far : float
        A bolder start (:meth:`Run.bolder`) may miss them this many times.
    warm_mu : float
        IPOPT's initial barrier from a previous design of a nearby variant (and from a
        global-phase candidate): a small barrier keeps a near-optimal start near ...
    warm_near : float
        ... solved from at once when within this ratio of the specs on the grid.
    time_rounds : int
        Reference-step samples: linearise-and-solve rounds per solve.
    time_box : float
        Their first trust region (relative to the coefficients).
    rows_first_near : float
        A polish's first solve carries the step samples above this share of their bound.
    pole_polish : bool
        A polish whose first trust region over the coefficients fails is solved over the
        nominal closed-loop poles and the Youla degrees instead (:meth:`Run.in_pole_space`;
        the smaller coefficient box it replaces changed no answer on the stages measured).
        On by default: it certifies ``paper_robust`` at 636,429 against 337,743 without it,
        4th-order stages 16-18 % higher (synthesis background page) ...
    pole_box : float
        ... within this share of the search box around its start (each pole's log-frequency
        and log-damping move by at most 3 % of their ranges, the nominal loop stays stable).
    chained_derivatives : bool
        The solve over the poles takes its derivatives by the chain rule through the
        coefficient program's own (:class:`robrst.synthesis.template.MappedTemplate`): the
        same numbers, about 4x cheaper per call (``paper_robust`` 72 s CPU against 107,
        the same answer).  Off: CasADi's derivatives through the composed graph (the
        default until 2026-12-07; IPOPT's iterates differ by rounding, and so may which
        basins the chain of polishes visits).
    """

    gamma_floor: float = 0.97
    soft_starts: int = 3
    free_box: float = 1.0
    free_boxes: int = 6
    free_max_iter: int = 300
    free_exchange_rounds: int = 10
    free_iter_budget: int = 800
    iter_budget: int = 2500
    far_start: float = 5.0
    near_start: float = 1.05
    bold_far: float = 20.0
    warm_mu: float = 1e-4
    warm_near: float = 1.05
    time_rounds: int = 8
    time_box: float = 0.5
    rows_first_near: float = 0.3
    pole_polish: bool = True
    pole_box: float = 0.03
    chained_derivatives: bool = True


RUN = RunOptions()


@dataclass(frozen=True, eq=False)
class Outcome:
    """A point of an attempt: controller, certificate, solve, phase and placement.

    Parameters
    ----------
    ctrl : RSTController
        The controller.
    cert : Certificate
        Its frequency-domain certificate.
    res : SolveResult
        The solve it came from.
    phase : str
        ``"hard"``, ``"soft"`` or ``"start"``.
    placement : str
        The nominal pole placement.
    x : numpy.ndarray
        The variable vector.
    setup : NLPSetup
        The program it was solved in.
    grid : tuple, optional
        ``(models, nu)``: the program's models and frequency grid [rad/s] after the
        rounds of :meth:`Run.hard` that reached it, the last certificate's offending
        points included (a solve continued from it keeps the exchange's points).

    Attributes
    ----------
    certified : bool
        The certificate holds.
    badness : float
        The worst violation's ratio to its bound (0 when certified).
    """

    ctrl: RSTController
    cert: Certificate
    res: SolveResult
    phase: str
    placement: str
    x: np.ndarray
    setup: NLPSetup
    grid: tuple = None

    @property
    def certified(self):
        return self.cert.certified

    @property
    def badness(self):
        v = worst_violation(self.cert)
        if v is None:
            return 0.0
        if v.quantity == "spectral_abscissa" or not v.bound:   # crossing / unresolved: bound 0
            return np.inf
        return v.ratio


def frequency_certificate(problem: Problem, ctrl: RSTController) -> Certificate:
    """The certificate of ``ctrl`` for the frequency-domain specs on every actuator of
    ``problem`` (the time-domain ones are checked once the reference path is designed).

    Parameters
    ----------
    problem : Problem
        The problem (its family, specs and certificate resolution).
    ctrl : RSTController
        The controller.

    Returns
    -------
    Certificate
    """
    so = problem.solver
    return certify_families(problem.families, ctrl, problem.specs.without_time_domain(),
                            n_sweep=so.cert_temperatures, rtol=so.cert_tol)


def program_models(problem: Problem) -> list:
    """The models the program starts with: every family member, and the models at both
    ends of the temperature range of every further actuator (``problem.scenarios``; the
    certificate's refinement adds their other temperatures where they bind).

    Parameters
    ----------
    problem : Problem
        The problem.

    Returns
    -------
    list of Plant
    """
    ends = [m for f in problem.scenarios for m in (f.models[0], f.models[-1])[:len(f.models)]]
    return list(problem.family.models) + ends


def refine(problem: Problem, cert: Certificate, models: list,
           nu: np.ndarray, max_new: int = 2) -> tuple[list, np.ndarray]:
    """Add the certificate's offending frequencies, and its worst temperatures, to the program.

    Every offending frequency joins the grid (with its 2 % neighbours); of the offending
    temperatures not yet modelled only the ``max_new`` worst join (the family members
    already span the range: most violations between them are the same peak).

    Parameters
    ----------
    problem : Problem
        The problem.
    cert : Certificate
        The last round's certificate.
    models : list of Plant
        The program's models.
    nu : numpy.ndarray
        The program's grid [rad/s].
    max_new : int
        At most this many new temperatures.

    Returns
    -------
    models : list of Plant
    nu : numpy.ndarray
    """
    known = {m.temperature_C for m in models}
    fs = problem.specs.sample_rate_hz
    new_T, further = {}, {}
    for v in cert.violations:
        if v.freq_rad_s is not None:
            w = v.freq_rad_s
            if v.loop == "sampled":   # grid frequencies are physical; the setup warps them
                w = min(w, 0.999 * np.pi * fs)
            nu = np.unique(np.concatenate([nu, [w * f for f in (0.98, 1.0, 1.02)]]))
        elif v.quantity.endswith("peak"):  # peak at infinity: push the grid further out
            nu = np.unique(np.concatenate([nu, [nu.max() * 100.0]]))
        k = actuator_of(v.label)[0]
        if k:          # a further actuator's model (problem.scenarios), by identity
            if np.isfinite(v.temperature_C) and not any(
                    m is q for q in models
                    for m in _models_at(problem.families[k], v.temperature_C)):
                further[k, v.temperature_C] = max(further.get((k, v.temperature_C), 0.0),
                                                  v.ratio)
        elif v.temperature_C not in known and np.isfinite(v.temperature_C):
            new_T[v.temperature_C] = max(new_T.get(v.temperature_C, 0.0), v.ratio)
    for T in sorted(new_T, key=lambda t: -new_T[t])[:max_new]:
        models.append(problem.family.at(T))
    for k, T in sorted(further, key=lambda kt: -further[kt])[:max_new]:
        models.append(_models_at(problem.families[k], T)[0])
    models.sort(key=lambda m: m.temperature_C)
    return models, nu


def _models_at(family, T):
    """The member of ``family`` at ``T`` if there is one (both objects a program may hold),
    else the model :meth:`~robrst.core.family.PlantFamily.at` ``T``."""
    members = [m for m in family.models if m.temperature_C == T]
    return members + [family.at(T)] if members else [family.at(T)]


def _stacked(a, b):
    """Two sets of linear rows as one (either may be ``None``)."""
    if a is None or b is None:
        return a if b is None else b
    return type(a)(A=np.vstack([a.A, b.A]), g=np.concatenate([a.g, b.g]),
                   c=np.concatenate([a.c, b.c]), keys=a.keys + b.keys,
                   labels=a.labels + b.labels)


def _better(problem, out, others):
    """``out`` (certified), or a certified outcome of ``others`` with a larger objective (a
    hard phase from another start may end at a worse local optimum than a start that
    already met the specs)."""
    return max([out, *(o for o in others if o is not None and o.certified)],
               key=lambda o: objective_value(problem, o))


def objective_value(problem: Problem, out: Outcome) -> float:
    """The objective of a certified outcome (larger is better; ``-inf`` if uncertified).

    Parameters
    ----------
    problem : Problem
        The problem (its objective).
    out : Outcome
        The outcome.

    Returns
    -------
    float
        ``|integral gain|``, ``-worst Ms`` or 0 (feasibility); ``-inf`` for an integral
        gain whose controller has a pole outside the program's strip (by more than
        ``CTRL_POLE_SLACK``, :func:`robrst.synthesis.context.strip_note`): a solve that
        ended there (IPOPT's acceptable level, a restoration phase) bought its gain with a
        lag the program excludes, and never beats a controller inside the strip.
    """
    if out is None:
        return -np.inf
    value = objective(problem, out.ctrl, out.cert)
    if value is None or strip_note(problem, out.ctrl):
        return -np.inf
    return value


def _key(obj):
    """A hashable key of nested program data (arrays by shape and bytes, dataclasses and
    dicts by their fields)."""
    if isinstance(obj, np.ndarray):
        return ("array", obj.shape, obj.dtype.str, obj.tobytes())
    if isinstance(obj, (list, tuple)):
        return (type(obj).__name__, *(_key(v) for v in obj))
    if isinstance(obj, dict):
        return ("dict", *sorted((k, _key(v)) for k, v in obj.items()))
    if hasattr(obj, "__dataclass_fields__"):
        return (type(obj).__name__, *(_key(getattr(obj, f)) for f in obj.__dataclass_fields__))
    if isinstance(obj, float):
        return ("float", obj.hex())   # exact: -0.0 and 0.0 differ
    hash(obj)   # a plain value (number, string, None): hashable, or a clear TypeError
    return obj


class Run:
    """One synthesis: what its attempts share (built solvers, progress, rounds, notes).

    Parameters
    ----------
    problem : Problem
        The problem.
    say : callable
        Progress: called with one line of text.
    templates : dict
        Built solvers by structure.
    warm : SynthesisResult, optional
        A previous design of a nearby variant.
    budget : int, optional
        IPOPT iterations of the synthesis (default ``RUN.iter_budget``); given, a hard stop
        (an extra start of a multi-start).

    Attributes
    ----------
    rounds : list of Round
        Every certification round so far.
    notes : list of str
        What the pipeline had to do.
    hopeless : bool
        Set when the specs are provably infeasible.
    solved : dict
        Program key -> result: a repeated program is not solved again.
    stop : callable
        Checked by :meth:`spent`: true ends every loop of the synthesis with the best
        point found so far (an interrupted design).
    search : GlobalSearch or None
        The global phase's record, once run (:mod:`robrst.synthesis.search`).
    tried : list of (str, Outcome)
        The global phase's candidates and the problem's own placement, as they ended.
    global_phase : bool
        The freely placed poles are searched globally (:mod:`robrst.synthesis.robust`).
    incumbent : RSTController or None
        A controller the answer is to beat (the caller's): a start of the freely placed
        poles' solves and, with the global phase, certified as it is and polished first.
    rows_first : bool
        The linearised rows (reference-step samples, roots near a floor) join the first
        solve with freely placed poles (a polish from a near-optimal start).
    pole_space : callable or None
        ``(ctx, setup) -> PoleSpace or None`` (:meth:`robrst.synthesis.search.PoleSpace.of`)
        when a polish may go over the poles (:meth:`in_pole_space`), else ``None``.
    poles_first : bool
        A polish whose earlier solve of the same candidate needed the poles (its trust
        region over the coefficients failed there): its solves start over the poles, and
        the coefficients' trust region runs only when they fail.
    over_poles : bool
        Set once a solve's answer came from the poles (:meth:`in_pole_space`).
    floor : float or None
        A polish's objective floor: the scaled integral gain its solves with freely placed
        poles keep (a linear row ``R(0) >= floor (S/s^k)(0)``), so a polish improves on the
        point it starts from or ends where no better point was found, never in a worse
        basin its restoration wandered to.
    """

    def __init__(self, problem: Problem, say: Callable[[str], None], templates: dict,
                 warm: SynthesisResult | None = None, budget: int | None = None,
                 stop: Callable[[], bool] | None = None) -> None:
        self.problem, self.say, self.templates, self.warm = problem, say, templates, warm
        self.budget = RUN.iter_budget if budget is None else int(budget)
        self.strict = budget is not None   # an extra start: its budget is a hard stop
        self.rounds, self.notes = [], []
        self.hopeless = False     # set when the specs are provably infeasible
        self.solved = {}          # program key -> result: a repeated program is not re-solved
        self.stop = stop or requested      # a signal (robrst.base.interrupt) stops too
        self.search, self.tried = None, []
        self.global_phase = False
        self.incumbent = None
        self.rows_first = False
        self.floor = None
        self.pole_space = None
        self.poles_first = self.over_poles = False

    def spent(self, placement: str | None = None) -> bool:
        """True once the synthesis has used its IPOPT iteration budget: ``RUN.iter_budget``
        for the rounds of ``placement`` (the fixed poles' rounds do not take the budget of
        the free search that follows them), twice that over all rounds.

        Parameters
        ----------
        placement : str, optional
            The placement whose rounds count (``None``: every round, one budget).

        Returns
        -------
        bool
            Also true once :attr:`stop` says so.
        """
        if self.stop():
            return True
        total = sum(r.iterations for r in self.rounds)
        if self.strict:
            return total > self.budget
        if placement is None or total > 2 * self.budget:
            return total > self.budget
        return sum(r.iterations for r in self.rounds if r.placement == placement) > self.budget

    def grant(self, placement: str) -> None:
        """A fresh iteration budget for what follows: ``RUN.iter_budget`` beyond the
        iterations the rounds of ``placement`` used so far (none for an extra start of a
        multi-start, whose budget is a hard stop).

        Parameters
        ----------
        placement : str
            The placement whose rounds count.
        """
        if not self.strict:
            used = sum(r.iterations for r in self.rounds if r.placement == placement)
            self.budget = max(self.budget, used + RUN.iter_budget)

    def solve(self, ctx: Context, setup: NLPSetup, x0: np.ndarray, phase: Phase, start: str,
              exact: bool = False) -> SolveResult:
        """One program by constraint exchange (trust regions with freely placed poles).

        Parameters
        ----------
        ctx : Context
            The synthesis's context.
        setup : NLPSetup
            The program's data.
        x0 : numpy.ndarray
            The start.
        phase : Phase
            Soft goals or the objective.
        start : str
            The start's name (reported).
        exact : bool
            Also impose each block's exact peak frequency once the grid holds.

        Returns
        -------
        SolveResult
        """
        ipopt = ctx.ipopt
        if start == WARM_START or start.startswith((GLOBAL_START, INCUMBENT)):
            ipopt = {**ipopt, "mu_init": RUN.warm_mu}   # a near-optimal start: a small barrier
        # the homotopy may pose the very same program again (same data, start and options):
        # the solves are deterministic, so its result is reused
        key = _key((setup, np.asarray(x0, float), ipopt, phase, exact))
        res = self.solved.get(key)
        spec = time_specs(ctx.problem, setup.w0)
        floored = setup.region is not None and (setup.region.zeta is not None
                                                or setup.region.ctrl_zeta is not None)
        if res is None and setup.placement == "free" and phase.kind == "hard":
            lin = None
            if self.rows_first and (spec is not None or floored):
                # a near-optimal start (the global phase's): its reference-step samples and
                # roots near their floor linearised from the first solve on, so the
                # objective does not first run out of the time specs
                found = (worst_time_ratio(setup, x0, spec, RUN.rows_first_near)[1]
                         if spec is not None else {})
                rows = time_rows(setup, x0, spec, (), found) if spec is not None else None
                lin = _stacked(rows, pole_rows(setup, x0))
            res = self.boxed(ctx, setup, x0, phase, exact, ipopt,
                             _stacked(lin, self.floor_row(setup)))
        elif res is None:
            res = solve_exchange(setup, x0, ipopt, phase, self.templates, exact=exact)
            if not res.success and not self.strict and not self.spent():
                # second chance (adaptive barrier), within the run's budget only
                res = solve_exchange(setup, x0, {**ctx.ipopt, "mu_strategy": "adaptive"}, phase,
                                     self.templates, exact=exact)
        if (spec is not None or floored) and res.success and key not in self.solved:
            res = self.linearised(ctx, setup, res, phase, exact, spec)
        self.solved[key] = res
        ex = res.exchange
        gamma = float(res.x[-1]) if phase.kind == "soft" else None
        self.rounds.append(Round(
            round=len(self.rounds) + 1, status=res.status, iterations=res.iterations,
            models=len(setup.models), frequencies=int(len(setup.nu)), violations=-1,
            exchange_rounds=ex.rounds, active_points=ex.active_points,
            stability_models=ex.stability_models,
            grid_points=ex.grid_points, phase=phase.kind, placement=setup.placement,
            start=start, gamma=gamma))
        self.say(f"{phase.kind} phase ({setup.placement} poles, from {start}): IPOPT"
                 f" {res.status} in {res.iterations} it, {len(setup.models)} models x"
                 f" {len(setup.nu)} freqs" + (f", worst spec ratio {gamma:.4g}" if gamma else ""))
        return res

    def linearised(self, ctx: Context, setup: NLPSetup, res: SolveResult, phase: Phase,
                   exact: bool, spec: TimeSpecs | None) -> SolveResult:
        """The linearised rows: reference-step samples (:mod:`robrst.synthesis._timesamples`,
        ``spec``) and the roots near a damping floor (:mod:`robrst.synthesis._polerows`).

        While a sample violates its spec or a root lies below its floor, the violated and
        near ones are linearised at the point and the program is solved again inside a
        trust region: in the objective phase first a restoration solve (phase ``"time"``:
        the worst normalised sample minimised, every other spec held), then the objective
        with the rows as constraints; in the soft phase the samples scale with ``gamma``
        (the roots' rows never do).  A step is kept when the worst exact ratio improved
        (the trust region then grows; it is halved otherwise).

        Parameters
        ----------
        ctx : Context
            The problem's context.
        setup : NLPSetup
            The program.
        res : SolveResult
            The solve to start from.
        phase : Phase
            Its phase.
        exact : bool
            Exact peak exchange (as the solve).
        spec : TimeSpecs or None
            The reference-step specs (``None``: damping floors only).

        Returns
        -------
        SolveResult
            The last accepted solve, ``iterations`` summed.
        """
        best, keys, f, iters = res, (), RUN.time_box, res.iterations
        hard_step = False     # the accepted step was the objective's (a hard solve)

        def ratios(x):
            w_t, fnd = worst_time_ratio(setup, x, spec) if spec is not None else (0.0, {})
            return max(w_t, worst_damping_ratio(setup, x)), w_t, fnd

        worst, w_time, found = ratios(best.x)
        restore = (phase.kind == "hard" and not (
            setup.objective == "min_Ms" and setup.bounds.get("S") is None))
        for _ in range(RUN.time_rounds):
            if self.spent() or (self.strict and iters > self.budget):
                break
            kind = "time" if w_time > 1.0 and restore else phase.kind
            if worst <= 1.0 and (kind != "hard" or hard_step):
                break
            rows = time_rows(setup, best.x, spec, keys, found) if spec is not None else None
            keys = rows.keys if rows is not None else keys
            rows = _stacked(rows, pole_rows(setup, best.x))
            if rows is None:
                break
            rows = _stacked(rows, self.floor_row(setup))
            c = best.x[:ctx.param.n_x]
            r = f * (np.abs(c) + 0.05 * np.max(np.abs(c)))
            x0 = best.x.copy()
            if kind == "time":
                x0[-1] = max(w_time, 1.0) * 1.02
            ipopt, rounds = ctx.ipopt, {}
            if setup.placement == "free":     # as the boxed solves
                ipopt = {**ipopt, "max_iter": min(ipopt["max_iter"], RUN.free_max_iter)}
                rounds = {"max_rounds": RUN.free_exchange_rounds}
            new = solve_exchange(setup, x0, ipopt, Phase(kind, TIME_MARGIN ** 2), self.templates,
                                 exact=exact, box=(c, r), lin=rows, **rounds)
            iters += new.iterations
            if not new.success:
                f /= 2
                continue
            if np.allclose(new.x[:-1], best.x[:-1], rtol=1e-9, atol=1e-12):
                break        # no freedom left (e.g. a unique Diophantine solution)
            w_new, wt_new, f_new = ratios(new.x)
            if kind == "time":
                new = replace(new, x=np.concatenate([new.x[:-1], [res.x[-1]]]))
            if w_new < worst or (w_new <= 1.0 and kind == "hard"):
                best, worst, w_time, found = new, w_new, wt_new, f_new
                f = min(2 * f, 4 * RUN.time_box)
                hard_step = kind == "hard"
            else:
                f /= 2
        if worst > 1.0:
            self.notes.append(_LINEARISED.format(f"{worst:.3g}"))
        return replace(best, iterations=iters)

    def floor_row(self, setup: NLPSetup) -> TimeRows | None:
        """The objective floor as a linear row of ``setup``'s program (:attr:`floor`), or
        ``None`` (no floor, another objective, fixed poles).

        Parameters
        ----------
        setup : NLPSetup
            The program's data.

        Returns
        -------
        TimeRows or None
        """
        if (self.floor is None or setup.objective != "max_integral_gain"
                or setup.placement != "free"):
            return None
        r0, q0, q0c = objective_rows(setup)
        g = self.floor
        return TimeRows(A=(g * q0 - r0)[None], g=np.zeros(1), c=np.array([g * q0c]),
                        keys=(("objective_floor", 0, 0.0, 1.0),),
                        labels=(("objective_floor", None, None, 0),))

    def boxed(self, ctx: Context, setup: NLPSetup, x0: np.ndarray, phase: Phase,
              exact: bool, ipopt: dict | None = None, lin: TimeRows | None = None
              ) -> SolveResult:
        """Trust-region solves for freely placed poles (free coefficients move resonances
        and slow poles far in one step; IPOPT alone wanders): a box around the point,
        re-centred and doubled while the solution lands on it, halved after a failure.
        Where they fail and the run may go over the poles, :meth:`in_pole_space`; a run
        that needed the poles before (:attr:`poles_first`, :attr:`over_poles`) starts
        there, and the boxes run only when the poles fail.

        Parameters
        ----------
        ctx : Context
            The synthesis's context.
        setup : NLPSetup
            The program's data.
        x0 : numpy.ndarray
            The start.
        phase : Phase
            Soft goals or the objective.
        exact : bool
            Also impose each block's exact peak frequency once the grid holds.
        ipopt : dict, optional
            IPOPT options (default the context's).
        lin : TimeRows, optional
            Linear rows imposed in every box.

        Returns
        -------
        SolveResult
            The best box's result, ``iterations`` summed.
        """
        ipopt = {**(ipopt or ctx.ipopt),
                 "max_iter": min(ctx.ipopt["max_iter"], RUN.free_max_iter)}
        best, x, iters, res, f = None, np.asarray(x0, float), 0, None, RUN.free_box
        first = (self.poles_first or self.over_poles) and self.poles_next()
        if first:       # the candidate's earlier solve needed the poles: over them first
            poles = self.in_pole_space(ctx, setup, x0, phase, exact, ipopt, lin)
            if poles is not None and poles.success:
                self.over_poles = True
                return poles
            iters += 0 if poles is None else poles.iterations
        for _ in range(RUN.free_boxes):
            c = x[:ctx.param.n_x]
            r = f * np.abs(c) + 0.05 * np.max(np.abs(c))
            res = solve_exchange(setup, x, ipopt, phase, self.templates, exact=exact, box=(c, r),
                                 max_rounds=RUN.free_exchange_rounds, lin=lin)
            iters += res.iterations
            cap = min(RUN.free_iter_budget, self.budget)
            if not res.success:
                if f <= RUN.free_box / 4 or iters > cap or (best is None and self.poles_next()):
                    break
                f /= 4
                continue
            gain = best is None or res.objective < best.objective - 1e-3 * abs(best.objective)
            best, x = res, res.x
            inside = np.all(np.abs(res.x[:ctx.param.n_x] - c) < 0.999 * r)
            if inside or not gain or iters > cap:
                break
            f = min(2 * f, 8 * RUN.free_box)
        if best is None and not first and self.poles_next():
            poles = self.in_pole_space(ctx, setup, x0, phase, exact, ipopt, lin)
            if poles is not None:
                iters += poles.iterations
                best = poles if poles.success else None
                self.over_poles = best is not None
        return replace(best if best is not None else res, iterations=iters)

    def in_pole_space(self, ctx: Context, setup: NLPSetup, x0: np.ndarray, phase: Phase,
                      exact: bool, ipopt: dict, lin: TimeRows | None = None
                      ) -> SolveResult | None:
        """The program solved over the nominal closed-loop poles and the Youla degrees
        (:class:`robrst.synthesis.template.MappedTemplate`) within ``RUN.pole_box`` of the
        start's point: where the trust region over the coefficients failed (IPOPT's iteration
        limit or a local infeasibility: a loop whose coefficients move a lightly damped
        pair far in one step), the poles move in steps of their own size and the nominal
        loop stays stable.  The grid, the rows, the exchange and the certificate are the
        coefficients' own.

        Parameters
        ----------
        ctx : Context
            The synthesis's context.
        setup : NLPSetup
            The program's data (freely placed poles).
        x0 : numpy.ndarray
            The start.
        phase : Phase
            The phase.
        exact : bool
            Exact peak exchange.
        ipopt : dict
            IPOPT options.
        lin : TimeRows, optional
            Linear rows imposed in every round.

        Returns
        -------
        SolveResult or None
            ``None`` when the space cannot be built or the start's nominal loop is unstable.
        """
        space = self.pole_space(ctx, setup)
        nx, x0 = ctx.param.n_x, np.asarray(x0, float)
        theta = None if space is None else space.point(x0[:nx])
        if theta is None:
            return None
        x = np.concatenate([space.controllers(theta[None])[0], x0[nx:]])
        maps = MappedTemplates(self.templates, space, np.clip(theta - RUN.pole_box, 0.0, 1.0),
                               np.clip(theta + RUN.pole_box, 0.0, 1.0),
                               chained=RUN.chained_derivatives)
        res = solve_exchange(setup, x, ipopt, phase, maps, exact=exact,
                             max_rounds=RUN.free_exchange_rounds, lin=lin)
        self.say(f"{phase.kind} phase over the poles: IPOPT {res.status} in {res.iterations} it,"
                 f" {res.exchange.rounds} exchange rounds")
        return res

    def poles_next(self) -> bool:
        """True when a failed trust region over the coefficients hands over to
        :meth:`in_pole_space` (a polish's run, the option on, the budget not spent).

        Returns
        -------
        bool
        """
        return self.pole_space is not None and RUN.pole_polish and not self.spent()

    def near_start(self, ctx: Context, setup: NLPSetup, starts: Sequence) -> Outcome | None:
        """The best start the exact certificate accepts among those near the specs on the
        grid (``worst <= RUN.near_start``): per kind of start, the boldest one by bisection.

        A spec a zero-gain loop meets exactly (the default damping floor is the plant's own
        least damping, the default ``Msd_rel_max`` its open-loop peak) puts every low-gain
        integral start at ``worst`` just above 1 on the grid, with the program's margin,
        while the certificate accepts it: without this no start is a fallback, and a run
        whose solves all fail answers far outside the specs although a plain integrator
        meets them.

        Parameters
        ----------
        ctx : Context
            The synthesis's context.
        setup : NLPSetup
            The program's data.
        starts : sequence of Start
            The scored starts (with freely placed poles every integral and PI seed of
            :func:`robrst.synthesis.starts.integral_seeds`, pure integrators included,
            joins them).

        Returns
        -------
        Outcome or None
            Certified, or ``None``.
        """
        every = list(starts)
        if setup.placement == "free":     # the integral seeds place no nominal poles
            blocks = grid_blocks(setup, np.ones(ctx.param.n_x))
            every += score_many(setup, blocks, [(n, x, None, None)
                                                for n, x in integral_seeds(ctx, pure=True)])
        near = [s for s in every if s.stable and s.worst <= RUN.near_start]
        kinds = {}
        for s in near:      # the families of starts: a kind over its crossover grid
            kinds.setdefault(s.name.split(" (")[0], []).append(s)

        def judged(s):
            """The start's outcome if the whole certificate accepts it (time-domain specs
            included, as the answer must), else ``None``."""
            out = self.outcome(ctx, setup, None, "start", x=ctx.full(s.xc, setup, s.wn, s.zeta))
            return out if out.certified and meets_time_specs(ctx.problem, out.ctrl) else None

        best = None
        for group in kinds.values():
            group.sort(key=lambda s: s.gain)
            low = judged(group[0])
            if low is None:
                continue
            # the boldest certified of the kind: bisection on the gain (a gentler start of
            # a kind the certificate accepts is accepted too, in the cases that matter)
            lo, hi = 0, len(group)
            while hi - lo > 1:
                mid = (lo + hi) // 2
                out = judged(group[mid])
                if out is not None:
                    lo, low = mid, out
                else:
                    hi = mid
            if best is None or objective_value(ctx.problem, low) > objective_value(
                    ctx.problem, best):
                best = low
        return best

    def outcome(self, ctx: Context, setup: NLPSetup, res: SolveResult, phase: str,
                x: np.ndarray | None = None) -> Outcome:
        """Certify the point ``x`` (default: the solve's) for the frequency-domain specs.

        Parameters
        ----------
        ctx : Context
            The synthesis's context.
        setup : NLPSetup
            The program's data.
        res : SolveResult
            The solve.
        phase : str
            ``"hard"``, ``"soft"`` or ``"start"``.
        x : numpy.ndarray, optional
            The point (default ``res.x``).

        Returns
        -------
        Outcome
        """
        x = res.x if x is None else x
        ctrl = ctx.controller(x)
        cert = frequency_certificate(ctx.problem, ctrl)
        if res is not None and self.rounds:
            self.rounds[-1] = replace(self.rounds[-1], violations=len(cert.violations))
        out = Outcome(ctrl=ctrl, cert=cert, res=res, phase=phase, placement=setup.placement,
                      x=np.asarray(x, float), setup=setup)
        p = ctx.problem
        lag = strip_note(p, ctrl) if cert.certified else None
        if lag:
            self.notes.append(f"a certified solve ended with {lag}")
        if cert.certified and not p.specs.time_domain and p.spread is None \
                and p.controller.T_mode != "reference_model":   # the whole certificate
            offer(objective_value(p, out), (p, ctrl, cert))      # if a signal stops the run
        return out

    def hard(self, ctx: Context, placement: str, x: np.ndarray, name: str,
             grid: tuple | None = None) -> Outcome | None:
        """The objective under hard specs from ``x``, certified, refined round by round.

        With freely placed poles, a first result the certificate refuses is solved again
        from ``x`` with each block's exact peak frequency in the exchange
        (``solve_exchange(exact=True)``), before any refinement.

        Parameters
        ----------
        ctx : Context
            The synthesis's context.
        placement : str
            The nominal pole placement.
        x : numpy.ndarray
            The start.
        name : str
            The start's name.
        grid : tuple, optional
            ``(models, nu)`` to start from (an earlier outcome's :attr:`Outcome.grid`);
            default the problem's models on the context's grid.

        Returns
        -------
        Outcome or None
            The last outcome (``None`` if IPOPT failed in the first round), with the
            rounds' grid.
        """
        p = ctx.problem
        # a copy of the grid's models: refine() appends to the list it is given
        models, nu = (program_models(p), ctx.nu) if grid is None else (list(grid[0]), grid[1])
        last = refined = None
        x = np.concatenate([x[:-1], [1.0]])
        exact, start = False, name
        for rnd in range(p.solver.max_rounds):
            if rnd and self.spent(placement):
                self.notes.append(f"iteration budget ({self.budget}) spent: refinement stopped")
                break
            setup = ctx.setup(models, nu, placement)
            res = self.solve(ctx, setup, x, Phase("hard"), start, exact=exact)
            if not res.success and rnd > 0:   # the refined program: back to the specs first
                x0 = np.concatenate([x[:-1], [max(last.badness, 1.0) * 1.02]])
                soft = self.solve(ctx, setup, x0, Phase("soft", RUN.gamma_floor),
                                  "previous round")
                if soft.success and soft.x[-1] <= 1.0:
                    res = self.solve(ctx, setup, soft.x, Phase("hard"), "soft-goal point",
                                     exact=exact)
                    if not res.success:
                        res = soft
            if not res.success:
                self.notes.append(f"objective phase ({placement} poles, from {name}) ended with"
                                  f" IPOPT {res.status}")
                if res.x is not None and np.all(np.isfinite(res.x)) and (
                        last is None or not last.certified):
                    # the last iterate may still be a better controller: the certificate
                    # judges it (an answer, not an optimum: phase "start")
                    it = self.outcome(ctx, setup, res, "start")
                    if it.certified or last is None:
                        last = it
                break
            last = self.outcome(ctx, setup, res, "hard")
            if last.certified:
                break
            if placement == "free" and not exact:
                # freely placed poles put closed-loop resonances between grid points, where
                # the certificate finds peaks far above the specs at every temperature (the
                # refined program from there may not be solved within the budget): the same
                # program again from the same start, the exchange adding each block's
                # exact peak frequency (and so in the rounds after it)
                exact = True
                continue
            x, start = res.x, "previous round"
            models, nu = refine(p, last.cert, models, nu)
            refined = last
        if last is None:
            return None
        if not last.certified and refined is not last:   # stopped before its refinement
            models, nu = refine(p, last.cert, models, nu)
        return replace(last, grid=(models, nu))

    def _from_warm(self, ctx, setup, placement, warm):
        """Soft goals, then the objective, from the previous design ``warm`` (a scored
        start): in a fleet design's next round the actuators just added move the specs a
        little, and the boldest start that already meets them may lead to a far worse
        local optimum.  Returns the certified outcome of the objective, else the soft-goal
        point (``None`` if nothing was solved)."""
        if warm.worst > RUN.far_start or self.spent(placement):
            return None
        x0 = ctx.full(warm.xc, setup, warm.wn, warm.zeta,
                      gamma=max(warm.worst * 1.02, RUN.gamma_floor) if warm.stable else
                      max(warm.worst, 1.0) * 2)
        res = self.solve(ctx, setup, x0, Phase("soft", RUN.gamma_floor), WARM_START)
        soft = self.outcome(ctx, setup, res, "soft")
        if not (res.success and res.x[-1] <= 1.0):
            return soft
        out = self.hard(ctx, placement, res.x, f"soft-goal point from {WARM_START}")
        return out if out is not None and (out.certified or not soft.certified) else soft

    def bolder(self, ctx: Context, setup: NLPSetup, placement: str, starts: Sequence,
               out: Outcome) -> Outcome | None:
        """A start beyond the certified ``out`` (a larger integral gain, not meeting the
        specs on the grid, the nearest to them): brought to the specs by the soft phase,
        then the objective (free placement only).  A
        higher-gain basin the boldest feasible start does not reach (a loop that damps a
        resonance actively crosses over near it).  ``None`` when the
        objective is not the integral gain, nothing is bolder or the budget is spent.

        Parameters
        ----------
        ctx : Context
            The problem's context.
        setup : NLPSetup
            The program on the family's models.
        placement : str
            The placement.
        starts : sequence of Start
            The scored starts.
        out : Outcome
            The certified outcome to beat.

        Returns
        -------
        Outcome or None
        """
        if (ctx.problem.solver.objective != "max_integral_gain" or placement != "free"
                or self.spent(placement) or self.hopeless):
            return None
        ki = objective_value(ctx.problem, out)
        cands = []
        for s in starts:
            if not s.stable or s.worst <= RUN.gamma_floor or s.worst > RUN.bold_far:
                continue
            k = abs(integral_gain(ctx.controller(ctx.full(s.xc, setup, s.wn, s.zeta))))
            if np.isfinite(k) and k > ki * (1 + 1e-3):
                cands.append((s.worst, s))
        if not cands:
            return None
        s = min(cands, key=lambda c: c[0])[1]
        x0 = ctx.full(s.xc, setup, s.wn, s.zeta, gamma=max(s.worst * 1.02, RUN.gamma_floor))
        res = self.solve(ctx, setup, x0, Phase("soft", RUN.gamma_floor), s.name)
        if not (res.success and res.x[-1] <= 1.0):
            return None
        return self.hard(ctx, placement, res.x, f"soft-goal point from {s.name}")

    def attempt(self, ctx: Context, placement: str, seeds: Sequence[tuple],
                soft: bool = True) -> Outcome | None:
        """Hard phase from the preferred start; if that fails, soft phase then hard phase.

        A previous design of a nearby variant (``warm``) within ``RUN.warm_near`` of the specs
        on the grid is solved from first, before the other starts are scored; when that
        does not certify, or otherwise, the preferred start is the best one when it already
        meets the specs on the grid, else a seed handed down, else the analytic design at
        the problem's poles.

        Parameters
        ----------
        ctx : Context
            The synthesis's context.
        placement : str
            The nominal pole placement.
        seeds : sequence of tuple
            Starts handed down (the homotopy's lower degree, a fixed placement's result).
        soft : bool
            Run the soft-goal phase when the preferred start does not meet the specs (off:
            the global phase follows and searches further).

        Returns
        -------
        Outcome or None
            The best certified outcome, else the least violating one (``None``: nothing
            solved).
        """
        setup = ctx.setup(program_models(ctx.problem), ctx.nu, placement)
        blocks = grid_blocks(setup, np.ones(ctx.param.n_x))   # weights unused by the scores
        warm = next((sd for sd in seeds if sd[0] == WARM_START and sd[1] is not None), None)
        from_warm = None     # the hard phase from the warm start, once run
        if warm is not None and not self.spent(placement):
            # a previous design of a nearby variant near the specs on the grid is the
            # preferred start: solved from at once, the other starts scored only if it fails
            s = score(setup, blocks, *warm)
            if ctx.problem.scenarios:     # a fleet design's next round: from the previous
                out = self._from_warm(ctx, setup, placement, s)     # design, soft goals first
                if out is not None:
                    # certified, or not: the actuators just added are then out of reach
                    # near the previous design, and the round ends (the exchange over
                    # actuators discards one and tries again)
                    return out
            elif s.stable and s.worst <= RUN.warm_near:
                from_warm = self.hard(ctx, placement, ctx.full(s.xc, setup, s.wn, s.zeta),
                                      s.name)
                if from_warm is not None and from_warm.certified:
                    return from_warm
        convex = ctx.problem.solver.init == "convex" and placement == "fixed"
        starts = candidates(ctx, setup, blocks, seeds, convex=convex)
        if not starts:
            return None
        named = {s.name: s for s in starts}
        ok = [s for s in starts if s.stable and s.worst <= RUN.gamma_floor]
        if ctx.problem.solver.objective == "min_Ms":   # the most robust feasible start
            first = min(ok, key=lambda s: s.worst) if ok else starts[0]
        else:                                           # the boldest feasible start
            first = max(ok, key=lambda s: s.gain) if ok else starts[0]
        feasible = first.stable and first.worst <= RUN.gamma_floor
        if not feasible or convex:
            prefer = "convex (nominal SOCP)" if convex else "analytic"
            first = next((named[sd[0]] for sd in seeds if sd[0] in named),
                         named.get(prefer, named.get("analytic", starts[0])))
            feasible = first.stable and first.worst <= RUN.gamma_floor
        outs = []
        if feasible:   # a start that meets the specs on the grid: certified, it is the fallback
            outs.append(self.outcome(ctx, setup, None, "start",
                                     x=ctx.full(first.xc, setup, first.wn, first.zeta)))
        if not (outs and outs[0].certified):
            near = self.near_start(ctx, setup, starts)
            if near is not None:
                if ctx.problem.solver.objective == "feasibility":
                    return near     # certified: the question is answered
                outs.append(near)
        if first.worst <= RUN.far_start and not self.spent(placement) and not self.hopeless:
            out = from_warm if from_warm is not None and first.name == WARM_START else \
                self.hard(ctx, placement, ctx.full(first.xc, setup, first.wn, first.zeta),
                          first.name)
            if out is not None and out.certified:
                # a PI zero on the slowest plant pole may be the boldest start and still end
                # at a worse local optimum: the boldest start of the other kinds is solved too
                other = [s for s in ok if ON_SLOW_POLE not in s.name]
                if ON_SLOW_POLE in first.name and other:
                    alt = max(other, key=lambda s: s.gain)
                    outs.append(self.hard(ctx, placement,
                                          ctx.full(alt.xc, setup, alt.wn, alt.zeta), alt.name))
                outs.append(self.bolder(ctx, setup, placement, starts, out))
                return _better(ctx.problem, out, outs)
            outs.append(out)
        n_soft = 1 if self.hopeless else RUN.soft_starts   # the best violation is all there is
        n_soft = n_soft if soft else 0
        for s in [s for s in starts if not (s is first and feasible)][:n_soft]:
            if self.spent(placement) and (self.strict or any(o is not None and o.certified
                                                             for o in outs)):
                break
            x0 = ctx.full(s.xc, setup, s.wn, s.zeta,
                          gamma=max(s.worst * 1.02, RUN.gamma_floor))
            if s.stable and s.worst <= RUN.gamma_floor:    # meets the specs: no soft phase
                soft, name = self.outcome(ctx, setup, None, "start", x=x0), s.name
            else:
                if not s.stable:
                    x0[-1] = max(s.worst, 1.0) * 2
                res = self.solve(ctx, setup, x0, Phase("soft", RUN.gamma_floor), s.name)
                soft = self.outcome(ctx, setup, res, "soft")
                name = f"soft-goal point from {s.name}"
                if not (res.success and res.x[-1] <= 1.0):
                    outs.append(soft)
                    continue
            out = self.hard(ctx, placement, soft.x, name)
            if out is not None and out.certified:
                return _better(ctx.problem, out, outs)
            outs += [out, soft]
        outs = [o for o in outs if o is not None]
        if not feasible and not any(o.certified for o in outs):
            # nothing certified: the preferred start, certified for what it achieves, answers
            # when nothing was solved or when it is clearly better (a soft phase cut short
            # may end farther from the specs); a solved point keeps its multipliers
            start = self.outcome(ctx, setup, None, "start",
                                 x=ctx.full(first.xc, setup, first.wn, first.zeta))
            if not outs or start.badness < (1 - 1e-6) * min(o.badness for o in outs):
                outs.append(start)
        certified = [o for o in outs if o.certified]
        if certified:
            self.notes.append("the objective could not be improved under the specs; returning"
                              " the best certified start or soft-goal point")
            return max(certified, key=lambda o: objective_value(ctx.problem, o))
        return min(outs, key=lambda o: o.badness)
