"""Which candidates, together, explain the held-out gap: screen, fit, credit, compare.

The selection's logic (:func:`select_effects`) asks an object of
:class:`~robrst.diagnose.candidates.CandidateFits`' methods for screens and fits; on the
diagnosis's records that is :class:`~robrst.diagnose.candidates.CandidateFits`
(:func:`explain`).  Every decision is also written to :attr:`Explanation.events`.

1. ``linear``: the linear corrections alone (the user's model re-fitted, regularised).
2. Screening (:mod:`robrst.diagnose._screen`): every excited candidate scored by an exact
   linear least-squares fit on precomputed columns, linearised about the user's model.
3. Forward selection: at each step the candidates whose screen improves on the current
   set by ``promising`` (held-out or training gap) are ranked, the best ``refine_top``
   are fitted by their own nonlinear models *jointly* with the set so far and the linear
   corrections (:func:`robrst.diagnose.fit.fit_model`, or the standalone fits of
   ``thermal_dynamics`` and ``stiffness_nonlinearity``), and the best is kept if it
   removes ``min_shrink`` of the excess held-out gap and beats the current set by
   ``margin`` (:func:`significant`; the constants live in :mod:`robrst.diagnose.options`);
   a constant output offset passes the same bar on the training records too.
   A set's fit starts at the values of the set before it; when the best one's training
   gap stays ``short_of_screen`` times above its screen, it is fitted again from the
   screens' starts (not from the smaller set's values: an effect fitted alone can stretch
   to stand in for the one still missing, e.g. creep's growth with temperature for a
   thermal drift, and the joint fit cannot leave that minimum; the new effect from its
   first screen as well as from the screen on top, which is linearised where the smaller
   set stretched) and the one that fits the training records better is kept.  The
   selection stops at ``max_effects``, at the noise floor, when no screen is promising or
   when the best fit is not significant.
4. Credit by removal: every selected effect is removed from the joint fit in turn (the
   others re-fitted; the least needed one's removal to convergence, as the set itself);
   an effect whose removal costs less than the same bar is no cause and is dropped (the
   set re-fitted without it, its fit the answer's).
5. Ties: the best other candidate fitted in a selected effect's step is its
   alternative; when neither explains the held-out gap significantly better (and the
   alternative was not selected too), that *slot* is a tie (:class:`Tie`).  A tie never
   discards what was selected before it: the answer names the effects of the earlier
   slots and says which candidates the tied slot cannot tell apart
   (:func:`robrst.diagnose._verdict.decide`).

Forms of one effect are not alternatives: ``hysteresis`` is fitted as Bouc–Wen and as
Prandtl–Ishlinskii and the better form is kept.  A constant output offset (``output_offset``)
is the constant of a static output nonlinearity: with ``output_nonlinearity`` in a set it
is not a separate cause.

Every gap is measured on the test records, every fit uses the training records only.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from robrst.diagnose.candidates import (DYNAMIC, OFFSET, SPECIAL, STANDALONE, CandidateFits,
                                        Screened, start_values)
from robrst.diagnose.options import OPTIONS

if TYPE_CHECKING:
    from robrst.diagnose.candidates import Scored, Setup

__all__ = ["Tie", "Explanation", "explain", "select_effects", "excess", "significant"]

_SEL = OPTIONS.select


@dataclass(frozen=True)
class Tie:
    """A slot of the selection that the held-out records cannot settle.

    Parameters
    ----------
    slot : int
        Its position in the selection (0: the first effect).
    effect : str
        The candidate selected there.
    alternative : str
        The candidate that explains the held-out gap as well in its place.
    gap, gap_alternative : float
        Held-out gaps of the set with each.
    before : tuple of str
        The effects selected before the slot.
    """

    slot: int
    effect: str
    alternative: str
    gap: float
    gap_alternative: float
    before: tuple = ()


@dataclass(frozen=True, eq=False)
class Explanation:
    """What :func:`select_effects` found (see the module doc).

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
    ties : tuple of Tie
        The slots the held-out records cannot settle, in slot order.
    alternatives : dict
        ``{key: (alternative, Scored)}``: the best other candidate of the same step.
    screen_rank : list
        ``[(key, screened held-out gap)]``, best first.
    events : tuple of str
        Every decision of the selection, in order (``selected <key>``, ``tie <key> | <alt>``,
        ``stop: ...``, ...).

    Attributes
    ----------
    tied : frozenset of str
        The effects selected in a tied slot.
    """

    linear: Scored
    singles: dict          # key -> Scored (fitted alone) or Screened
    steps: list            # [(key, gap before, Scored)] in the order selected
    removal: dict          # key -> held-out gap of the final set without it
    dropped: list          # [(key, gap with, gap without)]: credited nothing, removed
    ties: tuple = ()       # Tie per unsettled slot
    alternatives: dict = field(default_factory=dict)   # key -> (alternative, Scored)
    screen_rank: list = field(default_factory=list)    # [(key, screen gap)] best first
    events: tuple = ()     # the selection's decisions, in order

    @property
    def tied(self) -> frozenset:
        """The effects selected in a tied slot."""
        return frozenset(t.effect for t in self.ties)


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
    >>> from robrst.diagnose._select import excess
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




def _same(a, b):
    """Whether two starts (parameter name -> value) are the same."""
    return a.keys() == b.keys() and all(
        np.array_equal(np.asarray(a[k]), np.asarray(b[k])) for k in a)


def _compatible(chosen, key):
    """May ``key`` join the set ``chosen``?"""
    if key in chosen:
        return False
    if chosen and (key in STANDALONE or any(c in STANDALONE for c in chosen)):
        return False
    if key == OFFSET and "output_nonlinearity" in chosen:
        return False
    return True


def _constant_needed(key, sc, state, floor):
    """May the fit ``sc`` of ``key`` on top of ``state`` be selected?  A constant output
    offset (a sensor zero) is in every record alike, the training ones too: it is a cause
    only when it explains the training records significantly better as well.  One that only
    the held-out records want stands in for what the set cannot model (a rate-dependent
    hysteresis outside the library: 0.12 -> 0.065 held out with a 3.1 µm offset, 0.058 ->
    0.051 on training)."""
    return key != OFFSET or significant(sc.train_gap, state.train_gap, floor)


def _promising(scr, bases, floor):
    """Candidates worth a fit, best first: the screen 3 % better on the held-out or the
    training records and not worse on both together; the best by the screen and the next
    ones only when their screen comes close (the noise floor bounds the ratios); and the
    next ones that come close or whose screen explains the training records significantly,
    fitted when none of the first explains them."""
    scr = {k: f for k, f in scr.items() if f is not None}
    r_te = {k: scr[k].gap / max(bases[k].gap, 1e-300) for k in scr}
    r_tr = {k: scr[k].train_gap / max(bases[k].train_gap, 1e-300) for k in scr}
    ratio = {k: r_te[k] * r_tr[k] for k in scr}
    good = [k for k in ratio if ratio[k] < 1.0 and (
        r_te[k] <= _SEL.promising or r_tr[k] <= _SEL.promising)]
    if not good:
        return [], []
    # ranked by the product of the held-out and training ratios: an effect a wrong linear
    # model or another effect masks may improve a lot on one, not on the other
    ranked = sorted(good, key=ratio.get)
    fl = {k: floor / max(bases[k].gap, 1e-300) for k in good}
    g_best = min(max(r_te[k], fl[k]) for k in good)
    t_best = min(max(r_tr[k], fl[k]) for k in good)
    close = [k for k in ranked if max(r_te[k], fl[k]) <= _SEL.screen_spread * g_best
             or max(r_tr[k], fl[k]) <= _SEL.screen_spread * t_best]
    tries = [k for k in close if k in ranked[:_SEL.refine_top]]
    tries += [c for k in tries for c in SPECIAL.get(k, ()) if c in good and c not in tries]
    # a screen's held-out score is an extrapolation of its linearisation (creep on top of
    # hysteresis, its growth with temperature carried to the held-out ramps: 10x the gap
    # before, where its training score removes 87 % of the training gap): one that explains
    # the training records significantly is worth a fit when the first explain too little
    trained = sorted((k for k in scr if k not in good and k not in tries
                      and significant(scr[k].train_gap, bases[k].train_gap, floor)), key=r_tr.get)
    return tries, ([k for k in close if k not in tries] + trained)[:_SEL.refine_top]


def select_effects(fits: CandidateFits, say: Callable[[str], None]) -> Explanation:
    """Forward selection, credit by removal and ties on the screens and fits of ``fits``.

    Parameters
    ----------
    fits : CandidateFits
        The linear re-fit, screens and fits (any object with its methods and attributes
        ``linear``, ``floor``).
    say : callable
        Progress: one line of text per stage and fit.

    Returns
    -------
    Explanation
    """
    floor, lin = fits.floor, fits.linear
    events = []
    alone = fits.alone()
    rank0 = sorted(alone, key=lambda k: alone[k].gap)
    for k in rank0:
        say(f"  {k:<30} screen: held-out gap {alone[k].gap:.4g}"
            f" (training {alone[k].train_gap:.4g})")
    state, chosen, steps, alternatives = lin, [], [], {}
    while True:
        if len(chosen) >= _SEL.max_effects:
            events.append("stop: the largest set")
            break
        if state.gap <= OPTIONS.verdict.none_ratio * floor:
            events.append("stop: at the noise floor")
            break
        pool = [k for k in alone if _compatible(chosen, k)]
        scr, bases, starts = fits.first(pool) if not chosen else fits.on_top(state, pool)
        tries, later = _promising(scr, bases, floor)
        if not tries:
            events.append("stop: no promising candidate")
            break
        base = start_values(state) if chosen else {}
        form = state.form if "hysteresis" in chosen else None    # the form found before
        results = fits.fit_many([(chosen + [k], {**starts[k], **base}, form) for k in tries])
        first = min(results, key=lambda r: r.gap)
        if later and min(r.train_gap for r in results) > OPTIONS.verdict.near_ratio * floor and not (
                significant(first.gap, state.gap, floor)
                and significant(first.train_gap, state.train_gap, floor)):
            # the screen is first order (linearised about the user's model): where none of
            # the candidates it put first explains the training records, and the best of
            # them falls short on the held-out or the training ones, the next ones are
            # fitted too (a stiffening resonance at 150 V screened fourth, 11 % behind a
            # static output curve, fits to the floor: 0.00084 against 0.0096)
            results += fits.fit_many([(chosen + [k], {**starts[k], **base}, form) for k in later])
            tries = tries + later
            events.append("fitted beyond the screen's first: " + ", ".join(later))
        eligible = [(k, r) for k, r in zip(tries, results) if _constant_needed(k, r, state, floor)]
        if len(eligible) < len(tries):
            events.append(f"{OFFSET}: not needed by the training records")
        if not eligible:
            events.append("stop: no promising candidate")
            break
        k_best, best = min(eligible, key=lambda kv: kv[1].gap)
        fitted_ok = dict(eligible)
        for c in SPECIAL.get(k_best, ()):      # the special case, unless clearly worse
            if c in fitted_ok:                 # (and only one the training records need)
                sc = fitted_ok[c]
                if not significant(best.gap, sc.gap, floor):
                    k_best, best = c, sc
                    events.append(f"special case {c}")
        if best.train_gap < state.train_gap and DYNAMIC not in best.keys:
            best = fits.converge(best)
        if chosen and best.train_gap > _SEL.short_of_screen * max(scr[k_best].train_gap, floor):
            # stuck where the smaller set's fit left it: fitted again from the screens'
            # starts (every effect's as in the first step), the better on training kept.
            # The new effect starts from its first screen too: the screen on top of the
            # stuck set is linearised where the smaller set stretched to stand in for it,
            # and its start can lie in the same basin (a drift's lag of 1 s where the
            # first screen had the true 3 s: 0.0104 against 0.00084 on training)
            fresh_start = {}
            for c in chosen:
                fresh_start.update(start_values(lin) if c == DYNAMIC else fits.start_of(c))
            first = fits.start_of(k_best)
            news = [first] if _same(first, starts[k_best]) else [first, starts[k_best]]
            fresh = min((fits.refit(chosen + [k_best], {**fresh_start, **new}, form)
                         for new in news), key=lambda sc: sc.train_gap)
            if fresh.train_gap < state.train_gap and DYNAMIC not in fresh.keys:
                fresh = fits.converge(fresh)
            say(f"  fitted {fresh.name:<30} held-out gap {fresh.gap:.4g} (training"
                f" {fresh.train_gap:.4g}; from the screens' starts, the fit from the set"
                f" before left {best.train_gap:.4g} against a screen of"
                f" {scr[k_best].train_gap:.4g})")
            events.append(f"fresh fit {k_best}")
            if fresh.train_gap < best.train_gap:
                best = fresh
                fits.remember(best)
        if not significant(best.gap, state.gap, floor):
            events.append(f"stop: {k_best} not significant")
            break
        related = {k_best, *SPECIAL.get(k_best, ())} | {g for g, sp in SPECIAL.items()
                                                        if k_best in sp}
        others = [(k, sc) for k, sc in zip(tries, results) if k not in related]
        if others:
            alternatives[k_best] = min(others, key=lambda kv: kv[1].gap)
        steps.append((k_best, state.gap, best))
        chosen.append(k_best)
        events.append(f"selected {k_best}")
        state = best
    removal, dropped, state, chosen, steps = _credit(fits, state, chosen, steps, floor, say,
                                                     events)
    alternatives = {k: v for k, v in alternatives.items() if k in chosen}
    ties = []
    for slot, (k, _, sc) in enumerate(steps):
        if k not in alternatives:
            continue
        a, alt = alternatives[k]
        if a in chosen:                    # both selected: each is needed, no tie
            continue
        # the held-out records cannot settle it, and neither can the training ones (a
        # candidate that explains them to the floor is no tie of one leaving 240x the
        # floor on them: a saturation whose held-out records go 6 V beyond the lower limit
        # the training records never reached, against a static output curve)
        if not significant(sc.gap, alt.gap, floor) and not significant(sc.train_gap,
                                                                        alt.train_gap, floor):
            ties.append(Tie(slot, k, a, sc.gap, alt.gap, tuple(c for c, _, _ in steps[:slot])))
            events.append(f"tie {k} | {a}")
    singles = {k: fits.fitted.get((k,)) or Screened(k, alone[k].gap, alone[k].train_gap,
                                                    alone[k].beta) for k in alone}
    return Explanation(linear=lin, singles=singles, steps=steps, removal=removal,
                       dropped=dropped, ties=tuple(ties), alternatives=alternatives,
                       screen_rank=[(k, alone[k].gap) for k in rank0], events=tuple(events))


def _credit(fits, state, chosen, steps, floor, say, events):
    """Credit by removal: an effect the joint fit does not need is no cause (dropped, the
    set re-fitted without it).  Returns ``(removal, dropped, state, chosen, steps)``."""
    removal, dropped = {}, []
    while chosen:
        if len(chosen) == 1:
            without = {chosen[0]: fits.linear}
        else:
            st = start_values(state)
            form = state.form if "hysteresis" in chosen else None
            # the smaller sets fitted before this round (cached: from other starts)
            earlier = {k for k in chosen if tuple(sorted(c for c in chosen if c != k))
                       in fits.fitted}
            without = dict(zip(chosen, fits.fit_many(
                [([c for c in chosen if c != k], st, form if k != "hysteresis" else None)
                 for k in chosen])))
        weak = [k for k in chosen if not significant(state.gap, without[k].gap, floor)]
        if not weak and len(chosen) > 1:
            # the least needed effect's removal fitted to convergence before it is credited
            # (the set itself is: a removal stopped at the fits' budget can look needed)
            k = min(chosen, key=lambda k: without[k].gap)
            # the set without it is also fitted from the answer's values: its cached fit
            # (the selection's earlier step) may sit in another basin (creep + thermal
            # drift from the screens' starts left 0.0019, five times the floor, and made a
            # static input map of 1e-5/V look needed; from the three-effect answer's
            # creep and lag they reach 0.0004)
            fits_k = [fits.converge(without[k])]
            if k in earlier:        # else it was just fitted from the answer's values
                rest = [c for c in chosen if c != k]
                fits_k.append(fits.converge(fits.refit(rest, st, form if k != "hysteresis"
                                                       else None)))
            without[k] = min(fits_k, key=lambda sc: sc.train_gap)
            fits.remember(without[k])
            if not significant(state.gap, without[k].gap, floor):
                weak = [k]
        removal = {k: sc.gap for k, sc in without.items()}
        if not weak:
            break
        k = min(weak, key=lambda k: without[k].gap)
        dropped.append((k, state.gap, without[k].gap))
        say(f"  {k} credited nothing: the joint fit without it leaves {without[k].gap:.4g}"
            f" (with it {state.gap:.4g})")
        events.append(f"dropped {k}")
        chosen = [c for c in chosen if c != k]
        state = without[k]
        steps = [s for s in steps if s[0] != k]
        if steps:     # the answer's fit is the last step's: that of the set left, the
            # better on training of the removal's fit and the step's own
            last = steps[-1][2]
            if set(last.keys) == set(state.keys) and last.train_gap < state.train_gap:
                state = last
            steps[-1] = (*steps[-1][:2], state)
    return removal, dropped, state, chosen, steps


def explain(setup: Setup, say: Callable[[str], None]) -> Explanation:
    """Screen, select, credit and compare the candidates on the diagnosis's records.

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
    return select_effects(CandidateFits(setup, say), say)
