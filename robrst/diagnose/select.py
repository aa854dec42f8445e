"""Which candidates, together, explain the held-out gap: screen, fit, credit, compare.

1. ``linear``: the linear corrections alone (the user's model re-fitted, regularised).
2. Screening (:mod:`robrst.diagnose.screen`): every excited candidate scored by an exact
   linear least-squares fit on precomputed columns, linearised about the user's model
   and about the linear re-fit (the better of the two, on the training records).
3. Forward selection: at each step the candidates whose screen improves on the current
   set by ``promising`` (held-out or training gap) are ranked, the best ``refine_top``
   are fitted by their own nonlinear models *jointly* with the set so far and the linear
   corrections (:func:`robrst.diagnose.fit.fit_model`, or the standalone fits of
   ``thermal_dynamics`` and ``stiffness_nonlinearity``), and the best is kept if it
   removes ``min_shrink`` of the excess held-out gap and beats the current set by
   ``margin`` (:func:`significant`; the constants live in :mod:`robrst.diagnose.options`).  A set's fit starts at the values of the set before
   it; when the best one's training gap stays ``short_of_screen`` times above its screen,
   it is fitted again from the screens' starts (not from the smaller set's values: an
   effect fitted alone can stretch to stand in for the one still missing, e.g. creep's
   growth with temperature for a thermal drift, and the joint fit cannot leave that
   minimum) and the one that fits the training records better is kept.
4. Credit by removal: every selected effect is removed from the joint fit in turn (the
   others re-fitted); an effect whose removal costs less than the same bar is no cause
   and is dropped (the set re-fitted without it).
5. Alternatives: for every effect left, the best candidate that could stand in its place
   (by the screen) is fitted in its place; when it explains the held-out gap as well
   (neither is significantly better), the two are a tie.

Forms of one effect are not alternatives: ``hysteresis`` is fitted as Bouc–Wen and as
Prandtl–Ishlinskii and the better form is kept.  A constant output offset (``output_offset``)
is the constant of a static output nonlinearity: with ``output_nonlinearity`` in a set it
is not a separate cause.

Every gap is measured on the test records, every fit uses the training records only.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from robrst.diagnose import signals
from robrst.diagnose.effects import Chain
from robrst.diagnose.fit import fit_by_level, fit_model
from robrst.diagnose.options import OPTIONS
from robrst.diagnose.polish import polish_residues
from robrst.diagnose.screen import build_screen
from robrst.diagnose.stiffness import fit_stiffness
from robrst.diagnose.thermal import fit_thermal_dynamics, search_saturation

if TYPE_CHECKING:
    from robrst.diagnose.fit import Prepared

__all__ = ["Setup", "Scored", "Explanation", "explain", "excess", "significant",
           "linear_with_offset", "refit_keys", "OFFSET", "DYNAMIC", "STANDALONE"]

OFFSET = "output_offset"  # the constant output offset's candidate name
LONG = ("thermal_drift", "thermal_dynamics")   # follow the whole temperature history
DYNAMIC = "amplitude_dependent_dynamics"
STANDALONE = ("thermal_dynamics", "stiffness_nonlinearity")   # fitted alone, not combined
CHAIN = ("delay", "input_nonlinearity", "saturation", "slew", "creep", "thermal_drift")
# special cases of a more general candidate: fitted with it, and named when not worse
SPECIAL = {"input_nonlinearity": ("saturation",), "output_nonlinearity": ("output_offset",)}
_SEL, _FIT = OPTIONS.select, OPTIONS.fit



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
    stages : dict
        Compiled effect stages of this diagnosis (built once, shared).
    pinned, pinned_modal : tuple of int
        Corrections of ``lin`` / ``lin_modal`` the training records do not excite (held).
    train_cut, test_cut : list of Prepared, optional
        The records cut to ``cut_samples`` (from-rest ones) for screens and fits.
    """

    fs: float
    ref: float
    train: list            # Prepared, period-averaged (fitting)
    train_full: list       # Prepared, full records (training gap)
    test: list             # Prepared, full records (held-out gap)
    test_records: list     # Dataset (held-out gap normalisation)
    train_records: list
    lin: object            # LinearPart
    lin_modal: object      # LinearPart with per-mode gains (amplitude-dependent dynamics)
    stats: dict
    noise_sigma: float
    plant: object          # SISO Plant of the user's model (standalone fits) or None
    effects: tuple         # excited candidates to try
    dynamic: bool          # the amplitude-dependent dynamics can be fitted
    delays: tuple
    saturation: list       # starting limits per input (unused: found by the screen)
    floor: float
    gap_before: float      # held-out gap of the model as given
    gap_before_train: float  # ... and its training gap
    workers: int = 2
    stages: dict = field(default_factory=dict)   # compiled effect stages of this diagnosis
    pinned: tuple = ()         # corrections of lin the training records do not excite
    pinned_modal: tuple = ()   # ... of lin_modal
    train_cut: list = None     # Prepared, from-rest records cut to cut_samples (fits)
    test_cut: list = None      # ... (screens)


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
    keys : tuple of str
        The candidates it holds.
    form : str
        Of hysteresis: ``"input"`` (Bouc–Wen) or ``"prandtl_ishlinskii"``.

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
    keys: tuple = ()        # the candidates it holds
    form: str = "input"     # hysteresis: "input" (Bouc–Wen) or "prandtl_ishlinskii"

    @property
    def effects(self) -> tuple:
        """The candidates it holds."""
        return self.keys


@dataclass(frozen=True)
class Screened:
    """A candidate scored by the screen only (no nonlinear fit).

    Parameters
    ----------
    name : str
        The candidate.
    gap, train_gap : float
        Held-out and training NRMSE of its screen (on the screened samples).
    params : dict
        The screen's coefficients by column name.
    fit_s : float
        Wall time [s].
    """

    name: str
    gap: float
    train_gap: float
    params: dict
    fit_s: float = 0.0


@dataclass(frozen=True, eq=False)
class Explanation:
    """What :func:`explain` found (see the module doc).

    Parameters
    ----------
    linear : Scored
        The linear re-fit.
    singles : dict
        ``{key: Scored or Screened}``: every candidate alone (fitted when it was, else
        its screen).
    steps : list
        ``[(key, gap before, Scored)]`` in the order selected (credited effects only).
    removal : dict
        ``{key: held-out gap of the final set without it}``.
    dropped : list
        ``[(key, gap with, gap without)]``: selected, credited nothing, removed.
    tie : tuple, optional
        ``(key, alternative, gap, gap of the alternative)`` when neither is better.
    alternatives : dict
        ``{key: (alternative, Scored)}``: the best other candidate of the same step.
    screen_rank : list
        ``[(key, screened held-out gap)]``, best first.
    """

    linear: Scored
    singles: dict          # key -> Scored (fitted alone) or Screened
    steps: list            # [(key, gap before, Scored)] in the order selected
    removal: dict          # key -> held-out gap of the final set without it
    dropped: list          # [(key, gap with, gap without)]: credited nothing, removed
    tie: tuple = None      # (key, alternative, gap, gap of the alternative)
    alternatives: dict = field(default_factory=dict)   # key -> (alternative, Scored)
    screen_rank: list = field(default_factory=list)    # [(key, screen gap)] best first


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
    return excess(new, floor) <= (1 - _SEL.min_shrink) * excess(old, floor) and new * _SEL.margin <= old


def _score(setup, fit, t0, keys=(), form="input"):
    res_te = [p.Y - fit.predict_prepared(p) for p in setup.test]
    res_tr = [p.Y - fit.predict_prepared(p) for p in setup.train_full]
    return Scored(name=fit.name, fit=fit, gap=signals.nrmse(setup.test_records, res_te),
                  train_gap=signals.nrmse(setup.train_records, res_tr), residuals=res_te,
                  fit_s=time.perf_counter() - t0, keys=tuple(keys), form=form)


def _chain(setup, effects):
    ch = Chain(effects, setup.lin.model.n_in, setup.fs, setup.ref, setup.stats, setup.delays,
               cache=setup.stages)
    return ch


def cut(records: Sequence[Prepared], n: int = OPTIONS.screen.cut_samples) -> list:
    """The first ``n`` samples of each from-rest record (periodic ones whole).

    Parameters
    ----------
    records : sequence of Prepared
        The records.
    n : int
        Samples kept.

    Returns
    -------
    list of Prepared
    """
    return [p if p.periodic or len(p.U) <= n else replace(
        p, U=p.U[:n], Y=p.Y[:n], temp=p.temp[:n]) for p in records]


def _fit(setup, name, effects, joint, dynamic=False, start=None, theta=None,
         max_nfev=_FIT.nfev, ftol=_FIT.ftol, offset=False, curvature=False, mixing=False, keys=(), form="input"):
    t0 = time.perf_counter()
    lin = setup.lin_modal if dynamic else setup.lin
    if setup.train_cut is not None and not any(e in LONG for e in effects):
        setup = replace(setup, train=setup.train_cut)
    pinned = setup.pinned_modal if dynamic else setup.pinned
    if dynamic and not (effects or offset or curvature or mixing):
        fit = fit_by_level(name, setup.train, lin, _chain(setup, ()), setup.noise_sigma,
                           start=start, max_nfev=max_nfev, pinned=pinned)
    else:
        fit = fit_model(name, effects, setup.train, lin, _chain(setup, effects),
                        setup.noise_sigma, joint=joint, dynamic=dynamic, start=start,
                        theta=theta, max_nfev=max_nfev, ftol=ftol, offset=offset,
                        curvature=curvature, mixing=mixing, pinned=pinned)
    if dynamic:
        fit = polish_residues(fit, setup.train, setup.noise_sigma)
    return replace(_score(setup, fit, t0, keys, form), converged=fit.n_eval < max_nfev)


def _start(scored):
    """Parameter values of a fit by name (chain, linear corrections, slopes, output blocks)."""
    if scored is None or not hasattr(scored.fit, "chain"):
        return {}
    f = scored.fit
    z, th, s = f.parts()
    out = dict(zip(f.lin.names, th))
    out.update(zip(f.chain.names, z))   # "gain" of hysteresis wins: the linear one is pinned
    out.update({f"slope{i}": v for i, v in zip(f.slopes, s)})
    if f.post is not None:
        x = f.x[f._post_start:]
        out.update(zip(f.post.names(), x))
    return out


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
    return _fit(setup, f"linear+{OFFSET}", (), joint=True, offset=True, keys=(OFFSET,),
                form="output")


def _name(keys):
    return "+".join(sorted(keys)) or "linear"


def refit_keys(setup: Setup, keys: Sequence[str], start: dict | None = None,
               form: str | None = None, theta: np.ndarray | None = None,
               max_nfev: int = _FIT.nfev) -> Scored:
    """The candidates ``keys`` fitted jointly with the linear corrections.

    Parameters
    ----------
    setup : Setup
        The shared data.
    keys : sequence of str
        Candidates (effects, ``output_offset``, ``amplitude_dependent_dynamics``).
    start : dict, optional
        Starting values by parameter name; ``"form"`` the hysteresis form to fit first.
    form : str, optional
        Of hysteresis: ``"input"`` (Bouc–Wen) or ``"prandtl_ishlinskii"``; ``None`` fits
        the screen's form first and the other when the first leaves more than
        ``near_floor`` x the floor, keeping the one that predicts the held-out records
        better (two models of one mechanism: the choice does not change what is named).
    theta : numpy.ndarray, optional
        The linear re-fit's corrections: a linear part of ``stiffness_nonlinearity``.
    max_nfev : int
        Evaluations of the solver.

    Returns
    -------
    Scored
    """
    keys = tuple(sorted(set(keys)))
    start = dict(start or {})
    prefer = start.pop("form", None)
    if "hysteresis" in keys and form is None:
        forms = ("input", "prandtl_ishlinskii")
        if prefer in forms:           # the screen's form first; the other when it falls short
            first = refit_keys(setup, keys, start, prefer, theta, max_nfev)
            if first.gap <= _SEL.near_floor * setup.floor:
                return first
            other = refit_keys(setup, keys, start, forms[1 - forms.index(prefer)], theta,
                               max_nfev)
            return min((first, other), key=lambda sc: sc.gap)
        both = _run([lambda f=f: refit_keys(setup, keys, start, f, theta, max_nfev)
                     for f in forms], setup.workers)
        return min(both, key=lambda sc: sc.gap)       # the form that predicts better
    t0 = time.perf_counter()
    if keys and keys[0] in STANDALONE and len(keys) == 1:
        if keys[0] == "thermal_dynamics":       # a law about the user's model at its reference
            fit = fit_thermal_dynamics(setup.train, setup.plant, setup.fs, setup.ref)
        else:                                   # on the user's model and on the re-fitted one
            plants = [setup.plant] + ([setup.lin.continuous(theta).channel(0, 0, label="refit")]
                                      if theta is not None else [])
            fit = min((fit_stiffness(setup.train, p, setup.fs, setup.ref, cache=setup.stages)
                       for p in plants), key=lambda f: f.train_cost)
        return _score(setup, fit, t0, keys)
    chain = [k for k in keys if k in CHAIN]
    if "hysteresis" in keys:
        chain.append("hysteresis" if form == "input" else "pi_hysteresis")
    if "saturation" in keys and not any(k.startswith("u_m") for k in start):
        for j, (lo, hi) in enumerate(search_saturation(setup.train, setup.lin, None)):
            sfx = f"_u{j + 1}" if len(setup.delays) > 1 else ""
            start.setdefault(f"u_min_V{sfx}", lo)
            start.setdefault(f"u_max_V{sfx}", hi)
    curvature = "output_nonlinearity" in keys
    return _fit(setup, _name(keys), tuple(chain), joint=True, dynamic=DYNAMIC in keys,
                start=start, max_nfev=max_nfev, offset=OFFSET in keys or curvature,
                curvature=curvature, mixing="cross_coupling" in keys, keys=keys,
                form="prandtl_ishlinskii" if "hysteresis" in keys and form != "input"
                else ("dynamic" if DYNAMIC in keys else "input"))


def _converge(setup, sc, theta=None):
    """``sc`` re-fitted to convergence (up to ``final_nfev`` evaluations) if it stopped early.

    Kept if it fits the training records at least as well (the held-out gap is only
    measured, never used).
    """
    if sc.converged or not hasattr(sc.fit, "chain"):
        return sc
    more = refit_keys(setup, sc.keys, _start(sc), sc.form if "hysteresis" in sc.keys else None,
                      theta, max_nfev=_FIT.final_nfev)
    return more if more.train_gap <= sc.train_gap else sc


def _run(jobs, workers):
    """Results of the callables ``jobs`` (in order), in ``workers`` threads."""
    if workers <= 1 or len(jobs) == 1:
        return [f() for f in jobs]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return [fut.result() for fut in [pool.submit(f) for f in jobs]]


def _compatible(chosen, key):
    if key in chosen:
        return False
    if chosen and (key in STANDALONE or any(c in STANDALONE for c in chosen)):
        return False
    if key == OFFSET and "output_nonlinearity" in chosen:
        return False
    return True


def explain(setup: Setup, say: Callable[[str], None]) -> Explanation:
    """Screen, select, credit and compare the candidates (see the module doc).

    Parameters
    ----------
    setup : Setup
        The shared data.
    say : callable
        Progress: one line of text per stage and fit.

    Returns
    -------
    Explanation
    """
    t0 = time.perf_counter()
    lin = _fit(setup, "linear", (), joint=True)
    theta_l = lin.fit.parts()[1]
    say(f"linear re-fit: held-out gap {lin.gap:.4g} ({lin.fit.n_eval} evaluations,"
        f" {lin.fit_s:.1f} s)")
    keys = [k for k in setup.effects if k != DYNAMIC or setup.dynamic]
    level_ref = min(p.level for p in setup.train)
    zero = np.zeros(setup.lin.size)
    points = [zero] + ([theta_l] if _SEL.second_point and np.max(np.abs(theta_l), initial=0.0) > _SEL.second_point_min
                       else [])
    long_keys = [k for k in keys if k in LONG]
    was_cut = setup.train_cut is not None and any(
        len(a.U) < len(b.U) for a, b in zip(setup.train_cut + setup.test_cut,
                                            setup.train + setup.test))
    parts = ([(replace(setup, train=setup.train_cut, test=setup.test_cut),
               [k for k in keys if k not in LONG]), (setup, long_keys)] if was_cut
             else [(setup, keys)])
    screens = [build_screen(replace(st, effects=tuple(ks)), th, setup.delays, level_ref,
                            DYNAMIC in ks, stages=setup.stages)
               for st, ks in parts if ks or st is setup for th in points]
    say(f"screened {len(keys)} candidate(s) on exact linear columns"
        f" ({len(points)} linearisation point(s), {time.perf_counter() - t0:.1f} s)")

    def screened(ks, with_base=False):
        """The screen of ``ks`` (the linearisation point that fits training better), and
        the base of that screen when ``with_base``."""
        best = min(((s.fit(ks), s) for s in screens if all(k in s.keys() for k in ks)),
                   key=lambda fs: fs[0].train_gap, default=(None, None))
        return (best[0], best[1].fit(()) if best[1] is not None else None) if with_base \
            else best[0]

    def start_of(key):
        for s in screens:
            if key in s.keys():
                return s.start(key)
        return {}

    alone = {k: screened((k,)) for k in keys}
    # a candidate without columns (a delay searched at 0 samples) is the base itself
    nothing = screens[0].fit(())
    alone = {k: (v if v is not None else nothing) for k, v in alone.items()}
    rank0 = sorted(alone, key=lambda k: alone[k].gap)
    for k in rank0:
        say(f"  {k:<30} screen: held-out gap {alone[k].gap:.4g}"
            f" (training {alone[k].train_gap:.4g})")
    fitted = {}

    def refine(ks, start, form=None):
        ks = tuple(sorted(ks))
        if ks not in fitted:
            sc = refit_keys(setup, ks, start, form=form, theta=theta_l)
            fitted[ks] = sc
            say(f"  fitted {_name(ks):<30} held-out gap {sc.gap:.4g} (training"
                f" {sc.train_gap:.4g}; {sc.fit.n_eval} evaluations, {sc.fit_s:.1f} s)")
        return fitted[ks]

    state, chosen, steps, alternatives = lin, [], [], {}
    while len(chosen) < _SEL.max_effects and state.gap > OPTIONS.verdict.none_ratio * setup.floor:
        pool = [k for k in alone if _compatible(chosen, k)]
        if not chosen:
            both = {k: screened((k,), with_base=True) for k in pool}
            scr = {k: f for k, (f, _) in both.items()}
            bases = {k: b for k, (_, b) in both.items()}
            # the amplitude-dependent dynamics starts at the linear re-fit at every level
            starts = {k: (_start(lin) if k == DYNAMIC else start_of(k)) for k in pool}
        else:       # re-screened on top of the model selected so far (its fit the base)
            scr, bases, starts = {}, {}, {}
            for st, ks in parts:
                ks = [k for k in ks if k in pool]
                if not ks:
                    continue
                on_top = build_screen(replace(st, effects=tuple(ks)), None, setup.delays,
                                      level_ref, DYNAMIC in ks, stages=setup.stages,
                                      base_fit=state.fit)
                cur = on_top.fit(())
                for k in ks:
                    if k in on_top.keys():
                        scr[k], bases[k] = on_top.fit((k,)), cur
                        starts[k] = on_top.start(k) or start_of(k)
            for k in sorted(scr, key=lambda k: scr[k].gap / bases[k].gap):
                b = bases[k]
                say(f"  {k:<30} on top of {state.name}: screen {b.gap:.4g} ->"
                    f" {scr[k].gap:.4g} (training {b.train_gap:.4g} -> {scr[k].train_gap:.4g})")
        scr = {k: f for k, f in scr.items() if f is not None}
        r_te = {k: scr[k].gap / max(bases[k].gap, 1e-300) for k in scr}
        r_tr = {k: scr[k].train_gap / max(bases[k].train_gap, 1e-300) for k in scr}
        ratio = {k: r_te[k] * r_tr[k] for k in scr}
        # promising: 3 % better on the held-out or the training records, not worse on both
        # together (the product of the two ratios below 1)
        good = [k for k in ratio if ratio[k] < 1.0 and (
            r_te[k] <= _SEL.promising or r_tr[k] <= _SEL.promising)]
        if not good:
            break
        # ranked by the product of the held-out and training ratios: an effect a wrong
        # linear model or another effect masks may improve a lot on one, not on the other
        ranked = sorted(good, key=ratio.get)
        base = _start(state) if chosen else {}
        # the best by the screen, and the next ones only when their screen comes close
        # (relative to the base of their own screen; the noise floor bounds the ratios)
        fl = {k: setup.floor / max(bases[k].gap, 1e-300) for k in good}
        g_best = min(max(r_te[k], fl[k]) for k in good)
        t_best = min(max(r_tr[k], fl[k]) for k in good)
        tries = [k for k in ranked[:_SEL.refine_top]
                 if max(r_te[k], fl[k]) <= _SEL.screen_spread * g_best
                 or max(r_tr[k], fl[k]) <= _SEL.screen_spread * t_best]
        tries += [c for k in tries for c in SPECIAL.get(k, ()) if c in good and c not in tries]
        form = state.form if "hysteresis" in chosen else None    # the form found before
        results = _run([lambda k=k: refine(chosen + [k], {**starts[k], **base}, form)
                        for k in tries], setup.workers)
        k_best, best = min(zip(tries, results), key=lambda kv: kv[1].gap)
        for c in SPECIAL.get(k_best, ()):      # the special case, unless clearly worse
            if c in tries:
                sc = results[tries.index(c)]
                if not significant(best.gap, sc.gap, setup.floor):
                    k_best, best = c, sc
        if best.train_gap < state.train_gap and DYNAMIC not in best.keys:
            best = _converge(setup, best, theta_l)
            fitted[tuple(sorted(chosen + [k_best]))] = best
        if chosen and best.train_gap > _SEL.short_of_screen * max(scr[k_best].train_gap,
                                                             setup.floor):
            # stuck where the smaller set's fit left it: fitted again from the screens'
            # starts (every effect's as in the first step), the better on training kept
            fresh_start = {}
            for c in chosen:
                fresh_start.update(_start(lin) if c == DYNAMIC else start_of(c))
            fresh = refit_keys(setup, chosen + [k_best], {**fresh_start, **starts[k_best]},
                               form=form, theta=theta_l)
            if fresh.train_gap < state.train_gap and DYNAMIC not in fresh.keys:
                fresh = _converge(setup, fresh, theta_l)
            say(f"  fitted {fresh.name:<30} held-out gap {fresh.gap:.4g} (training"
                f" {fresh.train_gap:.4g}; from the screens' starts, the fit from the set"
                f" before left {best.train_gap:.4g} against a screen of"
                f" {scr[k_best].train_gap:.4g})")
            if fresh.train_gap < best.train_gap:
                best = fresh
                fitted[tuple(sorted(chosen + [k_best]))] = best
        if not significant(best.gap, state.gap, setup.floor):
            break
        related = {k_best, *SPECIAL.get(k_best, ())} | {g for g, sp in SPECIAL.items()
                                                        if k_best in sp}
        others = [(k, sc) for k, sc in zip(tries, results) if k not in related]
        if others:
            alternatives[k_best] = min(others, key=lambda kv: kv[1].gap)
        steps.append((k_best, state.gap, best))
        chosen.append(k_best)
        state = best
    # credit by removal: an effect the joint fit does not need is no cause
    removal, dropped = {}, []
    while chosen:
        if len(chosen) == 1:
            without = {chosen[0]: lin}
        else:
            st = _start(state)
            form = state.form if "hysteresis" in chosen else None
            without = dict(zip(chosen, _run(
                [lambda k=k: refine([c for c in chosen if c != k], st,
                                    form if k != "hysteresis" else None) for k in chosen],
                setup.workers)))
        removal = {k: sc.gap for k, sc in without.items()}
        weak = [k for k in chosen if not significant(state.gap, without[k].gap, setup.floor)]
        if not weak:
            break
        k = min(weak, key=lambda k: without[k].gap)
        dropped.append((k, state.gap, without[k].gap))
        say(f"  {k} credited nothing: the joint fit without it leaves {without[k].gap:.4g}"
            f" (with it {state.gap:.4g})")
        chosen = [c for c in chosen if c != k]
        state = without[k]
        steps = [s for s in steps if s[0] != k]
    # alternatives: the best other candidate fitted in the same step (a tie: neither explains
    # the held-out gap significantly better)
    tie = None
    alternatives = {k: v for k, v in alternatives.items() if k in chosen}
    gap_at = {k: sc.gap for k, _, sc in steps}
    for k, (a, alt) in alternatives.items():
        if not significant(gap_at[k], alt.gap, setup.floor):
            tie = (k, a, gap_at[k], alt.gap)
            break
    singles = {k: fitted.get((k,)) or Screened(k, alone[k].gap, alone[k].train_gap,
                                               alone[k].beta) for k in alone}
    return Explanation(linear=lin, singles=singles, steps=steps, removal=removal,
                       dropped=dropped, tie=tie, alternatives=alternatives,
                       screen_rank=[(k, alone[k].gap) for k in rank0])
