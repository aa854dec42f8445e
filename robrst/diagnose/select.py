"""Candidates and forward selection: which effects, together, explain the held-out gap.

1. ``linear``: the linear corrections alone (the user's model re-fitted, regularised).
2. Every excited effect alone on the user's model (linear part as given), and the
   dynamic form of hysteresis when the records allow it.  These are screening fits
   (early stopping, at most ``SCREEN_SAMPLES`` samples per training record — whole
   records for the thermal effects, which follow the whole temperature history); every
   candidate is scored on the whole test records.
3. Forward selection from the linear re-fit: the best remaining candidates (the two
   best from the second step on) are re-fitted *jointly* with the effects already
   selected and the linear corrections; the better is kept if it removes at least
   ``MIN_SHRINK`` of the excess held-out gap (gap above the noise floor) left so far
   and beats the current state by ``MARGIN``; the next candidates (``MAX_TRIES`` in
   all) are tried when none is; repeat.  A candidate qualifies when its screening fit
   improves on the model *as given* by ``PROMISING``, on the training or the held-out
   records — not on the linear re-fit: an effect masked by another effect or by a
   wrong linear model looks poor alone and only shows once fitted with them.

4. After every selection the remaining candidates are *re-screened* on top of the model
   selected so far (its effects and linear corrections held as the start, each candidate's
   parameters added; a screening fit): an effect hidden behind a larger one (creep behind
   saturation) only improves once that one is in.  A re-screened candidate qualifies when
   it improves on the current model by ``PROMISING``; it joins the candidates still
   waiting, and all are ranked by their re-screened gaps.

A constant output offset (``output_offset``: a sensor zero, one constant per output) is a
candidate like the effects: screened alone on the model as given, fitted jointly with the
others, selected only when it passes the same bars.

Every gap is measured on the test records, every fit uses the training records only.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

from robrst.diagnose import signals
from robrst.diagnose.effects import INPUT_EFFECTS, THERMAL, Chain
from robrst.diagnose.fit import fit_model
from robrst.diagnose.polish import polish_residues
from robrst.diagnose.thermal import fit_thermal_dynamics

__all__ = ["Setup", "Scored", "candidates", "forward", "excess", "significant",
           "linear_with_offset", "MIN_SHRINK", "MARGIN", "MAX_EFFECTS", "OFFSET"]

OFFSET = "output_offset"  # the constant output offset's candidate name

MIN_SHRINK = 0.3         # an explanation must remove >= 30 % of the excess gap it faces
MARGIN = 1.1             # ... and beat the alternative by 10 % in held-out gap
MAX_EFFECTS = 3
MAX_TRIES = 3            # joint fits tried per step until one is significant
FINAL_NFEV = 150         # an unconverged joint fit is run on up to this many evaluations
PROMISING = 0.97         # an effect alone must improve on the model as given by 3 %
SCREEN_NFEV = 25         # single candidates are screening fits: early stopping
SCREEN_FTOL = 1e-6
SCREEN_SAMPLES = 100_000  # ... on at most the first 100 000 samples of each training record


@dataclass(frozen=True, eq=False)
class Setup:
    """Everything the candidate fits share (built once per diagnosis).

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    ref : float
        The model's temperature [°C].
    train : list of Prepared
        Period-averaged training records (fitting).
    train_full : list of Prepared
        Full training records (training gap).
    test : list of Prepared
        Full test records (held-out gap).
    test_records : list of Dataset
        Test records (held-out gap normalisation).
    train_records : list of Dataset
        Training records.
    lin : LinearPart
        The user's model's corrections.
    lin_modal : LinearPart
        With per-mode gains (dynamic form of hysteresis).
    stats : dict
        Scales of the training data.
    noise_sigma : float
        Pooled noise level [µm].
    plant : Plant or None
        SISO Plant of the user's model (thermal_dynamics).
    effects : tuple of str
        Excited effects to try.
    dynamic : bool
        The dynamic form of hysteresis is possible.
    delays : tuple of int
        Searched delay per input.
    saturation : list
        Starting limits per input.
    floor : float
        The noise floor.
    gap_before : float
        Held-out gap of the model as given.
    gap_before_train : float
        Its training gap.
    workers : int
        Threads for the candidate fits.
    """

    fs: float
    ref: float
    train: list            # Prepared, period-averaged (fitting)
    train_full: list       # Prepared, full records (training gap)
    test: list             # Prepared, full records (held-out gap)
    test_records: list     # Dataset (held-out gap normalisation)
    train_records: list
    lin: object            # LinearPart
    lin_modal: object      # LinearPart with per-mode gains (dynamic form of hysteresis)
    stats: dict
    noise_sigma: float
    plant: object          # SISO Plant of the user's model (thermal_dynamics) or None
    effects: tuple         # excited effects to try
    dynamic: bool          # the dynamic form of hysteresis is possible
    delays: tuple
    saturation: list       # starting limits per input
    floor: float
    gap_before: float      # held-out gap of the model as given
    gap_before_train: float  # ... and its training gap
    workers: int = 2


@dataclass(frozen=True, eq=False)
class Scored:
    """A fitted candidate and its gaps (held-out and training).

    Parameters
    ----------
    name : str
        The candidate.
    fit : Fitted or ThermalFit
        Its fit.
    gap : float
        Held-out NRMSE.
    train_gap : float
        Training NRMSE.
    residuals : list of numpy.ndarray
        Held-out residuals per test record.
    fit_s : float
        Wall time of the fit [s].
    converged : bool
        The solver stopped before its evaluation limit.

    Attributes
    ----------
    effects : tuple of str
        The fit's effects.
    """

    name: str
    fit: object
    gap: float
    train_gap: float
    residuals: list        # held-out residuals per test record
    fit_s: float
    converged: bool = True  # the solver stopped before its evaluation limit

    @property
    def effects(self):
        return tuple(self.fit.effects) + (("hysteresis",) if self.fit.form == "dynamic" else ())


def excess(g: float, floor: float) -> float:
    """Gap above the noise floor: ``sqrt(max(g^2 - floor^2, 0))``.

    Parameters
    ----------
    g : float
        A gap.
    floor : float
        The noise floor.

    Returns
    -------
    float

    Examples
    --------
    >>> from robrst.diagnose.select import excess
    >>> excess(0.5, 0.3)
    0.4
    """
    return math.sqrt(max(g * g - floor * floor, 0.0))


def significant(new: float, old: float, floor: float) -> bool:
    """Does a gap ``new`` explain enough of ``old`` (the 30 % bar and the margin)?

    Parameters
    ----------
    new, old : float
        Gaps with and without the candidate.
    floor : float
        The noise floor.

    Returns
    -------
    bool
    """
    return excess(new, floor) <= (1 - MIN_SHRINK) * excess(old, floor) and new * MARGIN <= old


def score(setup, fit, t0):
    res_te = [p.Y - fit.predict_prepared(p) for p in setup.test]
    res_tr = [p.Y - fit.predict_prepared(p) for p in setup.train_full]
    return Scored(name=fit.name, fit=fit, gap=signals.nrmse(setup.test_records, res_te),
                  train_gap=signals.nrmse(setup.train_records, res_tr), residuals=res_te,
                  fit_s=time.perf_counter() - t0)


def _chain(setup, effects):
    ch = Chain(effects, setup.lin.model.n_in, setup.fs, setup.ref, setup.stats, setup.delays)
    ch.start_saturation(setup.saturation)
    return ch


def _screen(records, n):
    """The first ``n`` samples of each from-rest record (periodic ones are one period)."""
    return [p if p.periodic or len(p.U) <= n else replace(
        p, U=p.U[:n], Y=p.Y[:n], temp=p.temp[:n]) for p in records]


def _fit(setup, name, effects, joint, dynamic=False, start=None, theta=None, max_nfev=40,
         ftol=1e-8, screen=False, offset=False):
    t0 = time.perf_counter()
    train = _screen(setup.train, SCREEN_SAMPLES) if screen else setup.train
    lin = setup.lin_modal if dynamic else setup.lin
    fit = fit_model(name, effects, train, lin, _chain(setup, effects),
                    setup.noise_sigma, joint=joint, dynamic=dynamic, start=start, theta=theta,
                    max_nfev=max_nfev, ftol=ftol, offset=offset)
    if dynamic:
        fit = polish_residues(fit, train, setup.noise_sigma)
    return replace(score(setup, fit, t0), converged=fit.n_eval < max_nfev)


def _start(scored):
    """Parameter values of a fit by name (chain, linear corrections, slopes)."""
    if scored is None or not hasattr(scored.fit, "chain"):
        return {}
    f = scored.fit
    z, th, s = f.parts()
    out = dict(zip(f.lin.names, th))
    out.update(zip(f.chain.names, z))   # "gain" of hysteresis wins: the linear one is pinned
    out.update({f"slope{i}": v for i, v in zip(f.slopes, s)})
    if f.n_offset:
        out.update({f"offset{j}": v for j, v in enumerate(f.output_offset())})
    return out


def candidates(setup: Setup, say: Callable[[str], None]) -> tuple[Scored, dict[str, Scored]]:
    """The linear re-fit and every single candidate; returns (linear, {name: Scored}).

    All fits run in ``setup.workers`` threads, the longest first; the linear re-fit
    runs first on its own only when the dynamic form of hysteresis starts from it.

    Parameters
    ----------
    setup : Setup
        The shared data.
    say : callable
        Progress: one line of text per fit.

    Returns
    -------
    linear : Scored
    singles : dict
        ``{name: Scored}``.
    """
    def linear():
        return _fit(setup, "linear", (), joint=True)

    lin = linear() if setup.dynamic else None
    for e in setup.effects:          # build (and compile) every stage before any thread runs
        if e in INPUT_EFFECTS:
            _chain(setup, (e,))
    # thermal effects follow the whole temperature history: screened on whole records
    jobs = {e: (lambda e=e: _fit(setup, e, (e,), joint=False, max_nfev=SCREEN_NFEV,
                                 ftol=SCREEN_FTOL, screen=e not in THERMAL))
            for e in setup.effects if e in INPUT_EFFECTS}
    if "thermal_dynamics" in setup.effects:
        def thermal():
            t0 = time.perf_counter()
            return score(setup, fit_thermal_dynamics(setup.train, setup.plant, setup.fs,
                                                     setup.ref), t0)
        jobs["thermal_dynamics"] = thermal
    jobs[OFFSET] = lambda: _fit(setup, OFFSET, (), joint=False, offset=True,
                                max_nfev=SCREEN_NFEV, ftol=SCREEN_FTOL)
    if setup.dynamic:
        jobs["hysteresis:dynamic"] = lambda: _fit(setup, "hysteresis", (), joint=True,
                                                  dynamic=True, start=_start(lin))
    else:
        jobs["linear"] = linear
    keys = sorted(jobs, key=lambda k: k not in THERMAL)   # the longest fits start first
    out = dict(zip(keys, _run([jobs[k] for k in keys], setup.workers)))
    lin = out.pop("linear", lin)
    say(f"linear re-fit: held-out gap {lin.gap:.4g} ({lin.fit.n_eval} evaluations,"
        f" {lin.fit_s:.1f} s)")
    for k, sc in sorted(out.items(), key=lambda kv: kv[1].gap):
        say(f"  {k:<20} alone: held-out gap {sc.gap:.4g} (training {sc.train_gap:.4g};"
            f" {sc.fit.n_eval} evaluations, {sc.fit_s:.1f} s)")
    return lin, out


def _offset_of(state):
    """Does the fit ``state`` (Scored) carry an output offset?"""
    return state.name != "linear" and getattr(state.fit, "n_offset", 0) > 0


def _grown(state, key):
    """Effects, dynamic form, offset and name of ``state`` plus candidate ``key``."""
    effects = tuple(e for e in (state.fit.effects if state.name != "linear" else ())) + (
        () if key in ("hysteresis:dynamic", OFFSET) else (key,))
    dynamic = key == "hysteresis:dynamic" or getattr(state.fit, "form", "") == "dynamic"
    offset = key == OFFSET or _offset_of(state)
    name = "+".join(sorted(set(effects) | ({"hysteresis"} if dynamic else set())
                           | ({OFFSET} if offset else set())))
    return effects, dynamic, offset, name


def linear_with_offset(setup: Setup) -> Scored:
    """The linear re-fit with a constant output offset, fitted jointly.

    Parameters
    ----------
    setup : Setup
        The shared data.

    Returns
    -------
    Scored
    """
    return _fit(setup, f"linear+{OFFSET}", (), joint=True, offset=True)


def _combine(setup, state, key, single, on_top=False):
    """``state`` (Scored) plus candidate ``key`` (its single fit ``single``), jointly.

    A single candidate that already brings the held-out gap to the noise level needs no
    joint re-fit (the linear part stays the user's).  ``on_top``: ``single`` was
    re-screened on top of ``state`` (its values start the joint fit).
    """
    if key == "thermal_dynamics" or (state.name == "linear"
                                     and single.gap <= 1.25 * setup.floor):
        return single
    effects, dynamic, offset, name = _grown(state, key)
    kept = _start(state) if state.name != "linear" else {}
    starts = [{**kept, **_start(single)} if on_top else {**_start(single), **kept}]
    if state.name != "linear":
        # the fits so far may have absorbed the new effect (each effect alone mimics
        # the others): also start every effect from its default, keep the better fit
        starts.append({k: v for k, v in kept.items() if k in setup.lin.names})
    jobs = [lambda st=st: _fit(setup, name, effects, joint=True, dynamic=dynamic, start=st,
                               offset=offset)
            for st in starts]
    best = min(_run(jobs, setup.workers), key=lambda sc: sc.train_gap)
    # run on only a fit that is getting somewhere (fits the training records better)
    return _converge(setup, best) if best.train_gap < state.train_gap else best


def _run(jobs, workers):
    """Results of the callables ``jobs`` (in order), in ``workers`` threads."""
    if workers <= 1 or len(jobs) == 1:
        return [f() for f in jobs]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return [fut.result() for fut in [pool.submit(f) for f in jobs]]


def forward(setup: Setup, lin: Scored, singles: dict[str, Scored],
            say: Callable[[str], None]) -> tuple[list, tuple | None]:
    """Forward selection (see the module docstring).

    Parameters
    ----------
    setup : Setup
        The shared data.
    lin : Scored
        The linear re-fit.
    singles : dict
        Every single candidate.
    say : callable
        Progress.

    Returns
    -------
    steps : list of (key, before, Scored)
        The selections in order.
    tie : tuple or None
        Two candidates that explain the gap equally well and do not add up.
    """
    state, steps, tie = lin, [], None
    g0, t0 = setup.gap_before, setup.gap_before_train
    pool = {k: s for k, s in singles.items()
            if s.gap <= PROMISING * g0 or s.train_gap <= PROMISING * t0}
    ref = (g0, t0)
    rank = lambda k: pool[k].gap / ref[0] + pool[k].train_gap / ref[1]  # noqa: E731
    while len(steps) < MAX_EFFECTS and state.name != "thermal_dynamics":
        if state.gap <= 1.25 * setup.floor:
            break
        if steps:          # re-screen what is left on top of the model selected so far
            pool, ref = _rescreen(setup, state, singles, pool, steps, say), (
                state.gap, state.train_gap)
        order = [k for k in sorted(pool, key=rank) if not steps or k != "thermal_dynamics"]
        if not order:
            break
        two = len(order) > 1 and (steps or pool[order[1]].gap <= 2 * pool[order[0]].gap)
        tried = []
        for k in order[:MAX_TRIES]:
            tried.append((k, _combine(setup, state, k, pool[k], on_top=bool(steps))))
            if len(tried) >= (2 if two else 1) and any(
                    significant(sc.gap, state.gap, setup.floor) for _, sc in tried):
                break
        tried.sort(key=lambda kv: kv[1].gap)
        for k, sc in tried:
            how = "joint fit, " if getattr(sc.fit, "joint", False) else ""
            say(f"  + {k:<18} held-out gap {state.gap:.4g} -> {sc.gap:.4g} ({how}"
                f"{sc.fit.n_eval} evaluations, {sc.fit_s:.1f} s)")
        if not tried or not significant(tried[0][1].gap, state.gap, setup.floor):
            break
        k, best = tried[0]
        if not steps and len(tried) > 1:
            k2, other = tried[1]
            if significant(other.gap, state.gap, setup.floor) and best.gap * MARGIN >= other.gap:
                both = _combine(setup, best, k2, pool[k2])
                if significant(both.gap, best.gap, setup.floor):
                    steps += [(k, state.gap, best), (k2, best.gap, both)]
                    state = both
                    continue
                tie = (k, k2, best.gap, other.gap)
                break
        steps.append((k, state.gap, best))
        state = best
    return steps, tie


def _rescreen(setup, state, singles, pool, steps, say):
    """The candidates not yet selected, each screened on top of ``state``: ``{key: Scored}``.

    Every excited candidate is re-fitted with the selected model's effects (started at
    their values) and its linear corrections held; it qualifies when it improves on
    ``state`` by ``PROMISING`` (held-out or training gap).  The candidates that were
    already waiting stay (with their re-screened scores) even when they do not.
    """
    chosen = {k for k, _, _ in steps}
    keys = [k for k in singles if k not in chosen and k not in (
        "thermal_dynamics", "hysteresis:dynamic") and not (k == OFFSET and _offset_of(state))
        and not (k == "hysteresis" and "hysteresis" in state.effects)]
    theta = state.fit.parts()[1]

    def job(k):
        effects, dynamic, offset, name = _grown(state, k)
        return _fit(setup, name, effects, joint=False, dynamic=dynamic, theta=theta,
                    start={**_start(singles[k]), **_start(state)}, max_nfev=SCREEN_NFEV,
                    ftol=SCREEN_FTOL, screen=k not in THERMAL, offset=offset)

    out = {}
    for k, sc in zip(keys, _run([lambda k=k: job(k) for k in keys], setup.workers)):
        good = sc.gap <= PROMISING * state.gap or sc.train_gap <= PROMISING * state.train_gap
        say(f"  {k:<20} on top of {state.name}: held-out gap {state.gap:.4g} -> {sc.gap:.4g}"
            f" (training {state.train_gap:.4g} -> {sc.train_gap:.4g}; {sc.fit.n_eval}"
            f" evaluations, {sc.fit_s:.1f} s){'' if good else ', no improvement'}")
        if good or k in pool:
            out[k] = sc
    if "hysteresis:dynamic" in pool and "hysteresis" not in state.effects:
        out["hysteresis:dynamic"] = pool["hysteresis:dynamic"]
    return out


def _converge(setup, sc):
    """``sc`` re-fitted to convergence (up to ``FINAL_NFEV`` evaluations) if it stopped early.

    A joint fit that used all its evaluations is inconclusive (several effects fitted
    together converge slowly): it is run on from where it stopped.  Kept if it fits the
    training records at least as well (the held-out gap is only measured, never used).
    """
    f = sc.fit
    if sc.converged or not hasattr(f, "chain"):
        return sc
    more = _fit(setup, sc.name, f.effects, joint=f.joint, dynamic=f.form == "dynamic",
                start=_start(sc), max_nfev=FINAL_NFEV, offset=f.n_offset > 0)
    return more if more.train_gap <= sc.train_gap else sc
