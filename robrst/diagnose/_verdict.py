"""From scored candidates to the verdict, the findings and the :class:`Diagnosis` record.

Rules (see :mod:`robrst.diagnose._diagnosis`): the answer is the forward-selected set of
effects, else ``linear`` if the linear re-fit passes the same 30 % bar; it must also
bring the held-out gap near the floor (``near_ratio`` x floor, or at most
``near_excess`` of the excess gap left; :mod:`robrst.diagnose.options`), else
``cannot_tell`` with the best partial explanation.  Two candidates that explain the gap
equally well in one slot of the selection are a tie: the effects of the other slots are
still named and the tied slot is said as such (``ties``); when every selected slot is
tied, the answer is ``cannot_tell``.  A candidate that removes ``min_shrink`` of the training gap
but under ``held_out_min`` of the held-out gap is flagged ``overfit`` (finding
``train_only``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.diagnose.result import (
    Alternative, Diagnosis, EffectScore, FinalFit, Finding, FrfDeparture, LevelGap,
    ModelDiagnosed, NotCause, PartialExplanation, RecordGap, RecordsUsed, Regime,
    ResidualTest, ResidualTests, ScreenGap, SelectedEffect, SensorRecord, SensorReport,
    TestGap, Tie, TimeWindow, Traces, Where)
from robrst.diagnose.options import OPTIONS
from robrst.diagnose.candidates import DYNAMIC, OFFSET, Screened
from robrst.diagnose._select import excess, significant
from robrst.identify.vf import fit_data, fit_residues, initial_poles, to_continuous, vector_fit
from robrst.core.plant import Plant
from robrst.twin.model import hysteresis_sector

if TYPE_CHECKING:
    from robrst.diagnose.candidates import Scored, Setup
    from robrst.diagnose._select import Explanation
    from robrst.identify.modal import ModalModel

__all__ = ["Verdict", "decide", "build", "unmodelled", "tell_apart", "LEVEL_EFFECTS"]

_V, _SEL = OPTIONS.verdict, OPTIONS.select


LEVEL_EFFECTS = ("hysteresis", "amplitude_dependent_dynamics", "stiffness_nonlinearity",
                 "saturation", "input_nonlinearity", "output_nonlinearity")
# what record tells two candidates apart (by pair; the default names the usual levers); a
# callable takes the seconds a record must last (see _record_seconds)
TELL_APART = {
    frozenset(("hysteresis", "amplitude_dependent_dynamics")):
        "a slow triangle at two amplitudes (hysteresis keeps a loop at any rate; a level-"
        "dependent linear model has none at low frequency)",
    frozenset(("hysteresis", "stiffness_nonlinearity")):
        "a slow triangle at full stroke (a stiffness nonlinearity bends the curve without a"
        " loop; hysteresis opens one)",
    frozenset(("amplitude_dependent_dynamics", "stiffness_nonlinearity")):
        "a record at a third amplitude between the training ones",
    frozenset(("hysteresis", "creep")):
        "a large step held for several seconds (creep keeps moving, hysteresis does not)",
    frozenset(("creep", "thermal_drift")): lambda s:
        f"a record at constant temperature of {s:g} s with held steps (creep follows the"
        " input, drift the temperature)",
    frozenset(("creep", "thermal_dynamics")): lambda s:
        f"a record at constant temperature of {s:g} s with held steps (creep keeps moving"
        " after a step, a temperature-dependent linear model does not)",
    frozenset(("thermal_drift", "thermal_dynamics")):
        "a temperature ramp with the input held constant (a drift moves the output, a"
        " temperature-dependent linear model does not)",
    frozenset(("saturation", "input_nonlinearity")):
        "a slow ramp through the full input range",
    frozenset(("output_nonlinearity", "input_nonlinearity")):
        "a slow ramp and a fast multisine (a sensor map bends the output after the"
        " dynamics, an input map before)",
    frozenset(("slew", "delay")): "steps of several sizes (a rate limit grows with the step,"
                                   " a delay does not)",
}


@dataclass(frozen=True)
class Verdict:
    """The verdict of :func:`decide`.

    Parameters
    ----------
    cause : str
        An effect, ``output_offset``, ``linear`` or ``cannot_tell``.
    reason : str
        Why, in one sentence.
    causes : tuple of str
        The effects named (the selected effects of the slots the records settle).
    best_partial : dict, optional
        The best partial explanation of a ``cannot_tell``.
    gap : float, optional
        The held-out gap of the answer's model (the selected set, tied slots included).
    ties : tuple of dict
        Per tied slot: ``slot``, ``effects`` (the candidates it cannot tell apart),
        ``gaps``, ``after`` (the effects selected before it) and ``record`` (what record
        would tell them apart).
    """

    cause: str
    reason: str
    causes: tuple = ()
    best_partial: dict = None
    gap: float = None
    ties: tuple = ()


def key_name(key):
    """Effect name and form of a candidate key."""
    if key == OFFSET:
        return key, "output"
    if key == DYNAMIC:
        return key, "dynamic"
    return key, "input"


def _round_up(x):
    """``x`` rounded up to 1, 2 or 5 times a power of ten."""
    e = 10.0 ** math.floor(math.log10(max(x, 1e-12)))
    return next(m * e for m in (1, 2, 5, 10) if m * e >= x * (1 - 1e-12))


def _record_seconds(fits, duration_s):
    """How long a record at constant temperature must last to tell creep from a drift: five
    of the fitted drift's lags (its stack temperature has settled; creep keeps moving on
    every held step), at least the longest training record."""
    lags = []
    for sc in fits:
        prm = sc.fit.params() if hasattr(sc.fit, "params") else {}
        lag = (prm.get("thermal_drift") or ({}, {}))[0]
        lags += [v for k, v in lag.items() if k.startswith("lag_s")]
    return _round_up(max([5.0 * v for v in lags] + [duration_s, 1.0]))


def tell_apart(a: str, b: str, seconds: float = 60.0) -> str:
    """What record tells candidates ``a`` and ``b`` apart (a noun phrase).

    Parameters
    ----------
    a, b : str
        The candidates.
    seconds : float
        How long a record at constant temperature must last (creep against a thermal
        effect).

    Returns
    -------
    str
    """
    txt = TELL_APART.get(frozenset((a, b)), "records that excite them differently (other"
                         " amplitudes, rates and holding times than the training records)")
    return txt(seconds) if callable(txt) else txt


def where_text(info):
    """Where the gap lies: band and regime (for a ``cannot_tell``)."""
    band = info.get("band")
    reg = info.get("regime") or {}
    parts = []
    if band:
        parts.append(f"the gap lies in {band[0]:.3g}–{band[1]:.3g} Hz")
    dom = reg.get("dominant")
    if dom and reg.get(dom) is not None and reg[dom] >= 0.1:
        parts.append(f"its regime is {dom.replace('_', ' ')} ({100 * reg[dom]:.0f} % of the"
                     " residual variance)")
    return "; ".join(parts)


def _levels_text(amp, rank, single_level, levels):
    cands = [k for k, _ in rank if k in LEVEL_EFFECTS][:4] or list(LEVEL_EFFECTS[:3])
    txt = (f"the gap grows with the excitation level ({amp['gap_per_level'][0]:.3g} at"
           f" {amp['levels_V'][0]:.3g} V rms, {amp['gap_per_level'][-1]:.3g} at"
           f" {amp['levels_V'][-1]:.3g} V rms for a linear model of the lowest level): the"
           f" plant is not linear; candidates: {', '.join(cands)}")
    if single_level:
        lv = levels[0] if levels else amp["levels_V"][0]
        txt += (f"; the training records span one level ({lv:.3g} V rms): record a second"
                f" training level (e.g. {2 * lv:.3g} V rms) to tell them apart")
    return txt


def _ties(info, ex):
    """The JSON entries of the tied slots and their sentences."""
    step_fit = {k: sc for k, _, sc in ex.steps}
    out = []
    for t in ex.ties:
        a, b = key_name(t.effect)[0], key_name(t.alternative)[0]
        fits = [step_fit[t.effect]] + ([ex.alternatives[t.effect][1]]
                                       if t.effect in ex.alternatives else [])
        rec = tell_apart(a, b, _record_seconds(fits, info.get("duration_s", 0.0)))
        out.append({"slot": t.slot + 1, "effects": [a, b], "gaps": [t.gap, t.gap_alternative],
                    "after": [key_name(k)[0] for k in t.before], "record": rec,
                    "message": (f"{a} or {b}: these records cannot tell them apart (held-out"
                                f" gap {t.gap:.3g} vs {t.gap_alternative:.3g}; {rec} would)")})
    return tuple(out)


def _explains_training_only(info, ex):
    """A candidate fitted alone that explains the training records to their noise floor
    (``near_ratio``) where the answer does not, and is worse on the held-out ones: the
    two sets of records disagree (None when there is none)."""
    tight = _V.near_ratio * max(info.get("floor_train", info["floor"]), _V.resolved_gap)
    final = ex.steps[-1][2]
    if final.train_gap <= tight:
        return None
    chosen = {k for k, _, _ in ex.steps}
    better = [sc for k, sc in ex.singles.items() if k not in chosen
              and not isinstance(sc, Screened) and sc.train_gap <= tight and sc.gap > final.gap]
    return min(better, key=lambda sc: sc.train_gap, default=None)


def decide(info: dict, ex: Explanation, amp: dict | None = None) -> Verdict:
    """The verdict (see the module docstring).

    A tie at a slot never discards the effects selected in the other slots: they are
    named (``causes``), and the tied slot is said as such ("hysteresis, then creep or
    thermal_drift: these records cannot tell them apart; a record at constant
    temperature of 60 s with held steps would").  Only when every selected slot is tied
    is the answer ``cannot_tell``.

    Parameters
    ----------
    info : dict
        ``before``, ``floor``, ``before_train``, ``floor_train`` gaps; ``band`` and
        ``regime`` (where the gap lies); ``train_levels`` (input rms per training record);
        ``duration_s`` (the longest training record).
    ex : Explanation
        What the selection found.
    amp : dict, optional
        The ``amplitude_dependent`` finding.

    Returns
    -------
    Verdict
    """
    before, floor = info["before"], info["floor"]
    linear = ex.linear
    pct = lambda g: 100 * (1 - g / before)  # noqa: E731
    levels = sorted({round(d, 9) for d in info.get("train_levels", [])})
    single = len(levels) <= 1 or levels[-1] <= OPTIONS.records.level_ratio * levels[0]
    extra = ""
    where = where_text(info)
    ties = _ties(info, ex)
    tie_of = {t.effect: tj for t, tj in zip(ex.ties, ties)}
    if ex.steps:
        final = ex.steps[-1][2]
        gap = final.gap
        certain = tuple(key_name(k)[0] for k, _, _ in ex.steps if k not in tie_of)
        what = ", then ".join(key_name(k)[0] if k not in tie_of else tie_of[k]["message"]
                              for k, _, _ in ex.steps)
        if not certain:                    # every selected slot is a tie: nothing named
            t = ex.ties[0]
            a, b = key_name(t.effect)[0], key_name(t.alternative)[0]
            best = {"effects": [key_name(k)[0] for k, _, _ in ex.steps], "gap_after": gap,
                    "shrink": 1 - gap / before, "alternative": b,
                    "alternative_gap": t.gap_alternative}
            return Verdict("cannot_tell", (
                f"{a} and {b} explain the held-out gap equally well ({t.gap:.3g} vs"
                f" {t.gap_alternative:.3g}; neither removes {100 * _SEL.min_shrink:.0f} % more"
                f" of the excess than the other); {where + '; ' if where else ''}to tell them"
                f" apart: {ties[0]['record']}"
                + (f"; best partial explanation: {what} ({before:.3g} -> {gap:.3g},"
                   f" {pct(gap):.0f} %)" if len(ex.steps) > 1 else "")),
                (), best, gap, ties)
        credit = "; ".join(f"without {key_name(k)[0]} {ex.removal[k]:.3g}" for k, _, _ in ex.steps
                           if k in ex.removal)
        joint = (" (fitted jointly with the linear corrections)"
                 if getattr(final.fit, "joint", False) else "")
        names = " + ".join(key_name(k)[0] for k, _, _ in ex.steps)
        lead = f"{what}; {names}{joint}" if ties else f"{names}{joint}"
        answer, causes = certain[0], certain
        reason = (f"{lead} shrinks the held-out gap by {pct(gap):.0f} % ({before:.3g} ->"
                  f" {gap:.3g}; linear re-fit alone {linear.gap:.3g}; {credit}; noise floor"
                  f" {floor:.3g})")
    elif significant(linear.gap, before, floor):
        causes, answer, gap = (), "linear", linear.gap
        what = "the linear re-fit"
        reason = (f"a re-fit of the linear model explains the gap ({before:.3g} -> {gap:.3g};"
                  f" no effect adds {100 * _SEL.min_shrink:.0f} % to it; noise floor {floor:.3g})")
        if amp:
            best = {"effects": ["linear"], "gap_after": gap, "shrink": 1 - gap / before}
            return Verdict("cannot_tell", (
                f"a linear re-fit narrows the gap ({before:.3g} -> {gap:.3g}) but"
                f" {_levels_text(amp, ex.screen_rank, single, levels)}"), (), best, gap)
    elif info["before_train"] <= _V.none_ratio * info.get("floor_train", floor):
        return Verdict("cannot_tell", (
            f"the training records show no gap ({info['before_train']:.3g}, at their noise"
            f" floor) while the test records do ({before:.3g}): the test records excite"
            " something the training records do not; add training records like the test"
            " ones"))
    else:
        if amp:
            extra = f"; {_levels_text(amp, ex.screen_rank, single, levels)}"
        return Verdict("cannot_tell", (
            f"no candidate in the library nor a linear re-fit removes"
            f" {100 * _SEL.min_shrink:.0f} % of the excess held-out gap (linear re-fit"
            f" {linear.gap:.3g} vs {before:.3g}){'; ' + where if where else ''}{extra}"))
    near = gap <= _V.near_ratio * floor or excess(gap, floor) <= _V.near_excess * excess(before, floor)
    other = _explains_training_only(info, ex) if ex.steps else None
    if near and other is not None:
        best = {"effects": [key_name(k)[0] for k, _, _ in ex.steps], "gap_after": gap,
                "shrink": 1 - gap / before}
        return Verdict("cannot_tell", (
            f"{other.name} explains the training records to their noise floor (training gap"
            f" {other.train_gap:.3g}) but not the held-out ones ({other.gap:.3g}), and the best"
            f" held-out explanation, {what} ({before:.3g} -> {gap:.3g}), leaves"
            f" {ex.steps[-1][2].train_gap:.3g} on the training records: the held-out records"
            " differ from the training ones by something no candidate explains (a change"
            " between the sessions: a gain, the sensor, the set-up); record training and"
            f" test records in one session{'; ' + where if where else ''}"), (), best, gap,
            ties)
    if near:
        if gap > _V.near_ratio * floor:
            ratio = (f"{gap / floor:.3g}x the noise floor" if floor > 0 else
                     "above the noise floor (not determined from these records)")
            reason += (f"; what is left ({gap:.3g}) is {ratio}:"
                       " part of the gap is still unexplained")
        return Verdict(answer, reason, causes, None, gap, ties)
    best = {"effects": [key_name(k)[0] for k, _, _ in ex.steps] or ["linear"],
            "gap_after": gap, "shrink": 1 - gap / before}
    if amp:
        extra = f"; {_levels_text(amp, ex.screen_rank, single, levels)}"
    return Verdict("cannot_tell", (
        f"nothing brings the held-out gap near the noise floor {floor:.3g} (an effect outside"
        f" the library may explain the {100 * excess(gap, floor) / excess(before, floor):.0f} %"
        f" of the excess left); best partial explanation: {what} ({before:.3g} -> {gap:.3g},"
        f" {pct(gap):.0f} %){'; ' + where if where else ''}{extra}"), (), best, gap,
        ties)


def unmodelled(setup: Setup, linear: Scored, info: dict,
               order_extra: Sequence[int] = _V.unmodelled_orders
               ) -> tuple[ModalModel, float, ModalModel] | None:
    """Higher-order linear fits on the training records, and the re-fit's own order fitted
    from the data alone.

    Parameters
    ----------
    setup : Setup
        The shared data.
    linear : Scored
        The linear re-fit (its order is the base).
    info : dict
        The gaps.
    order_extra : sequence of int
        Orders added to the re-fit's.

    Returns
    -------
    (ModalModel, float, ModalModel) or None
        The best higher-order model (or the own-order one from the data, when its held-out
        gap is within ``unmodelled_same_order`` of it), its held-out gap, and the re-fit
        as a continuous model.
    """
    base = setup.lin.continuous(linear.fit.parts()[1])
    data = fit_data(setup.train_records)
    best, fresh = None, None
    # each higher order from the re-fit's poles; and the re-fit's own order from the data
    # alone (poles spread over the band): a re-fit that stays in a local minimum of a
    # wrong model (its resonance far from the data's) is not missing an order
    for extra in (*order_extra, None):
        if extra is None:
            poles0 = initial_poles(base.order, setup.fs, *data.band)
        else:
            poles0 = np.concatenate([base.discretise(setup.fs).zpoles,
                                     initial_poles(extra, setup.fs, *data.band)])
        try:
            poles = vector_fit(data, poles0, n_iter=_V.unmodelled_iterations)
            dm, _ = fit_residues(data, poles)
            cm = to_continuous(dm)
        except Exception:  # noqa: BLE001 - any failure: no finding from this order
            continue
        num = den = 0.0
        for p, d in zip(setup.test, setup.test_records):
            E = p.Y - dm.response(p.U, periodic=p.periodic)
            num += float(np.sum(E ** 2))
            den += float(np.sum((d.Y - d.Y.mean(axis=0)) ** 2))
        gap = float(np.sqrt(num / den)) if den > 0 else np.inf
        if extra is None:
            fresh = (cm, gap, base)
        elif best is None or gap < best[1]:
            best = (cm, gap, base)
    if fresh is not None and (best is None or fresh[1] <= _V.unmodelled_same_order * best[1]):
        return fresh        # the model's own order suffices: its dynamics are wrong
    return best


def _sector(params, records):
    """The fitted Bouc–Wen map's input-gain sector over the training records' voltage
    range (:func:`robrst.twin.model.hysteresis_sector`)."""
    u = np.concatenate([np.ravel(d.u) for d in records])
    lo, hi = float(np.min(u)), float(np.max(u))
    if not hi > lo:
        return None
    return hysteresis_sector(params["A"], params["B_per_V"], params["Gamma_per_V"],
                             params["gain"], lo, hi)


def _params(key, sc):
    """Reported parameters of candidate ``key`` in the fit ``sc`` (values, 1-sigma)."""
    name, form = key_name(key)
    if form == "dynamic":
        p, sd = sc.fit.linear_change()
        p = {k: v for k, v in p.items() if k.endswith("_per_level")}
        return p, {k: sd[k] for k in p}
    prm = sc.fit.params()
    if key == "hysteresis" and "hysteresis" not in prm:
        return prm.get("pi_hysteresis", ({}, {}))
    return prm.get(name, ({}, {}))


def _score(key, sc, before, before_train):
    name, form = key_name(key)
    if isinstance(sc, Screened):
        return EffectScore(name=name, gap_before=before, gap_after=sc.gap,
                           shrink=1 - sc.gap / before if before > 0 else 0.0,
                           train_gap=sc.train_gap, params={}, params_std={}, n_eval=0,
                           fit_s=sc.fit_s, form=form, overfit=False, method="screen")
    params, sds = _params(key, sc)
    if form == "input" and getattr(sc, "form", "input") == "prandtl_ishlinskii":
        form = "prandtl_ishlinskii"
    overfit = (sc.train_gap <= (1 - _SEL.min_shrink) * before_train
               and sc.gap >= (1 - _V.held_out_min) * before)
    return EffectScore(name=name, gap_before=before, gap_after=sc.gap,
                       shrink=1 - sc.gap / before if before > 0 else 0.0,
                       train_gap=sc.train_gap, params=params, params_std=sds,
                       n_eval=sc.fit.n_eval, fit_s=sc.fit_s, form=form, overfit=bool(overfit))


def _linear_score(linear, before, model_is_plant, plant):
    vals, sds = linear.fit.linear_change()
    if model_is_plant:
        fitted = linear.fit.lin.continuous(linear.fit.parts()[1]).channel(0, 0)
        for kind, new, old in (("a", fitted.A, plant.A), ("b", fitted.B, plant.B)):
            start = 1 if kind == "a" else 0
            for i in range(start, min(len(new), len(old))):
                if old[i] != 0:
                    vals[f"rel_{kind}{i}"] = float(new[i] / old[i] - 1)
    return EffectScore(name="linear", gap_before=before, gap_after=linear.gap,
                       shrink=1 - linear.gap / before if before > 0 else 0.0,
                       train_gap=linear.train_gap, params=vals, params_std=sds,
                       n_eval=linear.fit.n_eval, fit_s=linear.fit_s)


def build(info: dict, where: dict, tests: dict, traces: dict, cause: str, reason: str,
          skipped: dict | None = None, findings: Sequence[dict] = (), linear: Scored | None = None,
          singles: dict | None = None, steps: Sequence = (), causes: Sequence[str] = (),
          best_partial: dict | None = None, decomposition: dict | None = None,
          explanation: Explanation | None = None, sensor: dict | None = None,
          ties: Sequence[dict] = ()) -> Diagnosis:
    """The :class:`Diagnosis` record.

    Parameters
    ----------
    info : dict
        Gaps, floor, data and model descriptions.
    where : dict
        Localisation (windows, band, FRF, regime).
    tests : dict
        Whiteness and cross-correlation.
    traces : dict
        Arrays for the report.
    cause : str
        The verdict.
    reason : str
        Why.
    skipped : dict, optional
        Effects not tried, with the reason.
    findings : sequence of dict
        The findings.
    linear : Scored, optional
        The linear re-fit.
    singles : dict, optional
        Every single candidate.
    steps : sequence
        The forward selection's steps.
    causes : sequence of str
        The selected effects.
    best_partial : dict, optional
        The best partial explanation of a ``cannot_tell``.
    decomposition : dict, optional
        Shares of the residual.
    explanation : Explanation, optional
        What the selection found (credit by removal, alternatives, the screen).
    sensor : dict, optional
        Outliers and dropouts set aside (:func:`robrst.diagnose._sensor.repair`).
    ties : sequence of dict
        The tied slots (:attr:`Verdict.ties`).

    Returns
    -------
    Diagnosis
    """
    before, model, plant = info["before"], info["model"], info["plant"]
    n_tr, names = info["n_train"], info["names"]
    scores, fit_res = [], {}
    offset_alone = None
    for key, sc in (singles or {}).items():
        es = _score(key, sc, before, info["before_train"])
        if key == OFFSET:           # not an effect: reported beside them, like the re-fit
            offset_alone = es
            continue
        if not isinstance(sc, Screened):
            fit_res.setdefault(es.name, sc.residuals)
        scores.append(es)
    scores.sort(key=lambda s: s.gap_after)
    found = [Finding.of(f) for f in findings if f]
    for s in scores:
        if s.overfit:
            found.append(Finding("train_only", (
                f"{s.name} removes {100 * (1 - s.train_gap / info['before_train']):.0f} % of"
                f" the training gap but {100 * s.shrink:.0f} % of the held-out gap: it fits the"
                " training records only"),
                {"effect": s.name, "train_gap": s.train_gap, "test_gap": s.gap_after}))
    selected, final = [], None
    ex = explanation
    removal = ex.removal if ex else {}
    final_gap = steps[-1][2].gap if steps else None
    records = tuple(traces["records"])
    for key, gap0, sc in steps:
        name, form = key_name(key)
        final_fit = steps[-1][2]
        p = _params(key, final_fit) if form != "dynamic" else final_fit.fit.linear_change()
        if key == "hysteresis" and getattr(final_fit, "form", "") == "prandtl_ishlinskii":
            form = "prandtl_ishlinskii"
        gw = removal.get(key)
        tied = next((t["effects"][1] for t in ties if t["effects"][0] == name), None)
        credit = (1 - excess(final_gap, info["floor"]) / excess(gw, info["floor"])
                  if gw is not None and excess(gw, info["floor"]) > 0 else None)
        # the hysteresis as the design's input-gain sector over the records' voltages
        sector = (_sector(p[0], records[:n_tr]) if key == "hysteresis" and form == "input"
                  and p[0] else None)
        selected.append(SelectedEffect(
            name=name, form=form, gap_before=gap0, gap_after=sc.gap, tied_with=tied,
            shrink=1 - sc.gap / gap0 if gap0 > 0 else 0.0, params=p[0], params_std=p[1],
            gap_without=gw, credit=credit, input_gain_sector=sector))
    if steps:
        sc = steps[-1][2]
        ch, cs = sc.fit.linear_change()
        moves = [abs(v) for k, v in ch.items() if not k.endswith("_per_level")]
        final = FinalFit(
            effects=tuple(s.name for s in selected), gap_after=sc.gap,
            shrink=1 - sc.gap / before if before > 0 else 0.0, train_gap=sc.train_gap,
            linear_change=ch, linear_change_std=cs, linear_moved=max(moves) if moves else 0.0,
            n_eval=sc.fit.n_eval,
            gap_per_record=tuple(
                TestGap(names[n_tr + i], float(np.sqrt(np.sum(r ** 2) / np.sum(
                    (d.Y - d.Y.mean(axis=0)) ** 2))))
                for i, (r, d) in enumerate(zip(sc.residuals, records[n_tr:]))))
        fit_res["final"] = sc.residuals
    answer_fit = (steps[-1][2].fit if steps else (linear.fit if linear is not None else None))
    lin_score = _linear_score(linear, before, isinstance(plant, Plant), plant) if linear else None
    data = RecordsUsed(fs_hz=info["fs"], train=tuple(names[:n_tr]), test=tuple(names[n_tr:]),
                       samples=int(sum(d.n for d in records)), noise_sigma_um=info["sigma"],
                       inputs=model.n_in, outputs=model.n_out,
                       periodic=tuple(bool(d.period) for d in records))
    B = A = None
    if (model.n_in, model.n_out) == (1, 1):
        ch = plant if isinstance(plant, Plant) else model.channel(0, 0)
        B, A = tuple(float(v) for v in ch.B), tuple(float(v) for v in ch.A)
    mrec = ModelDiagnosed(B=B, A=A, label=model.label, reference_C=info["ref"],
                          inputs=model.n_in, outputs=model.n_out, order=model.order,
                          poles_hz=tuple(sorted(float(abs(p) / (2 * np.pi))
                                                for p in model.poles)))
    return Diagnosis(
        cause=cause, reason=reason, gap_before=before, noise_floor=info["floor"],
        gap_train=info["before_train"], noise_floor_method=info["method"],
        per_record=tuple(RecordGap(**r) for r in info["per_record"]),
        per_level=tuple(LevelGap(r["level_V"], tuple(r["records"]), tuple(r["split"]),
                                 r["gap"], r["noise_floor"])
                        for r in info.get("per_level", [])),
        effects=tuple(scores), linear_refit=lin_score, where=_where(where),
        tests=ResidualTests(*(ResidualTest(stat, tests[k][stat], tests[k]["bound"],
                                           tests[k]["passed"])
                              for k, stat in (("whiteness", "max_abs_autocorr"),
                                              ("cross_correlation", "max_abs_crosscorr")))),
        decomposition=decomposition or {}, data=data, model=mrec, causes=tuple(causes),
        selected=tuple(selected), final=final, findings=tuple(found),
        best_partial=(PartialExplanation(**{**best_partial,
                                            "effects": tuple(best_partial["effects"])})
                      if best_partial else None),
        skipped=skipped or {}, seconds=time.perf_counter() - info["t_start"],
        output_offset=offset_alone,
        not_causes=tuple(NotCause(key_name(k)[0], a, b) for k, a, b in (ex.dropped if ex else [])),
        alternatives=tuple(Alternative(key_name(k)[0], key_name(a)[0], sc.gap)
                           for k, (a, sc) in (ex.alternatives.items() if ex else [])),
        screen=tuple(ScreenGap(key_name(k)[0], g) for k, g in (ex.screen_rank if ex else [])),
        sensor=_sensor_report(sensor),
        ties=tuple(Tie(t["slot"], tuple(t["effects"]), tuple(t["gaps"]), tuple(t["after"]),
                       t["record"], t["message"]) for t in ties),
        selection=tuple(ex.events) if ex else (),
        traces=Traces(names=tuple(names), records=records,
                      base_residuals=tuple(traces["base_residuals"]), psd_f=traces["psd_f"],
                      psd=traces["psd"], noise_psd=traces["noise_psd"], fit_residuals=fit_res,
                      answer_fit=answer_fit, focus=n_tr + int(np.argmax(
                          [np.sum(np.asarray(r) ** 2) for r in traces["base_residuals"][n_tr:]]))))


def _where(w):
    """The :class:`Where` record of the localisation's entries."""
    frf, reg = w["frf"], dict(w["regime"])
    dominant, measure = reg.pop("dominant", None), reg.pop("measure", "eta2")
    band = w["frequency_band_hz"]
    return Where(time_windows=tuple(TimeWindow(**x) for x in w["time_windows"]),
                 energy_fraction=w["time_windows_energy_fraction"],
                 frequency_band_hz=None if band is None else tuple(band),
                 frf=FrfDeparture(None if frf["band_hz"] is None else tuple(frf["band_hz"]),
                                  frf["max_rel_error"], frf["bins"]),
                 regime=Regime(reg, dominant, measure))


def _sensor_report(sensor):
    """The :class:`SensorReport` of :func:`robrst.diagnose._sensor.repair`'s entries."""
    if not sensor:
        return None
    return SensorReport(
        outliers=sensor["outliers"], dropouts=sensor["dropouts"], samples=sensor["samples"],
        share=sensor["share"],
        records=tuple(SensorRecord(r["file"], r["outliers"], r["dropouts"],
                                   tuple(tuple(ab) for ab in r["dropouts_s"]), r["flagged"])
                      for r in sensor["records"]),
        noise_floor_with_faults=sensor.get("noise_floor_with_faults"))
