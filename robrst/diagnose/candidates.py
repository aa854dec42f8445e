"""Candidate fits on the diagnosis's records: the shared state, scores, screens and fits.

:class:`Setup` holds what every candidate's fit shares (built once per diagnosis);
:func:`refit_keys` fits a set of candidates jointly with the linear corrections and scores
it on the held-out records (:class:`Scored`); :class:`CandidateFits` is what the forward
selection (:mod:`robrst.diagnose._select`) asks of the records — the linear re-fit, the
exact screens (:mod:`robrst.diagnose._screen`) about the user's model and on top of a
fitted set, and cached fits of sets of candidates — so the selection's logic runs on any
object with the same methods (the property tests give it synthetic gaps).

Every gap is measured on the test records, every fit uses the training records only.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

import robrst.diagnose._signals as signals
from robrst.diagnose._effects import Chain
from robrst.diagnose.fit import fit_by_level, fit_model
from robrst.diagnose.options import OPTIONS
from robrst.diagnose._polish import polish_residues
from robrst.diagnose._screen import build_screen
from robrst.diagnose._stiffness import fit_stiffness
from robrst.diagnose._thermal import fit_thermal_dynamics, search_saturation

if TYPE_CHECKING:
    from robrst.core.plant import Plant
    from robrst.diagnose.fit import Fitted, Prepared
    from robrst.diagnose.linear import LinearPart
    from robrst.diagnose._stiffness import StiffnessFit
    from robrst.diagnose._thermal import ThermalFit

__all__ = ["Setup", "Scored", "Screened", "CandidateFits", "cut", "start_values",
           "linear_with_offset", "refit_keys", "OFFSET", "DYNAMIC", "STANDALONE", "SPECIAL",
           "LONG", "CHAIN"]

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
    lin: LinearPart
    lin_modal: LinearPart  # with per-mode gains (amplitude-dependent dynamics)
    stats: dict
    noise_sigma: float
    plant: Plant | None    # SISO Plant of the user's model (standalone fits)
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
    fit: Fitted | StiffnessFit | ThermalFit
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
        # each level's fit within its own budget (a fit that stops there is final: a
        # continuation would repeat it), the caller's budget the converged flag's
        fit = fit_by_level(name, setup.train, lin, _chain(setup, ()), setup.noise_sigma,
                           start=start, max_nfev=min(max_nfev, _FIT.level_nfev), pinned=pinned)
    else:
        fit = fit_model(name, effects, setup.train, lin, _chain(setup, effects),
                        setup.noise_sigma, joint=joint, dynamic=dynamic, start=start,
                        theta=theta, max_nfev=max_nfev, ftol=ftol, offset=offset,
                        curvature=curvature, mixing=mixing, pinned=pinned)
    if dynamic:
        fit = polish_residues(fit, setup.train, setup.noise_sigma)
    return replace(_score(setup, fit, t0, keys, form), converged=fit.n_eval < max_nfev)


def start_values(scored: Scored | None) -> dict:
    """Parameter values of a fit by name (chain, linear corrections, slopes, output blocks):
    the starting values of a larger set's fit.

    Parameters
    ----------
    scored : Scored or None
        The fit (a standalone fit has no named parameters: empty).

    Returns
    -------
    dict
    """
    if scored is None or not hasattr(scored.fit, "chain"):
        return {}
    f = scored.fit
    z, th, s = f.parts()
    out = dict(zip(f.lin.names, th))
    out.update(zip(f.chain.names, z))   # "gain" of hysteresis wins: the linear one is pinned
    out.update(dict(zip(f.slope_names(), s)))
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
    more = refit_keys(setup, sc.keys, start_values(sc), sc.form if "hysteresis" in sc.keys else None,
                      theta, max_nfev=_FIT.final_nfev)
    return more if more.train_gap <= sc.train_gap else sc


def _run(jobs, workers):
    """Results of the callables ``jobs`` (in order), in ``workers`` threads."""
    if workers <= 1 or len(jobs) == 1:
        return [f() for f in jobs]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return [fut.result() for fut in [pool.submit(f) for f in jobs]]




class CandidateFits:
    """The screens and fits the forward selection asks for, on the diagnosis's records.

    Built once per diagnosis: the linear re-fit (:attr:`linear`), then the exact screens
    of every candidate about the user's model (records from rest cut to
    ``cut_samples``, the thermal candidates on whole records).  Fits of a set of
    candidates are cached by the set (:meth:`fit`): credit by removal re-uses the fits
    of the selection's steps.

    Parameters
    ----------
    setup : Setup
        The shared data.
    say : callable
        Progress: one line of text per stage and fit.

    Attributes
    ----------
    linear : Scored
        The linear re-fit.
    theta : numpy.ndarray
        Its corrections.
    keys : list of str
        The candidates tried.
    floor : float
        The noise floor.
    """

    def __init__(self, setup: Setup, say: Callable[[str], None]) -> None:
        self.setup, self.say = setup, say
        t0 = time.perf_counter()
        self.linear = lin = _fit(setup, "linear", (), joint=True)
        self.theta = lin.fit.parts()[1]
        self.floor = setup.floor
        say(f"linear re-fit: held-out gap {lin.gap:.4g} ({lin.fit.n_eval} evaluations,"
            f" {lin.fit_s:.1f} s)")
        self.keys = [k for k in setup.effects if k != DYNAMIC or setup.dynamic]
        self.level_ref = min(p.level for p in setup.train)
        zero = np.zeros(setup.lin.size)
        points = [zero] + ([self.theta] if _SEL.second_point and np.max(
            np.abs(self.theta), initial=0.0) > _SEL.second_point_min else [])
        long_keys = [k for k in self.keys if k in LONG]
        was_cut = setup.train_cut is not None and any(
            len(a.U) < len(b.U) for a, b in zip(setup.train_cut + setup.test_cut,
                                                setup.train + setup.test))
        self.parts = ([(replace(setup, train=setup.train_cut, test=setup.test_cut),
                        [k for k in self.keys if k not in LONG]), (setup, long_keys)]
                      if was_cut else [(setup, self.keys)])
        self.screens = [build_screen(replace(st, effects=tuple(ks)), th, setup.delays,
                                     self.level_ref, DYNAMIC in ks, stages=setup.stages)
                        for st, ks in self.parts if ks or st is setup for th in points]
        say(f"screened {len(self.keys)} candidate(s) on exact linear columns"
            f" ({len(points)} linearisation point(s), {time.perf_counter() - t0:.1f} s)")
        self.fitted = {}

    def _screened(self, ks, with_base=False):
        """The screen of ``ks`` (the linearisation point that fits training better), and
        the base of that screen when ``with_base``."""
        best = min(((s.fit(ks), s) for s in self.screens if all(k in s.keys() for k in ks)),
                   key=lambda fs: fs[0].train_gap, default=(None, None))
        return (best[0], best[1].fit(()) if best[1] is not None else None) if with_base \
            else best[0]

    def alone(self) -> dict:
        """Every candidate's screen alone on the user's model.

        Returns
        -------
        dict
            ``{candidate: ScreenFit}`` (a candidate without columns, e.g. a delay searched
            at 0 samples, is the base itself).
        """
        nothing = self.screens[0].fit(())
        out = {}
        for k in self.keys:
            v = self._screened((k,))
            out[k] = v if v is not None else nothing
        return out

    def start_of(self, key: str) -> dict:
        """Starting values of ``key``'s fit from the first screens (its best option).

        Parameters
        ----------
        key : str
            The candidate.

        Returns
        -------
        dict
        """
        for s in self.screens:
            if key in s.keys():
                return s.start(key)
        return {}

    def first(self, pool: Sequence[str]) -> tuple[dict, dict, dict]:
        """Screens of the first step (alone on the user's model) and their starts.

        Parameters
        ----------
        pool : sequence of str
            The candidates.

        Returns
        -------
        screens, bases, starts : dict
            By candidate: its screen, the base of that screen, its fit's starting values
            (the amplitude-dependent dynamics starts at the linear re-fit).
        """
        both = {k: self._screened((k,), with_base=True) for k in pool}
        scr = {k: f for k, (f, _) in both.items()}
        bases = {k: b for k, (_, b) in both.items()}
        starts = {k: (start_values(self.linear) if k == DYNAMIC else self.start_of(k))
                  for k in pool}
        return scr, bases, starts

    def on_top(self, state: Scored, pool: Sequence[str]) -> tuple[dict, dict, dict]:
        """Screens of the candidates re-screened on top of the fitted set ``state``.

        Parameters
        ----------
        state : Scored
            The set selected so far (its fit is the base).
        pool : sequence of str
            The candidates.

        Returns
        -------
        screens, bases, starts : dict
            As :meth:`first`.
        """
        scr, bases, starts = {}, {}, {}
        setup = self.setup
        for st, ks in self.parts:
            ks = [k for k in ks if k in pool]
            if not ks:
                continue
            on_top = build_screen(replace(st, effects=tuple(ks)), None, setup.delays,
                                  self.level_ref, DYNAMIC in ks, stages=setup.stages,
                                  base_fit=state.fit)
            cur = on_top.fit(())
            for k in ks:
                if k in on_top.keys():
                    scr[k], bases[k] = on_top.fit((k,)), cur
                    starts[k] = on_top.start(k) or self.start_of(k)
        for k in sorted(scr, key=lambda k: scr[k].gap / bases[k].gap):
            b = bases[k]
            self.say(f"  {k:<30} on top of {state.name}: screen {b.gap:.4g} ->"
                     f" {scr[k].gap:.4g} (training {b.train_gap:.4g} -> {scr[k].train_gap:.4g})")
        return scr, bases, starts

    def fit(self, keys: Sequence[str], start: dict, form: str | None = None) -> Scored:
        """The set ``keys`` fitted jointly (cached by the set).

        Parameters
        ----------
        keys : sequence of str
            The candidates.
        start : dict
            Starting values by parameter name.
        form : str, optional
            The hysteresis form (None: the screen's form first).

        Returns
        -------
        Scored
        """
        ks = tuple(sorted(keys))
        if ks not in self.fitted:
            sc = refit_keys(self.setup, ks, start, form=form, theta=self.theta)
            self.fitted[ks] = sc
            self.say(f"  fitted {_name(ks):<30} held-out gap {sc.gap:.4g} (training"
                     f" {sc.train_gap:.4g}; {sc.fit.n_eval} evaluations, {sc.fit_s:.1f} s)")
        return self.fitted[ks]

    def fit_many(self, jobs: Sequence[tuple]) -> list:
        """:meth:`fit` of every ``(keys, start, form)``, in the diagnosis's threads.

        Parameters
        ----------
        jobs : sequence of tuple
            ``(keys, start, form)`` each.

        Returns
        -------
        list of Scored
        """
        return _run([lambda j=j: self.fit(*j) for j in jobs], self.setup.workers)

    def refit(self, keys: Sequence[str], start: dict, form: str | None = None) -> Scored:
        """The set ``keys`` fitted from ``start`` (not cached; converged when it improves on
        the training records).

        Parameters
        ----------
        keys : sequence of str
            The candidates.
        start : dict
            Starting values by parameter name.
        form : str, optional
            The hysteresis form.

        Returns
        -------
        Scored
        """
        return refit_keys(self.setup, keys, start, form=form, theta=self.theta)

    def converge(self, sc: Scored) -> Scored:
        """``sc`` continued to convergence when its fit stopped early (kept when it fits the
        training records at least as well); the cache holds the result.

        Parameters
        ----------
        sc : Scored
            A fitted set.

        Returns
        -------
        Scored
        """
        out = _converge(self.setup, sc, self.theta)
        self.fitted[tuple(sorted(sc.keys))] = out
        return out

    def remember(self, sc: Scored) -> None:
        """Hold ``sc`` as the fit of its set.

        Parameters
        ----------
        sc : Scored
            A fitted set.
        """
        self.fitted[tuple(sorted(sc.keys))] = sc
