"""The sim-to-real gap diagnosis: measure, localise, explain, quantify.

Pipeline (:func:`diagnose`)::

    train + test records --check--> base simulation (the model under diagnosis)
      -> gap on test (NRMSE) and its noise floor
      -> where: time windows, frequency band, FRF departure, regime, residual tests
      -> each library effect fitted on train, scored on test; the linear re-fit too
      -> verdict: none | <effect> | linear | cannot_tell

Decision rules (constants below): the gap is at the noise floor (``none``) when the
test NRMSE is within ``NONE_RATIO`` of the floor; an effect is named only if it
shrinks the held-out gap by at least ``MIN_SHRINK`` and beats both the linear re-fit
and the runner-up by ``MARGIN`` in held-out gap; otherwise the answer is the linear
model (a re-fit does as well) or ``cannot_tell`` with the reason.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

from robrst.diagnose import signals
from robrst.diagnose.effects import EFFECTS, fit_effect, fit_linear
from robrst.diagnose.linear import LinearSim
from robrst.errors import DataError
from robrst.plant import paper_plant

__all__ = ["Diagnosis", "EffectScore", "diagnose", "check_records", "MIN_SAMPLES"]

MIN_SAMPLES = 500        # per record
NONE_RATIO = 1.25        # gap <= 1.25 x noise floor: nothing to explain
MIN_SHRINK = 0.3         # an explanation must remove >= 30 % of the held-out gap
MARGIN = 1.1             # winner's held-out gap must be 10 % below the alternatives'


@dataclass(frozen=True)
class EffectScore:
    """One candidate's held-out result (gap on the test records)."""

    name: str
    gap_before: float
    gap_after: float
    shrink: float
    train_gap: float
    params: dict
    params_std: dict
    n_eval: int
    fit_s: float

    def as_dict(self):
        return {"name": self.name, "gap_before": self.gap_before, "gap_after": self.gap_after,
                "shrink": self.shrink, "train_gap": self.train_gap, "params": self.params,
                "params_std": self.params_std, "n_eval": self.n_eval, "fit_s": self.fit_s}


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Result of :func:`diagnose`; :meth:`as_dict` is the public JSON contract."""

    cause: str
    reason: str
    gap_before: float
    noise_floor: float
    gap_train: float
    effects: tuple            # EffectScore, best first
    linear_refit: EffectScore
    where: dict
    tests: dict
    decomposition: dict
    data: dict
    model: dict
    traces: dict = field(default_factory=dict, repr=False)   # arrays for reports

    @property
    def winner(self):
        return next((e for e in self.effects if e.name == self.cause), None)

    def as_dict(self):
        d = {"cause": self.cause, "reason": self.reason,
             "gap": {"metric": "nrmse", "before": self.gap_before, "noise_floor": self.noise_floor,
                     "after": self._after(), "before_train": self.gap_train},
             "effects": [e.as_dict() for e in self.effects],
             "linear_refit": self.linear_refit.as_dict() if self.linear_refit else None,
             "where": self.where, "tests": self.tests, "decomposition": self.decomposition,
             "data": self.data, "model": self.model}
        return _finite(d)

    def _after(self):
        if self.cause == "linear":
            return self.linear_refit.gap_after
        w = self.winner
        return w.gap_after if w else None


def _finite(x):
    """Non-finite floats become None (JSON has no inf/nan)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


def check_records(train, test):
    """Validate record sets; return the common sampling rate [Hz].

    Raises :class:`DataError` naming the file for empty sets, records shorter than
    ``MIN_SAMPLES`` and sampling rates that differ (relative 1e-6).
    """
    if not train or not test:
        raise DataError("diagnosis needs at least one training and one test record")
    recs = list(train) + list(test)
    for d in recs:
        if d.n < MIN_SAMPLES:
            raise DataError(f"{d.source or 'record'}: too short ({d.n} samples); a diagnosis"
                            f" needs at least {MIN_SAMPLES} samples per record")
        if np.ptp(d.y) == 0.0 and np.ptp(d.u) > 0.0:   # both constant: no excitation
            raise DataError(f"{d.source or 'record'}: column y is constant ({d.y[0]:g} µm)"
                            " while u varies: no sensor signal to compare the model with")
    fs0 = recs[0].fs
    for d in recs[1:]:
        if abs(d.fs - fs0) > 1e-6 * fs0:
            raise DataError(f"{d.source or 'record'}: sampled at {d.fs:.6g} Hz but"
                            f" {recs[0].source or 'the first record'} at {fs0:.6g} Hz;"
                            " resample to one rate")
    return fs0


def _excited(records):
    return any(np.ptp(d.u) > 1e-6 or np.ptp(d.temp) > 1e-6 for d in records)


def _name(d, i):
    return d.source or f"record{i}"


def _score(fit, test, gap_before, train, fit_s):
    res_te = [d.y - fit.predict(d) for d in test]
    res_tr = [d.y - fit.predict(d) for d in train]
    after = signals.nrmse(test, res_te)
    return EffectScore(name=fit.name, gap_before=gap_before, gap_after=after,
                       shrink=1.0 - after / gap_before if gap_before > 0 else 0.0,
                       train_gap=signals.nrmse(train, res_tr), params=fit.params,
                       params_std=fit.std, n_eval=fit.n_eval, fit_s=fit_s), res_te


def diagnose(train, test, plant=None, reference_C=None, effects=EFFECTS, progress=None):
    """Diagnose the gap between a simulation model and measured records.

    Parameters
    ----------
    train, test : list of Dataset
        Training records (effects are fitted on them) and held-out test records
        (every reported gap is measured on them).  Same sampling rate; each record
        starts at rest; ``u`` is the commanded voltage (open or closed loop).
    plant : Plant, optional
        The simulation model's linear dynamics (default: the paper's D(s), eq. 4).
    reference_C : float, optional
        Temperature [°C] at which ``plant`` holds (default ``plant.temperature_C``
        or 28 °C).
    effects : sequence of str
        Effects to try (default all of :data:`EFFECTS`).
    progress : callable, optional
        Called with one line of text per stage.

    Returns
    -------
    Diagnosis
    """
    say = progress or (lambda m: None)
    fs = check_records(train, test)
    plant = plant or paper_plant()
    ref = reference_C if reference_C is not None else (plant.temperature_C or 28.0)
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        raise DataError(f"unknown effect(s) {unknown}; expected {list(EFFECTS)}")
    lin = LinearSim.of(plant, fs)
    all_recs = list(train) + list(test)
    names = [_name(d, i) for i, d in enumerate(all_recs)]
    base_res = [d.y - lin(d.u) for d in all_recs]
    res_te = base_res[len(train):]
    before = signals.nrmse(test, res_te)
    before_train = signals.nrmse(train, base_res[:len(train)])
    var = np.array([signals.noise_sigma(r, fs) ** 2 for r in base_res])  # once per record
    sig_te = np.sqrt(np.mean(var[len(train):]))
    floor = signals.nrmse(test, [np.full(d.n, sig_te) for d in test])
    sigma = np.sqrt(np.mean(var))
    say(f"gap of the simulation model on {len(test)} test record(s): NRMSE {before:.4g}"
        f" (noise floor {floor:.3g})")
    windows, frac = signals.time_windows(all_recs, base_res, sigma, names)
    band, f, P, level = signals.frequency_band(base_res, fs, sigma)
    where = {"time_windows": windows, "time_windows_energy_fraction": frac,
             "frequency_band_hz": band, "frf": signals.frf_departure(all_recs, plant, fs),
             "regime": signals.regime(all_recs, base_res, ref)}
    tests = {"whiteness": signals.whiteness(base_res),
             "cross_correlation": signals.cross_correlation(all_recs, base_res)}
    data = {"fs_hz": fs, "train": names[:len(train)], "test": names[len(train):],
            "samples": int(sum(d.n for d in all_recs)), "noise_sigma_um": float(sigma)}
    model = {"B": [float(v) for v in plant.B], "A": [float(v) for v in plant.A],
             "label": plant.label, "reference_C": float(ref)}
    traces = {"names": names, "records": all_recs, "base_residuals": base_res,
              "psd_f": f, "psd": P, "noise_psd": level}

    def verdict(cause, reason, scores=(), linear=None, decomposition=None):
        return Diagnosis(cause=cause, reason=reason, gap_before=before, noise_floor=floor,
                         gap_train=before_train,
                         effects=tuple(scores), linear_refit=linear, where=where, tests=tests,
                         decomposition=decomposition or {}, data=data, model=model,
                         traces=traces)

    if not _excited(train) or not _excited(test):
        which = "training" if not _excited(train) else "test"
        return verdict("cannot_tell", f"the {which} records have no excitation (u and temp"
                       " constant): nothing distinguishes one effect from another")
    scores, fits = [], {}
    for k, name in enumerate(list(effects) + ["linear"], start=1):
        t0 = time.perf_counter()
        fit = (fit_linear(train, plant, fs) if name == "linear"
               else fit_effect(name, train, plant, fs, ref))
        sc, r = _score(fit, test, before, train, time.perf_counter() - t0)
        fits[name] = r
        scores.append(sc)
        say(f"[{k}/{len(effects) + 1}] {name:<17} held-out gap {before:.4g} -> {sc.gap_after:.4g}"
            f" (shrink {100 * sc.shrink:.1f} %, {sc.n_eval} evaluations, {sc.fit_s:.1f} s)")
    linear = scores.pop()
    scores.sort(key=lambda s: s.gap_after)
    traces["fit_residuals"] = fits
    decomposition = _decompose(res_te, before, floor, linear)
    cause, reason = _decide(before, floor, scores, linear)
    if cause == "none" and before_train > 2 * NONE_RATIO * floor:
        reason += (f"; the training records do show a gap ({before_train:.3g}) that the test"
                   " records do not excite")
    say(f"cause: {cause} ({reason})")
    return verdict(cause, reason, scores, linear, decomposition)


def _decompose(res, before, floor, linear):
    """Shares of the held-out residual's mean square: offset, noise, linear, rest."""
    ms = float(np.mean(np.concatenate(res) ** 2))
    offset = float(np.mean(np.concatenate(res)) ** 2) / ms if ms > 0 else 0.0
    noise = min(1.0, (floor / before) ** 2) if before > 0 else 1.0
    lin = max(0.0, 1.0 - (linear.gap_after / before) ** 2) if before > 0 else 0.0
    lin = min(lin, 1.0 - noise)
    return {"offset": offset, "noise": noise, "linear_model_error": lin,
            "unexplained_by_linear": max(0.0, 1.0 - noise - lin)}


def _decide(before, floor, scores, linear):
    if before <= NONE_RATIO * floor:
        return "none", (f"held-out gap {before:.3g} is within {NONE_RATIO}x the noise floor"
                        f" {floor:.3g}")
    best = scores[0]
    if best.shrink < MIN_SHRINK and linear.shrink < MIN_SHRINK:
        return "cannot_tell", (f"no effect in the library nor a linear re-fit removes"
                               f" {100 * MIN_SHRINK:.0f} % of the held-out gap (best:"
                               f" {best.name}, {100 * best.shrink:.0f} %)")
    if linear.gap_after <= best.gap_after * MARGIN:
        return "linear", (f"a re-fit of the linear model does as well (held-out gap"
                          f" {linear.gap_after:.3g} vs {best.gap_after:.3g} with {best.name})")
    if best.shrink < MIN_SHRINK:
        return "cannot_tell", f"best effect {best.name} removes only {100 * best.shrink:.0f} %"
    runner = scores[1] if len(scores) > 1 else None
    if runner is not None and runner.gap_after <= best.gap_after * MARGIN and runner.shrink >= MIN_SHRINK:
        return "cannot_tell", (f"{best.name} and {runner.name} explain the held-out gap equally"
                               f" well ({best.gap_after:.3g} vs {runner.gap_after:.3g})")
    return best.name, (f"adding {best.name} shrinks the held-out gap by {100 * best.shrink:.0f} %"
                       f" ({before:.3g} -> {best.gap_after:.3g}; noise floor {floor:.3g})")
