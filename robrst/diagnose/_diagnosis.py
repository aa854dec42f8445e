"""The sim-to-real gap diagnosis: measure, localise, explain, quantify.

Pipeline (:func:`diagnose`)::

    train + test records --check--> base simulation (the model under diagnosis;
        periodic records in steady state, others from rest)
      -> gap on test (NRMSE), noise floor (period differences or residual spectrum),
         gap per record and per excitation level
      -> where: time windows, frequency band, FRF departure, regime, residual tests
      -> candidates fitted on train, scored on test: the linear re-fit, each excited
         effect alone, then forward selection of effects fitted jointly with the
         linear corrections (:mod:`robrst.diagnose._select`)
      -> findings (amplitude_dependent, unmodelled_dynamics, output_offset, train_only)
         and verdict: none | <effect> | output_offset | linear | cannot_tell

Verdict rules (constants in :mod:`robrst.diagnose.options`): ``none`` when the held-out
gap is within ``none_ratio`` of the floor (or below ``resolved_gap``).  An answer (the
selected effects, or ``linear`` when no effect adds to the linear re-fit) must remove
``min_shrink`` of the excess gap (the same 30 % bar for ``linear`` as for effects) *and*
bring the gap near the floor: within ``near_ratio`` x the floor, or ``near_excess`` of the
excess left.  Otherwise ``cannot_tell``, with the best partial explanation.  A constant
output offset is a candidate like the effects (:data:`robrst.diagnose._select.OFFSET`):
when the answer includes it, it is named (``causes``, finding ``output_offset`` with the
fitted offset); a ``cannot_tell`` whose held-out residual is mostly a constant
(``offset_share``) names it too instead of searching for missing linear dynamics.  A
``none`` whose training records show a gap says so.  The JSON contract
(:meth:`Diagnosis.as_dict`) only ever gains fields.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from robrst.data.dataset import check_sensor
import robrst.diagnose._signals as signals
from robrst.diagnose._effects import EFFECTS, INPUT_EFFECTS, THERMAL, Chain, summary
from robrst.diagnose._findings import (amplitude_finding, comparable, floor_of, noise_estimate,
                                      noise_levels, unmodelled_finding)
from robrst.diagnose.fit import fit_model, prepare
from robrst.diagnose.linear import LinearPart, as_modal, unexcited
from robrst.diagnose._periodic import with_periods
from robrst.diagnose.options import OPTIONS
from robrst.diagnose._sensor import repair
from robrst.diagnose.result import Diagnosis, EffectScore
from robrst.diagnose.candidates import DYNAMIC, OFFSET, Setup, cut, linear_with_offset
from robrst.diagnose._select import explain, significant
from robrst.diagnose._thermal import max_delay, search_delay
from robrst.diagnose._verdict import build, decide, unmodelled
from robrst.base.errors import DataError, SpecError
from robrst.core.plant import Plant, as_plant, paper_plant
from robrst.identify.modal import ModalModel
from robrst.base.threads import one_blas_thread

if TYPE_CHECKING:
    from robrst.core.plant import Plant
    from robrst.data.dataset import Dataset
    from robrst.diagnose.fit import Fitted
    from robrst.identify.modal import ModalModel

__all__ = ["Diagnosis", "EffectScore", "diagnose", "check_records", "decompose",
           "offset_finding", "polynomial_plant", "skipped_effects"]

_REC, _VERDICT = OPTIONS.records, OPTIONS.verdict


def check_records(train: Sequence[Dataset], test: Sequence[Dataset], n_in: int | None = None,
                  n_out: int | None = None) -> float:
    """Validate record sets; return the common sampling rate [Hz].

    Parameters
    ----------
    train, test : sequence of Dataset
        The training and test records.
    n_in, n_out : int, optional
        The model's channel counts the records must have.

    Returns
    -------
    float
        The sampling rate [Hz].

    Raises
    ------
    DataError
        Naming the file: empty sets, records shorter than ``min_samples``, a constant
        output while the input varies, sampling rates that differ (relative 1e-6) and
        channel counts that differ from each other or from the model's.
    """
    if not train or not test:
        raise DataError("diagnosis needs at least one training and one test record")
    recs = list(train) + list(test)
    first = recs[0].source or "the first record"
    k, m = (recs[0].n_in, recs[0].n_out) if n_in is None else (n_in, n_out)
    for d in recs:
        name = d.source or "record"
        if d.n < _REC.min_samples:
            raise DataError(f"{name}: too short ({d.n} samples); a diagnosis"
                            f" needs at least {_REC.min_samples} samples per record")
        if (d.n_in, d.n_out) != (k, m):
            raise DataError(f"{name}: {d.n_in} input(s) and {d.n_out} output(s), but the model"
                            f" has {k} and {m}")
        check_sensor(d)                  # u varies, a sensor column does not
    fs0 = recs[0].fs
    for d in recs[1:]:
        if abs(d.fs - fs0) > 1e-6 * fs0:
            raise DataError(f"{d.source or 'record'}: sampled at {d.fs:.6g} Hz but {first} at"
                            f" {fs0:.6g} Hz; resample to one rate")
    return fs0


def _excited(records):
    lim = _REC.excited_ptp
    return any(np.ptp(d.U, axis=0).max() > lim or (d.temp is not None and np.ptp(d.temp) > lim)
               for d in records)


def _name(d, i):
    return d.source or f"record{i}"


def polynomial_plant(plant: object, model: ModalModel) -> Plant | None:
    """The SISO :class:`~robrst.core.plant.Plant` of the model under diagnosis, or ``None``.

    ``thermal_dynamics`` runs the twin's full step, whose linear part is ``B(s)/A(s)``: a
    :class:`~robrst.identify.modal.ModalModel` (a model file of ``robrst identify``) is
    expanded (:meth:`~robrst.identify.modal.ModalModel.channel`); a model of several inputs
    or outputs, or one whose expanded coefficients overflow, has none.

    Parameters
    ----------
    plant : Plant or ModalModel
        The model as given.
    model : ModalModel
        Its modal form.

    Returns
    -------
    Plant or None
    """
    if isinstance(plant, Plant):
        return plant
    if (model.n_in, model.n_out) != (1, 1):
        return None
    try:
        return model.channel(0, 0)
    except SpecError:
        return None


def skipped_effects(train: Sequence[Dataset], test: Sequence[Dataset], effects: Sequence[str],
                    model: ModalModel, polynomial: bool = True) -> dict:
    """Effects not tried, with the reason.

    Parameters
    ----------
    train, test : sequence of Dataset
        The training and test records.
    effects : sequence of str
        The effects asked for.
    model : ModalModel
        The model under diagnosis.
    polynomial : bool
        Whether the model has SISO polynomials ``B(s)``, ``A(s)`` (:func:`polynomial_plant`):
        ``thermal_dynamics`` and ``stiffness_nonlinearity`` run the twin's step on them.

    Returns
    -------
    dict
        ``{effect: reason}``: temperature not excited, an effect of the input on records
        whose input is 0 V throughout, one input and output only (or polynomials that
        overflow), several only, or (amplitude-dependent dynamics) not periodic at two
        training levels.
    """
    out = {}
    temps = [d.temp for d in train if d.temp is not None]
    # within a record or across records (each at its own constant temperature)
    t_range = float(np.ptp(np.concatenate(temps))) if temps else 0.0
    siso = (model.n_in, model.n_out) == (1, 1)
    no_input = not any(np.any(d.U) for d in train)     # 0 V throughout (a drift record)
    for e in effects:
        if e in THERMAL and t_range < _REC.temp_excited_K:
            out[e] = (f"temperature constant within {t_range:.3g} K on the training records"
                      if temps else "no temperature measured")
        elif e in INPUT_EFFECTS and e not in THERMAL and no_input:
            out[e] = "the training input is 0 V throughout: nothing drives it"
        elif e in ("thermal_dynamics", "stiffness_nonlinearity") and not siso:
            out[e] = "one input and one output only"
        elif e == "cross_coupling" and siso:
            out[e] = "several inputs or outputs only"
        elif e == DYNAMIC and not _levels_ok(train, test):
            out[e] = "needs periodic records at two or more training levels"
        elif e in ("thermal_dynamics", "stiffness_nonlinearity") and not polynomial:
            out[e] = ("the model's polynomials B(s), A(s) overflow float64 (its order is too"
                      " high for the twin's linear step)")
    return out


def _levels_ok(train, test):
    """The dynamic form of hysteresis needs periodic records at >= 2 training levels."""
    recs = list(train) + list(test)
    if not all(d.period and d.periods >= 1 for d in recs):
        return False
    lv = sorted(d.level for d in train)
    return len(lv) >= 2 and lv[-1] > _REC.level_ratio * lv[0]


def diagnose(train: Sequence[Dataset], test: Sequence[Dataset], plant: Plant | ModalModel | None = None,
             reference_C: float | None = None, effects: Sequence[str] = EFFECTS,
             progress: Callable[[str], None] | None = None, workers: int = 2) -> Diagnosis:
    """Diagnose the gap between a simulation model and measured records.

    Parameters
    ----------
    train, test : list of Dataset
        Training records (candidates are fitted on them) and held-out test records
        (every reported gap is measured on them).  Same sampling rate and channels;
        ``u`` is the commanded input (open or closed loop).  Periodic records are
        simulated in steady state, the others from rest.
    plant : Plant, ModalModel or control.TransferFunction/StateSpace, optional
        The simulation model's linear dynamics (default: the paper's D(s), eq. 4);
        a :class:`~robrst.identify.modal.ModalModel` may have several inputs/outputs.
    reference_C : float, optional
        Temperature [°C] at which the model holds (default its ``temperature_C`` or
        28 °C); also the temperature of records without one.
    effects : sequence of str
        Effects to try (default all of :data:`EFFECTS`).
    progress : callable, optional
        Called with one line of text per stage and fit, prefixed with the seconds elapsed.
    workers : int
        Candidate fits run in this many threads.

    Returns
    -------
    Diagnosis

    Raises
    ------
    DataError
        Bad record sets (named); unknown effects.
    """
    t_start = time.perf_counter()
    say = (lambda m: None) if progress is None else (     # elapsed time on every line
        lambda m: progress(f"[{time.perf_counter() - t_start:6.1f} s] {m}"))
    plant = paper_plant() if plant is None else (
        plant if isinstance(plant, ModalModel) else as_plant(plant))
    model = as_modal(plant)
    fs = check_records(train, test, model.n_in, model.n_out)
    ref = reference_C if reference_C is not None else (model.temperature_C or 28.0)
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        raise DataError(f"unknown effect(s) {unknown}; expected {list(EFFECTS)}")
    train, found = with_periods(train)
    test, found_test = with_periods(test)
    with one_blas_thread():
        return _diagnose(train, test, plant, model, fs, float(ref), tuple(effects),
                         say, workers, t_start, found + found_test)


def _diagnose(train, test, plant, model, fs, ref, effects, say, workers, t_start, found=()):
    lin = LinearPart(model, fs)
    th0 = np.zeros(lin.size)
    all_recs = train + test
    n_tr = len(train)
    names = [_name(d, i) for i, d in enumerate(all_recs)]
    preps = [prepare(d, ref, for_fit=False) for d in all_recs]
    base_res = [p.Y - lin.simulate(th0, p.U, p.periodic) for p in preps]
    fixed, sensor = repair(all_recs, [p.Y - r for p, r in zip(preps, base_res)], fs)
    if sensor:          # outliers and dropouts set aside: the gap and the floor are the plant's
        sig_raw, _ = noise_levels(all_recs, base_res, fs)
        sensor["noise_floor_with_faults"] = floor_of(test, sig_raw[n_tr:])
        all_recs, train, test = fixed, fixed[:n_tr], fixed[n_tr:]
        preps = [prepare(d, ref, for_fit=False) for d in all_recs]
        base_res = [p.Y - lin.simulate(th0, p.U, p.periodic) for p in preps]
    before = signals.nrmse(test, base_res[n_tr:])
    before_train = signals.nrmse(train, base_res[:n_tr])
    noise = noise_estimate(all_recs, base_res, fs)
    sig, method = noise.levels, noise.method
    floor = floor_of(test, sig[n_tr:])
    floor_train = floor_of(train, sig[:n_tr])
    sigma = float(np.sqrt(np.mean(noise.upper ** 2)))    # priors and thresholds need a level
    say(f"gap of the simulation model on {len(test)} test record(s): NRMSE {before:.4g}"
        f" (noise floor {floor:.3g}, from {method.replace('_', ' ')})")
    faults = _sensor_finding(sensor, floor)
    if faults:
        say(f"sensor: {faults['message']}")
    periodic = _periodic_finding(found)
    if periodic:
        say(periodic["message"])
    undetermined = _undetermined_finding(noise, names)
    windows, frac = signals.time_windows(all_recs, base_res, sigma, names)
    band, f, P, level = signals.frequency_band(base_res, fs, sigma)
    dmodel = model.discretise(fs)
    where = {"time_windows": windows, "time_windows_energy_fraction": frac,
             "frequency_band_hz": band, "frf": signals.frf_departure(all_recs, dmodel, fs),
             "regime": signals.regime(all_recs, base_res, ref)}
    tests = {"whiteness": signals.whiteness(base_res),
             "cross_correlation": signals.cross_correlation(all_recs, base_res)}
    per_record = [{"file": n, "split": "train" if i < n_tr else "test",
                   "level_V": d.level, "periodic": bool(d.period),
                   "gap": signals.nrmse([d], [r]), "noise_floor": floor_of([d], [s])}
                  for i, (n, d, r, s) in enumerate(zip(names, all_recs, base_res, sig))]
    info = {"fs": fs, "ref": ref, "names": names, "n_train": n_tr, "before": before,
            "before_train": before_train, "floor": floor, "floor_train": floor_train, "sigma": sigma, "method": method,
            "per_record": per_record, "model": model, "plant": plant, "t_start": t_start}
    traces = {"names": names, "records": all_recs, "base_residuals": base_res,
              "psd_f": f, "psd": P, "noise_psd": level}
    siso = polynomial_plant(plant, model)
    skipped = skipped_effects(train, test, effects, model, siso is not None)
    tried = tuple(e for e in effects if e not in skipped)
    if not _excited(train) or not _excited(test):
        which = "training" if not _excited(train) else "test"
        return build(info, where, tests, traces, "cannot_tell",
                     f"the {which} records have no excitation (u and temp constant):"
                     " nothing distinguishes one effect from another", skipped=skipped)
    none_ratio, resolved = _VERDICT.none_ratio, _VERDICT.resolved_gap
    if before <= none_ratio * floor or before <= resolved:
        amp, info["per_level"] = amplitude_finding(all_recs, base_res, None, sig, n_tr)
        why = (f"within {none_ratio}x the noise floor {floor:.3g}" if before <= none_ratio * floor
               else f"below {resolved:g}: the model reproduces the records to six digits"
                    f" (noise floor {floor:.3g}, the records' own rounding)")
        why = f"held-out gap {before:.3g} is {why}"
        if before_train > _VERDICT.near_ratio * max(floor_train, resolved):
            why += (f"; but the training records show a gap ({before_train:.3g},"
                    f" {before_train / floor_train:.3g}x their noise floor) the test records do"
                    " not: the test records do not excite what causes it (add test records"
                    " like the training ones to diagnose it)")
        return build(info, where, tests, traces, "none", why, skipped=skipped,
                     findings=[amp, faults, periodic, undetermined], sensor=sensor)
    train_p = [prepare(d, ref) for d in train]
    lin_modal = LinearPart(model, fs, modal_gains=True)
    setup = Setup(fs=fs, ref=ref, train=train_p, train_full=preps[:n_tr], test=preps[n_tr:],
                  test_records=test, train_records=train, lin=lin,
                  lin_modal=lin_modal, stats=summary(train),
                  noise_sigma=sigma, plant=siso,
                  effects=tried + (OFFSET,), dynamic=DYNAMIC in tried,
                  delays=(search_delay(train_p, lin, max_delay(fs)) if "delay" in tried
                          else (0,) * model.n_in),
                  saturation=[], floor=floor, gap_before=before,
                  gap_before_train=before_train, workers=workers,
                  pinned=unexcited(lin, [d.U for d in train], fs),
                  pinned_modal=unexcited(lin_modal, [d.U for d in train], fs),
                  train_cut=cut(train_p), test_cut=cut(preps[n_tr:]))
    ex = explain(setup, say)
    linear, steps = ex.linear, ex.steps
    say("amplitude check: a linear model of the lowest training level at every level")
    amp, info["per_level"] = amplitude_finding(all_recs, base_res, _low_level_refit(
        setup, train, train_p, preps, ex.singles.get(DYNAMIC)), sig, n_tr)
    info["band"], info["regime"] = where["frequency_band_hz"], where["regime"]
    info["train_levels"] = [d.level for d in train]
    info["duration_s"] = max(d.n / fs for d in train)
    verdict = decide(info, ex, amp)
    cause, reason, causes, best, gap = (verdict.cause, verdict.reason, verdict.causes,
                                        verdict.best_partial, verdict.gap)
    findings = [amp, faults, periodic, undetermined]
    off = None
    if OFFSET in causes:            # selected on the same footing as the effects
        off = offset_finding(base_res[n_tr:], fitted=steps[-1][2].fit)
    elif cause == "cannot_tell" and not _curved(ex, floor):
        # nothing explains the gap and it is mostly a constant: say so (a sensor offset), and
        # do not search for missing dynamics (a higher order imitates a constant badly) --
        # unless a static output nonlinearity explains it better than a constant; measured
        # on what the best model found leaves, and only a constant of the sensor's
        held = steps[-1][2] if steps else linear
        off = offset_finding(held.residuals,
                             predicted=[p.Y - r for p, r in zip(preps[n_tr:], held.residuals)],
                             train_res=_train_residuals(setup, held))
    if off:
        findings.append(off)
        reason += f"; {off['message']}"
    # a linear model of a higher order cannot explain a gap that changes with the level
    level_dependent = amp is not None or any(k == DYNAMIC for k, _, _ in steps)
    if not off and not level_dependent and cause in ("cannot_tell", "linear") and (gap is None
                                                            or gap > _VERDICT.near_ratio * floor):
        # what is left may be linear dynamics the model lacks (a named effect's answer
        # says itself how much it leaves unexplained)
        hi = unmodelled(setup, linear, info)
        if hi and steps and gap is not None and hi[1] >= gap:
            hi = None
        un = unmodelled_finding(hi[0], hi[2], fs, hi[1], linear.gap, before, floor,
                                [d.U for d in train]) if hi else None
        if un:
            findings.append(un)
            reason += f"; {un['message']}"
    say(f"cause: {cause} ({reason})")
    if OFFSET in causes:
        shares = decompose(base_res[n_tr:], before, floor, linear.residuals,
                           steps[-1][2].fit.output_offset(), linear_with_offset(setup).residuals)
    else:
        shares = decompose(base_res[n_tr:], before, floor, linear.residuals)
    return build(info, where, tests, traces, cause, reason, skipped=skipped, findings=findings,
                 linear=linear, singles=ex.singles, steps=steps, causes=causes,
                 best_partial=best, decomposition=shares, explanation=ex, sensor=sensor,
                 ties=verdict.ties)


def _sensor_finding(sensor, floor):
    """``sensor_faults`` finding from :func:`robrst.diagnose._sensor.repair`'s report."""
    if not sensor:
        return None
    drops = [f"{a:.4g}–{b:.4g} s" for r in sensor["records"] for a, b in r["dropouts_s"]][:4]
    return {"kind": "sensor_faults", "outliers": sensor["outliers"],
            "dropouts": sensor["dropouts"], "share": sensor["share"],
            "message": (f"the records hold {sensor['outliers']} outlier(s) and"
                        f" {sensor['dropouts']} dropout(s) of the sensor"
                        f"{' (' + ', '.join(drops) + ')' if drops else ''},"
                        f" {100 * sensor['share']:.2g} % of the samples; they are set aside"
                        " (replaced by the model plus the residual interpolated across them):"
                        f" noise floor {floor:.3g}, {sensor['noise_floor_with_faults']:.3g}"
                        " with them")}


def _periodic_finding(found):
    """``periodic_records`` finding: records without ``period_samples`` whose input repeats."""
    if not found:
        return None
    per = sorted({(f["period_samples"], f["periods"]) for f in found})
    txt = ", ".join(f"{p} samples ({k} periods)" for p, k in per)
    return {"kind": "periodic_records", "records": [f["file"] for f in found],
            "period_samples": [f["period_samples"] for f in found],
            "message": (f"the input of {len(found)} record(s) without period_samples repeats"
                        f" every {txt}: they are simulated in periodic steady state and their"
                        " noise floor comes from the period-to-period differences")}


def _undetermined_finding(noise, names):
    """``noise_undetermined`` finding: records whose input excites every band."""
    if not noise.undetermined:
        return None
    which = [names[i] for i in noise.undetermined]
    return {"kind": "noise_undetermined", "records": which,
            "message": (f"the input of {len(which)} record(s) excites every frequency band and"
                        " they are not periodic: their noise cannot be told from a model error"
                        " and counts as 0 in the noise floor (periodic records, or a band"
                        " left unexcited, would give it)")}


def _train_residuals(setup, sc):
    """Training residuals (whole records) of a scored candidate, or None."""
    if not hasattr(sc.fit, "predict_prepared"):
        return None
    return [p.Y - sc.fit.predict_prepared(p) for p in setup.train_full]


def _curved(ex, floor):
    """Does a static output nonlinearity explain the held-out gap better than a constant?"""
    a, b = ex.singles.get("output_nonlinearity"), ex.singles.get(OFFSET)
    return a is not None and b is not None and significant(a.gap, b.gap, floor)


def _low_level_refit(setup, train, train_p, preps, dynamic=None):
    """Residuals (all records) of a linear re-fit on the lowest training level, or None.

    The amplitude-dependent dynamics fitted level by level holds that fit already: its
    corrections at the lowest level (no second fit of the same records).
    """
    recs = list(setup.train_records) + list(setup.test_records)
    low_rec = min(recs, key=lambda d: d.level)
    if not any(d.level > _REC.level_ratio * low_rec.level and comparable(d, low_rec)
               for d in recs):
        return None
    fit = getattr(dynamic, "fit", None)
    if fit is not None and getattr(fit, "slopes", None) and not fit.chain.size:
        lin, th = fit.lin, fit.theta_at(fit.level_ref)
        model = lin.continuous(th).discretise(setup.fs)
        return [p.Y - model.response(p.U, periodic=p.periodic) for p in preps]
    lowest = min(d.level for d in train)
    low = [p for p, d in zip(train_p, train) if d.level <= lowest * (1 + OPTIONS.levels.lowest_tol)]
    ch = Chain((), setup.lin.model.n_in, setup.fs, setup.ref, setup.stats, cache=setup.stages)
    fit = fit_model("linear@low", (), low, setup.lin, ch, setup.noise_sigma, joint=True,
                    max_nfev=OPTIONS.fit.low_level_nfev, ftol=OPTIONS.fit.ftol)
    return [p.Y - fit.predict_prepared(p) for p in preps]


def decompose(res: Sequence[np.ndarray], before: float, floor: float,
              linear_res: Sequence[np.ndarray], offset: np.ndarray | None = None,
              offset_linear_res: Sequence[np.ndarray] | None = None) -> dict[str, float]:
    """Shares of the held-out residual's mean square by nested models: a partition.

    Parameters
    ----------
    res : list of array
        Held-out residuals of the model under diagnosis (per test record).
    before, floor : float
        Their NRMSE and the noise floor (same units).
    linear_res : list of array
        Held-out residuals of the linear re-fit.
    offset : array, optional
        The constant output offset per output of the answer, when it includes
        ``output_offset``.
    offset_linear_res : list of array, optional
        With ``offset``: held-out residuals of the linear re-fit with a constant output
        offset fitted jointly.

    Returns
    -------
    dict
        ``offset``, ``linear_model_error``, ``noise``, ``unexplained_by_linear``: each a
        share of the residual's sum of squares, removed in this order.  When the answer
        includes ``output_offset`` the constant comes first (what subtracting the answer's
        fitted offset removes from ``res``), then the linear re-fit (what the joint re-fit
        with an offset removes on top); otherwise the linear re-fit first (``1 - (gap_refit /
        gap)^2``), then what a constant removes from the re-fit's residual — so an offset
        an effect causes is not counted as one.  Then the noise floor, and what is left.
        Shares are clamped at 0 (a re-fit worse on the held-out records removes nothing).
    """
    total = _ss(res)
    if total <= 0:
        return {"offset": 0.0, "noise": 1.0, "linear_model_error": 0.0,
                "unexplained_by_linear": 0.0}
    if offset is not None:
        c = np.ravel(offset)
        shifted = [np.asarray(r, float).reshape(len(r), -1) - c[None, :] for r in res]
        off = min(1.0, max(0.0, 1.0 - _ss(shifted) / total))
        lin = max(0.0, 1.0 - off - _ss(offset_linear_res) / total)
    else:
        lin = max(0.0, 1.0 - _ss(linear_res) / total)
        off = min(1.0 - lin, _constant_ss(linear_res) / total)
    offset = off
    noise = min(1.0 - offset - lin, (floor / before) ** 2) if before > 0 else 1.0 - offset - lin
    return {"offset": offset, "noise": noise, "linear_model_error": lin,
            "unexplained_by_linear": max(0.0, 1.0 - offset - noise - lin)}


def _ss(res):
    return float(sum(np.sum(np.asarray(r, float) ** 2) for r in res))


def _constant_ss(res):
    """What a constant per output removes from the residuals' sum of squares."""
    R = np.concatenate([np.asarray(r, float).reshape(len(r), -1) for r in res])
    return float(R.shape[0] * np.sum(R.mean(axis=0) ** 2))


def _offset(res):
    """The residuals' mean and its share of their mean square."""
    allr = np.concatenate([np.asarray(r).ravel() for r in res])
    ms = float(np.mean(allr ** 2))
    mean = float(np.mean(allr))
    return mean, (mean ** 2 / ms if ms > 0 else 0.0)


def _gain_share(res, predicted):
    """The share of the residuals' mean square a constant and a gain (``a + b y``) remove."""
    r = np.concatenate([np.asarray(x, float).ravel() for x in res])
    y = np.concatenate([np.asarray(x, float).ravel() for x in predicted])
    A = np.column_stack([np.ones_like(y), y])
    coef = np.linalg.lstsq(A, r, rcond=None)[0]
    ss = float(np.sum(r * r))
    return 1.0 - float(np.sum((r - A @ coef) ** 2)) / ss if ss > 0 else 0.0


def offset_finding(res: Sequence[np.ndarray], fitted: Fitted | None = None,
                   predicted: Sequence[np.ndarray] | None = None,
                   train_res: Sequence[np.ndarray] | None = None) -> dict | None:
    """``output_offset`` finding, or None.

    With ``fitted`` (the answer's fit, which includes a constant output offset) the
    offset is the fitted one and the finding is always made; its ``share`` is what that
    constant alone is of the held-out residual's mean square.  Without, the finding (a
    sensor zero the records should lose) is made when a constant is most
    (``offset_share``) of the held-out residual ``res`` of the best model found, *and* it
    is a sensor's: a gain (the model's output ``predicted`` scaled) does not explain the
    residual better (a gain change between records moves an output's mean), and the
    training residual ``train_res`` holds the same constant within a quarter (hysteresis
    or a drift shifts each record's mean by its own amount; a sensor zero is the same in
    every record).

    Parameters
    ----------
    res : sequence of numpy.ndarray
        Held-out residuals per test record.
    fitted : Fitted, optional
        The answer's fit.
    predicted : sequence of numpy.ndarray, optional
        The model's held-out outputs (per test record).
    train_res : sequence of numpy.ndarray, optional
        The same model's training residuals.

    Returns
    -------
    dict or None
        ``{"kind": "output_offset", "offset_um", "share"}``.
    """
    if fitted is not None:
        vals = list(fitted.params()["output_offset"][0].values())
        allr = np.concatenate([np.asarray(r).ravel() for r in res])
        ms = float(np.mean(allr ** 2))
        mean = vals[0] if len(vals) == 1 else vals
        share = float(np.mean(np.square(vals)) / ms) if ms > 0 else 0.0
        txt = ", ".join(f"{v:.4g}" for v in vals)
        return {"kind": "output_offset", "offset_um": mean, "share": min(share, 1.0),
                "message": (f"a constant output offset of {txt} µm (fitted with the other"
                            " corrections): a sensor zero or bias the model lacks, not a"
                            " dynamic effect")}
    mean, share = _offset(res)
    if share < _VERDICT.offset_share:
        return None
    if predicted is not None and _gain_share(res, predicted) > share + _VERDICT.gain_share:
        return None                      # a gain explains it: not a constant of the sensor
    if train_res is not None:
        t_mean, _ = _offset(train_res)
        if abs(t_mean - mean) > _VERDICT.offset_agree * abs(mean):
            return None                  # not the same in the training records
    return {"kind": "output_offset", "offset_um": mean, "share": share,
            "message": (f"the held-out residual is mostly a constant offset ({mean:.4g} µm,"
                        f" {100 * share:.1f} % of its mean square): a sensor zero or bias the"
                        " model lacks, not a dynamic effect; remove it from the records (or"
                        " add it to the model) and diagnose again")}
