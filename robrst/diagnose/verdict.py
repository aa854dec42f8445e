"""From scored candidates to the verdict, the findings and the :class:`Diagnosis` record.

Rules (see :mod:`robrst.diagnose.diagnosis`): the answer is the forward-selected set of
effects, else ``linear`` if the linear re-fit passes the same 30 % bar; it must also
bring the held-out gap near the floor (``NEAR_RATIO`` x floor, or at most
``NEAR_EXCESS`` of the excess gap left), else ``cannot_tell`` with the best partial
explanation.  Two effects that explain the gap equally well and do not add up are a
tie (``cannot_tell``).  A candidate that removes ``MIN_SHRINK`` of the training gap
but under ``HELD_OUT_MIN`` of the held-out gap is flagged ``overfit`` (finding
``train_only``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from robrst.diagnose.result import Diagnosis, EffectScore
from robrst.diagnose.select import MIN_SHRINK, OFFSET, excess, significant
from robrst.identify.vf import fit_data, fit_residues, initial_poles, to_continuous, vector_fit
from robrst.core.plant import Plant

if TYPE_CHECKING:
    from robrst.diagnose.select import Scored, Setup
    from robrst.identify.modal import ModalModel

__all__ = ["decide", "build", "unmodelled", "NEAR_RATIO", "NEAR_EXCESS"]

NEAR_RATIO = 2.0
NEAR_EXCESS = 0.35
HELD_OUT_MIN = 0.05


def _key_name(key):
    if key == OFFSET:
        return key, "output"
    return ("hysteresis", "dynamic") if key == "hysteresis:dynamic" else (key, "input")


def decide(info: dict, linear: Scored, steps: list, tie: tuple | None) -> tuple:
    """The verdict (see the module docstring).

    Parameters
    ----------
    info : dict
        ``before``, ``floor``, ``before_train`` gaps.
    linear : Scored
        The linear re-fit.
    steps : list
        The forward selection's steps.
    tie : tuple or None
        Two candidates that explain the gap equally well.

    Returns
    -------
    tuple
        ``(cause, reason, causes, best partial explanation or None, answer gap)``.
    """
    before, floor = info["before"], info["floor"]
    pct = lambda g: 100 * (1 - g / before)  # noqa: E731
    if tie:
        a, b, ga, gb = tie
        best = {"effects": [_key_name(a)[0]], "gap_after": ga, "shrink": 1 - ga / before}
        return "cannot_tell", (f"{_key_name(a)[0]} and {_key_name(b)[0]} explain the held-out"
                               f" gap equally well ({ga:.3g} vs {gb:.3g}) and do not add up"), \
            (), best, None
    if steps:
        causes = tuple(_key_name(k)[0] for k, _, _ in steps)
        final = steps[-1][2]
        answer, gap = causes[0], final.gap
        what = " + ".join(causes)
        joint = " (fitted jointly with the linear corrections)" if getattr(
            final.fit, "joint", False) else ""
        reason = (f"adding {what}{joint} shrinks the held-out gap by {pct(gap):.0f} %"
                  f" ({before:.3g} -> {gap:.3g}; linear re-fit alone {linear.gap:.3g};"
                  f" noise floor {floor:.3g})")
    elif significant(linear.gap, before, floor):
        causes, answer, gap = (), "linear", linear.gap
        what = "the linear re-fit"
        reason = (f"a re-fit of the linear model explains the gap ({before:.3g} -> {gap:.3g};"
                  f" no effect adds {100 * MIN_SHRINK:.0f} % to it; noise floor {floor:.3g})")
    elif info["before_train"] <= 1.25 * info.get("floor_train", floor):
        return "cannot_tell", (f"the training records show no gap ({info['before_train']:.3g},"
                               " at their noise floor) while the test records do"
                               f" ({before:.3g}): the test records excite something the training"
                               " records do not; add training records like the test ones"), \
            (), None, None
    else:
        return "cannot_tell", (f"no effect in the library nor a linear re-fit removes"
                               f" {100 * MIN_SHRINK:.0f} % of the excess held-out gap (linear"
                               f" re-fit {linear.gap:.3g} vs {before:.3g})"), (), None, None
    near = gap <= NEAR_RATIO * floor or excess(gap, floor) <= NEAR_EXCESS * excess(before, floor)
    if near:
        if gap > NEAR_RATIO * floor:
            reason += (f"; what is left ({gap:.3g}) is {gap / floor:.3g}x the noise floor:"
                       " part of the gap is still unexplained")
        return answer, reason, causes, None, gap
    best = {"effects": list(causes) or ["linear"], "gap_after": gap, "shrink": 1 - gap / before}
    return "cannot_tell", (f"nothing brings the held-out gap near the noise floor {floor:.3g};"
                           f" best partial explanation: {what} ({before:.3g} -> {gap:.3g},"
                           f" {pct(gap):.0f} %)"), (), best, gap


def unmodelled(setup: Setup, linear: Scored, info: dict,
               order_extra: Sequence[int] = (2, 4)) -> tuple[ModalModel, float] | None:
    """Higher-order linear fits on the training records.

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
    (ModalModel, float) or None
        The best higher-order model and its held-out gap.
    """
    base = setup.lin.continuous(linear.fit.parts()[1])
    data = fit_data(setup.train_records)
    best = None
    for extra in order_extra:
        poles0 = np.concatenate([base.discretise(setup.fs).zpoles,
                                 initial_poles(extra, setup.fs, *data.band)])
        try:
            poles = vector_fit(data, poles0, n_iter=8)
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
        if best is None or gap < best[1]:
            best = (cm, gap, base)
    return best


def _score(key, sc, before, before_train):
    name, form = _key_name(key)
    params, sds = ({}, {})
    if form == "dynamic":
        params, sds = sc.fit.linear_change()
        params = {k: v for k, v in params.items() if k.endswith("_per_level")}
        sds = {k: sds[k] for k in params}
    else:
        params, sds = sc.fit.params().get(name, ({}, {}))
    overfit = (sc.train_gap <= (1 - MIN_SHRINK) * before_train
               and sc.gap >= (1 - HELD_OUT_MIN) * before)
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
          best_partial: dict | None = None, decomposition: dict | None = None) -> Diagnosis:
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
        prev = next((s for s in scores if s.name == es.name), None)
        if prev is None or es.gap_after < prev.gap_after:
            scores = [s for s in scores if s.name != es.name] + [es]
            fit_res[es.name] = sc.residuals
    scores.sort(key=lambda s: s.gap_after)
    findings = [f for f in findings if f]
    for s in scores:
        if s.overfit:
            findings.append({"kind": "train_only", "effect": s.name,
                             "message": (f"{s.name} removes"
                                         f" {100 * (1 - s.train_gap / info['before_train']):.0f} %"
                                         f" of the training gap but {100 * s.shrink:.0f} % of the"
                                         " held-out gap: it fits the training records only"),
                             "train_gap": s.train_gap, "test_gap": s.gap_after})
    selected, final = [], None
    for key, gap0, sc in steps:
        name, form = _key_name(key)
        p = sc.fit.params().get(name, ({}, {})) if form != "dynamic" else sc.fit.linear_change()
        selected.append({"name": name, "form": form, "gap_before": gap0, "gap_after": sc.gap,
                         "shrink": 1 - sc.gap / gap0 if gap0 > 0 else 0.0,
                         "params": p[0], "params_std": p[1]})
    if steps:
        sc = steps[-1][2]
        ch, cs = sc.fit.linear_change()
        moves = [abs(v) for k, v in ch.items() if not k.endswith("_per_level")]
        final = {"effects": [s["name"] for s in selected], "gap_after": sc.gap,
                 "shrink": 1 - sc.gap / before if before > 0 else 0.0,
                 "train_gap": sc.train_gap, "linear_change": ch, "linear_change_std": cs,
                 "linear_moved": max(moves) if moves else 0.0, "n_eval": sc.fit.n_eval,
                 "gap_per_record": [
                     {"file": names[n_tr + i], "gap": float(np.sqrt(np.sum(r ** 2) / np.sum(
                         (d.Y - d.Y.mean(axis=0)) ** 2)))}
                     for i, (r, d) in enumerate(zip(sc.residuals, traces["records"][n_tr:]))]}
        fit_res["final"] = sc.residuals
    traces["fit_residuals"] = fit_res
    lin_score = _linear_score(linear, before, isinstance(plant, Plant), plant) if linear else None
    data = {"fs_hz": info["fs"], "train": names[:n_tr], "test": names[n_tr:],
            "samples": int(sum(d.n for d in traces["records"])), "noise_sigma_um": info["sigma"],
            "inputs": model.n_in, "outputs": model.n_out,
            "periodic": [bool(d.period) for d in traces["records"]]}
    mdict = {"B": None, "A": None, "label": model.label, "reference_C": info["ref"],
             "inputs": model.n_in, "outputs": model.n_out, "order": model.order,
             "poles_hz": sorted(float(abs(p) / (2 * np.pi)) for p in model.poles)}
    if (model.n_in, model.n_out) == (1, 1):
        ch = plant if isinstance(plant, Plant) else model.channel(0, 0)
        mdict["B"], mdict["A"] = [float(v) for v in ch.B], [float(v) for v in ch.A]
    gap_extra = {"noise_floor_method": info["method"], "per_record": info["per_record"],
                 "per_level": info.get("per_level", [])}
    extra = {"causes": list(causes), "selected": selected, "final": final,
             "findings": findings, "best_partial": best_partial, "skipped": skipped or {},
             "seconds": time.perf_counter() - info["t_start"], "gap": gap_extra,
             "output_offset": offset_alone.as_dict() if offset_alone else None}
    return Diagnosis(cause=cause, reason=reason, gap_before=before, noise_floor=info["floor"],
                     gap_train=info["before_train"], effects=tuple(scores),
                     linear_refit=lin_score, where=where, tests=tests,
                     decomposition=decomposition or {}, data=data, model=mdict, extra=extra,
                     traces=traces)
