"""The diagnosis result record and its JSON contract (fields are only ever added).

Contract of ``robrst diagnose --json`` (:meth:`Diagnosis.as_dict`): ``cause``,
``reason``, ``gap{metric, before, noise_floor, after, before_train, noise_floor_method,
per_record[], per_level[]}``, ``effects[]`` (each candidate alone, best first:
``name, gap_before, gap_after, shrink, train_gap, params, params_std, n_eval, fit_s,
form, overfit``), ``linear_refit{...}``, ``where{...}``, ``tests{...}``,
``decomposition``, ``data``, ``model``, and (added) ``causes[]``, ``selected[]``,
``final{}``, ``findings[]``, ``best_partial``, ``skipped{}``, ``seconds``,
``output_offset{}`` (the constant output offset screened alone, same fields as an
effect's; it is a candidate but not an effect, so not in ``effects[]``), and (added)
``effects[].method`` (``fit``: its own nonlinear model; ``screen``: the exact linear
screen only), ``selected[].gap_without`` and ``selected[].credit`` (the held-out gap of
the answer without that effect, and the share of the excess gap it removes),
``not_causes[]`` (effects selected but credited nothing by removal), ``alternatives[]``
(what could stand in place of each cause, and its held-out gap), ``screen[]`` (every
candidate's screened held-out gap) and ``sensor{}`` (outliers and dropouts found in the
records), and (added) ``ties[]`` (a slot of the selection the records cannot settle:
``slot``, ``effects``, ``gaps``, ``after``, ``record``, ``message``; the effects of the
other slots stay in ``causes``), ``selected[].tied_with`` and ``selection[]`` (every
decision of the forward selection, in order), and (added) ``selected[].input_gain_sector``
(a Bouc–Wen hysteresis's ``nominal, delta, slopes, range_V``:
:func:`robrst.twin.model.hysteresis_sector`).

Every section is a frozen record (:class:`Where`, :class:`ResidualTests`,
:class:`SelectedEffect`, :class:`FinalFit`, :class:`Finding`, :class:`Tie`, ...), a field of
:class:`Diagnosis`; the JSON is written once from them (:meth:`Diagnosis.as_dict`), in the
order published as ``docs/reference/diagnose.schema.json``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.diagnose._stiffness import StiffnessFit
    from robrst.diagnose._thermal import ThermalFit
    from robrst.diagnose.fit import Fitted
    from robrst.twin.model import GainSector

__all__ = ["EffectScore", "Diagnosis", "finite", "RecordGap", "LevelGap", "TimeWindow",
           "FrfDeparture", "Regime", "Where", "ResidualTest", "ResidualTests", "RecordsUsed",
           "ModelDiagnosed", "SelectedEffect", "TestGap", "FinalFit", "PartialExplanation",
           "NotCause", "Alternative", "ScreenGap", "Tie", "SensorRecord", "SensorReport",
           "Finding", "Traces"]


class _Section:
    """A section of the diagnosis JSON: its fields in order, records and tuples made plain.

    ``_json_names`` renames a field in the JSON, ``_merged`` merges a mapping field's items
    into the section, ``_omitted_if_none`` leaves a field out while it is ``None`` (a field
    the JSON has only in some answers).
    """

    _json_names: ClassVar[Mapping[str, str]] = {}
    _merged: ClassVar[tuple[str, ...]] = ()
    _omitted_if_none: ClassVar[tuple[str, ...]] = ()

    def as_dict(self) -> dict:
        """The section as the diagnosis JSON holds it.

        Returns
        -------
        dict
        """
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None and f.name in self._omitted_if_none:
                continue
            if f.name in self._merged:
                out.update(_plain(v))
            else:
                out[self._json_names.get(f.name, f.name)] = _plain(v)
        return out


def _plain(x: Any) -> Any:
    if hasattr(x, "as_dict"):
        return x.as_dict()
    if isinstance(x, Mapping):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    return x


@dataclass(frozen=True)
class EffectScore(_Section):
    """One candidate's held-out result (gap on the test records).

    Parameters
    ----------
    name : str
        The effect (or ``"linear"``, ``"output_offset"``, a joint selection's name).
    gap_before : float
        Held-out NRMSE of the model under diagnosis.
    gap_after : float
        Held-out NRMSE with the candidate fitted.
    shrink : float
        ``1 - gap_after / gap_before``.
    train_gap : float
        NRMSE on the training records with the candidate.
    params : dict
        Fitted parameters.
    params_std : dict
        Their 1-sigma (``inf``: not determined by the data).
    n_eval : int
        Model evaluations of the fit.
    fit_s : float
        Wall time of the fit [s].
    form : str
        ``"input"`` (the twin's parametrisation), ``"prandtl_ishlinskii"`` (hysteresis as
        play operators), ``"dynamic"`` (amplitude-dependent dynamics) or ``"output"``.
    overfit : bool
        The fit improves the training records but not the held-out ones.
    method : str
        ``"fit"`` (its own nonlinear model) or ``"screen"`` (the exact linear screen only;
        the gaps on the screened samples).
    """

    name: str
    gap_before: float
    gap_after: float
    shrink: float
    train_gap: float
    params: Mapping[str, float]
    params_std: Mapping[str, float]
    n_eval: int
    fit_s: float
    form: str = "input"
    overfit: bool = False
    method: str = "fit"       # "fit" (its own nonlinear model) or "screen" (linear columns)


@dataclass(frozen=True)
class RecordGap(_Section):
    """The gap of the model under diagnosis on one record.

    Parameters
    ----------
    file : str
        The record.
    split : str
        ``"train"`` or ``"test"``.
    level_V : float
        Its excitation level (input RMS) [V].
    periodic : bool
        A periodic record.
    gap : float
        Its NRMSE.
    noise_floor : float
        Its noise floor (same units).
    """

    file: str
    split: str
    level_V: float
    periodic: bool
    gap: float
    noise_floor: float


@dataclass(frozen=True)
class LevelGap(_Section):
    """The gap of the model under diagnosis on the records of one excitation level.

    Parameters
    ----------
    level_V : float
        The level (input RMS) [V].
    records : tuple of str
        Its records.
    split : tuple of str
        Their split (``"train"`` or ``"test"``).
    gap : float
        Their NRMSE.
    noise_floor : float
        Their noise floor.
    """

    level_V: float
    records: tuple[str, ...]
    split: tuple[str, ...]
    gap: float
    noise_floor: float


@dataclass(frozen=True)
class TimeWindow(_Section):
    """A time window where the residual stands above three times the noise.

    Parameters
    ----------
    file : str
        The record.
    start_s, end_s : float
        The window [s].
    rms_um : float
        The residual's RMS in it [µm].
    """

    file: str
    start_s: float
    end_s: float
    rms_um: float


@dataclass(frozen=True)
class FrfDeparture(_Section):
    """Where the measured frequency response departs from the model's.

    Parameters
    ----------
    band_hz : tuple of float or None
        The band of the bins that depart (``None``: none does).
    max_rel_error : float or None
        The largest relative departure (over the departing bins, else over the coherent
        ones; ``None`` without coherent bins).
    bins : int
        The departing bins.
    """

    band_hz: tuple[float, float] | None
    max_rel_error: float | None
    bins: int


@dataclass(frozen=True)
class Regime(_Section):
    """Which operating regime explains the residual's variance (its ``eta2`` share).

    Parameters
    ----------
    shares : Mapping
        Per regime variable (``temperature``, ``amplitude``, ``direction``, ...) its share
        (``None`` where the records do not vary it).
    dominant : str or None
        The variable of the largest share.
    measure : str
        ``"eta2"`` (the correlation ratio).
    """

    shares: Mapping[str, float | None]
    dominant: str | None
    measure: str = "eta2"
    _merged: ClassVar[tuple[str, ...]] = ("shares",)


@dataclass(frozen=True)
class Where(_Section):
    """Where the gap lies: in time, in frequency, in the frequency response, in a regime.

    Parameters
    ----------
    time_windows : tuple of TimeWindow
        The windows above three times the noise, largest residual first.
    energy_fraction : float
        The share of the residual's energy they hold (JSON
        ``time_windows_energy_fraction``).
    frequency_band_hz : tuple of float or None
        The band holding 95 % of the residual's excess over the noise (``None``: the
        spectrum is at the noise floor).
    frf : FrfDeparture
        The frequency response's departure.
    regime : Regime
        The regime that explains the residual.
    """

    time_windows: tuple[TimeWindow, ...]
    energy_fraction: float
    frequency_band_hz: tuple[float, float] | None
    frf: FrfDeparture
    regime: Regime
    _json_names: ClassVar[Mapping[str, str]] = {"energy_fraction": "time_windows_energy_fraction"}


@dataclass(frozen=True)
class ResidualTest(_Section):
    """A correlation test of the residual (99 %, Bonferroni over the lags).

    Parameters
    ----------
    statistic : str
        The statistic's JSON name (``max_abs_autocorr`` or ``max_abs_crosscorr``).
    value : float
        Its value.
    bound : float
        The test's bound.
    passed : bool
        ``value <= bound``.
    """

    statistic: str
    value: float
    bound: float
    passed: bool

    def as_dict(self) -> dict:
        """The test as the diagnosis JSON holds it.

        Returns
        -------
        dict
        """
        return {self.statistic: self.value, "bound": self.bound, "passed": self.passed}


@dataclass(frozen=True)
class ResidualTests(_Section):
    """The residual's whiteness and its cross-correlation with the input.

    Parameters
    ----------
    whiteness : ResidualTest
        Autocorrelation at lags 1..max_lag.
    cross_correlation : ResidualTest
        Residual-input cross-correlation.
    """

    whiteness: ResidualTest
    cross_correlation: ResidualTest


@dataclass(frozen=True)
class RecordsUsed(_Section):
    """The records the diagnosis used.

    Parameters
    ----------
    fs_hz : float
        Sampling rate [Hz].
    train, test : tuple of str
        The records' names.
    samples : int
        Samples in all.
    noise_sigma_um : float
        The noise level used by priors and thresholds [µm].
    inputs, outputs : int
        Channels.
    periodic : tuple of bool
        Per record (training first).
    """

    fs_hz: float
    train: tuple[str, ...]
    test: tuple[str, ...]
    samples: int
    noise_sigma_um: float
    inputs: int
    outputs: int
    periodic: tuple[bool, ...]


@dataclass(frozen=True)
class ModelDiagnosed(_Section):
    """The model under diagnosis.

    Parameters
    ----------
    B, A : tuple of float or None
        Its numerator and denominator (one channel; ``None`` for a multi-channel model).
    label : str
        Its label.
    reference_C : float
        The reference temperature [°C].
    inputs, outputs, order : int
        Its channels and order.
    poles_hz : tuple of float
        Its poles' magnitudes [Hz], ascending.
    """

    B: tuple[float, ...] | None
    A: tuple[float, ...] | None
    label: str
    reference_C: float
    inputs: int
    outputs: int
    order: int
    poles_hz: tuple[float, ...]


@dataclass(frozen=True)
class SelectedEffect(_Section):
    """An effect the forward selection chose, in the final joint fit.

    Parameters
    ----------
    name : str
        The effect.
    form : str
        Its form (see :class:`EffectScore`).
    gap_before, gap_after : float
        The held-out gap before and after its slot.
    tied_with : str or None
        The effect these records cannot tell from it.
    shrink : float
        ``1 - gap_after / gap_before``.
    params, params_std : Mapping
        Its parameters in the final joint fit, and their 1-sigma.
    gap_without : float or None
        The held-out gap of the answer without it.
    credit : float or None
        The share of the excess gap it removes.
    input_gain_sector : GainSector, optional
        A Bouc–Wen hysteresis as an input-gain sector
        (:func:`robrst.twin.model.hysteresis_sector`).
    """

    name: str
    form: str
    gap_before: float
    gap_after: float
    tied_with: str | None
    shrink: float
    params: Mapping[str, float]
    params_std: Mapping[str, float]
    gap_without: float | None
    credit: float | None
    input_gain_sector: GainSector | None = None
    _omitted_if_none: ClassVar[tuple[str, ...]] = ("input_gain_sector",)


@dataclass(frozen=True)
class TestGap(_Section):
    """The final model's gap on one test record.

    Parameters
    ----------
    file : str
        The record.
    gap : float
        Its NRMSE.
    """

    __test__ = False     # not a test class (its name starts with Test)
    file: str
    gap: float


@dataclass(frozen=True)
class FinalFit(_Section):
    """The final joint fit of the selected effects and the linear corrections.

    Parameters
    ----------
    effects : tuple of str
        The selected effects.
    gap_after : float
        Its held-out gap.
    shrink : float
        ``1 - gap_after / gap_before``.
    train_gap : float
        Its gap on the training records.
    linear_change, linear_change_std : Mapping
        How the linear part moved (log ratios, relative gains), and their 1-sigma.
    linear_moved : float
        The largest move.
    n_eval : int
        Model evaluations of the fit.
    gap_per_record : tuple of TestGap
        Its gap on each test record.
    """

    effects: tuple[str, ...]
    gap_after: float
    shrink: float
    train_gap: float
    linear_change: Mapping[str, float]
    linear_change_std: Mapping[str, float]
    linear_moved: float
    n_eval: int
    gap_per_record: tuple[TestGap, ...]


@dataclass(frozen=True)
class PartialExplanation(_Section):
    """The best partial explanation of a ``cannot_tell``.

    Parameters
    ----------
    effects : tuple of str
        Its effects (``("linear",)``: a linear re-fit).
    gap_after : float
        Its held-out gap.
    shrink : float
        The share of the gap it removes.
    alternative : str, optional
        The effect that explains the gap as well.
    alternative_gap : float, optional
        Its held-out gap.
    """

    effects: tuple[str, ...]
    gap_after: float
    shrink: float
    alternative: str | None = None
    alternative_gap: float | None = None
    _omitted_if_none: ClassVar[tuple[str, ...]] = ("alternative", "alternative_gap")


@dataclass(frozen=True)
class NotCause(_Section):
    """An effect selected but credited nothing by removal.

    Parameters
    ----------
    name : str
        The effect.
    gap_with, gap_without : float
        The held-out gap of the joint fit with it and without it.
    """

    name: str
    gap_with: float
    gap_without: float


@dataclass(frozen=True)
class Alternative(_Section):
    """What could stand in place of a cause.

    Parameters
    ----------
    effect : str
        The cause.
    alternative : str
        The effect in its place.
    gap_alternative : float
        The held-out gap with the alternative.
    """

    effect: str
    alternative: str
    gap_alternative: float


@dataclass(frozen=True)
class ScreenGap(_Section):
    """A candidate's held-out gap on the exact linear screen.

    Parameters
    ----------
    name : str
        The candidate.
    gap : float
        Its screened held-out gap.
    """

    name: str
    gap: float


@dataclass(frozen=True)
class Tie(_Section):
    """A slot of the selection that the records cannot settle.

    Parameters
    ----------
    slot : int
        The slot (1 first).
    effects : tuple of str
        The two candidates.
    gaps : tuple of float
        Their held-out gaps.
    after : tuple of str
        The effects selected before it.
    record : str
        A record that would tell them apart.
    message : str
        The sentence.
    """

    slot: int
    effects: tuple[str, str]
    gaps: tuple[float, float]
    after: tuple[str, ...]
    record: str
    message: str


@dataclass(frozen=True)
class SensorRecord(_Section):
    """Outliers and dropouts found in one record.

    Parameters
    ----------
    file : str
        The record.
    outliers, dropouts : int
        How many.
    dropouts_s : tuple of tuple of float
        The dropouts' windows [s].
    flagged : int
        Samples set aside.
    """

    file: str
    outliers: int
    dropouts: int
    dropouts_s: tuple[tuple[float, float], ...]
    flagged: int


@dataclass(frozen=True)
class SensorReport(_Section):
    """Outliers and dropouts set aside (replaced by the model plus the interpolated residual).

    Parameters
    ----------
    outliers, dropouts : int
        How many, over the records.
    samples : int
        Samples set aside.
    share : float
        Their share of all samples.
    records : tuple of SensorRecord
        Per record that holds any.
    noise_floor_with_faults : float or None
        The noise floor the faults would have given.
    """

    outliers: int
    dropouts: int
    samples: int
    share: float
    records: tuple[SensorRecord, ...]
    noise_floor_with_faults: float | None = None
    _omitted_if_none: ClassVar[tuple[str, ...]] = ("noise_floor_with_faults",)


@dataclass(frozen=True)
class Finding(_Section):
    """A finding beside the verdict.

    Parameters
    ----------
    kind : str
        ``amplitude_dependent``, ``unmodelled_dynamics``, ``output_offset``,
        ``train_only``, ``sensor_faults``, ``periodic_records``, ...
    message : str
        The sentence.
    details : Mapping
        The figures of its kind (as the JSON holds them beside ``kind`` and ``message``).
    """

    kind: str
    message: str
    details: Mapping[str, Any] = field(default_factory=dict)
    _merged: ClassVar[tuple[str, ...]] = ("details",)

    @classmethod
    def of(cls, entry: Mapping[str, Any]) -> Finding:
        """The finding of a JSON-shaped entry (``kind``, ``message`` and its figures).

        Parameters
        ----------
        entry : Mapping
            The entry.

        Returns
        -------
        Finding
        """
        return cls(entry["kind"], entry["message"],
                   {k: v for k, v in entry.items() if k not in ("kind", "message")})


@dataclass(frozen=True, eq=False)
class Traces:
    """Arrays for the report and the model file (not in the JSON).

    Parameters
    ----------
    names : tuple of str
        The records' names (training first).
    records : tuple of Dataset
        The records.
    base_residuals : tuple of numpy.ndarray
        The model under diagnosis's residual on each.
    psd_f, psd : numpy.ndarray
        The residual's spectrum (all records).
    noise_psd : float
        The white-noise floor of that spectrum.
    fit_residuals : Mapping
        Test-record residuals per fitted candidate (and ``"final"``).
    answer_fit : Fitted, StiffnessFit, ThermalFit or None
        The answer's fitted model (the final joint fit, else the linear re-fit).
    focus : int
        The record the report draws: the test record with the largest residual of the
        model under diagnosis (an index into ``records``).
    """

    names: tuple[str, ...]
    records: tuple[Dataset, ...]
    base_residuals: tuple[np.ndarray, ...]
    psd_f: np.ndarray
    psd: np.ndarray
    noise_psd: float
    fit_residuals: Mapping[str, Sequence[np.ndarray]] = field(default_factory=dict)
    answer_fit: Fitted | StiffnessFit | ThermalFit | None = None
    focus: int = 0


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Result of :func:`~robrst.diagnose._diagnosis.diagnose`; :meth:`as_dict` is the contract.

    Parameters
    ----------
    cause : str
        One of the effects, ``output_offset``, ``none``, ``linear`` or ``cannot_tell``.
    reason : str
        Why, in one sentence.
    gap_before : float
        Held-out NRMSE of the model under diagnosis.
    noise_floor : float
        The noise floor in the same units.
    gap_train : float
        The gap on the training records.
    noise_floor_method : str
        How the floor was found (``period_differences``, ``spectrum``, ...).
    per_record : tuple of RecordGap
        The gap on each record.
    per_level : tuple of LevelGap
        The gap per excitation level.
    effects : tuple of EffectScore
        Every candidate alone, best first.
    linear_refit : EffectScore or None
        The linear re-fit alone.
    where : Where
        Time windows, frequency band, FRF departure, regime.
    tests : ResidualTests
        Whiteness and residual-input cross-correlation tests.
    decomposition : Mapping
        Shares of the residual's mean square (``offset``, ``noise``,
        ``linear_model_error``, ``unexplained_by_linear``).
    data : RecordsUsed
        The records used.
    model : ModelDiagnosed
        The model diagnosed.
    causes : tuple of str
        Every selected effect.
    selected : tuple of SelectedEffect
        The selected effects in the final joint fit.
    final : FinalFit or None
        The final joint fit of the selected effects.
    findings : tuple of Finding
        Findings beside the verdict.
    best_partial : PartialExplanation or None
        The best partial explanation of a ``cannot_tell``.
    skipped : Mapping
        Effects not tried, with the reason.
    seconds : float
        Wall time [s].
    output_offset : EffectScore or None
        The constant output offset screened alone.
    not_causes : tuple of NotCause
        Effects selected but credited nothing by removal.
    alternatives : tuple of Alternative
        What could stand in place of each cause.
    screen : tuple of ScreenGap
        Every candidate's screened held-out gap.
    sensor : SensorReport or None
        Outliers and dropouts set aside.
    ties : tuple of Tie
        The slots the records cannot settle.
    selection : tuple of str
        Every decision of the forward selection, in order.
    traces : Traces or None
        Arrays for the report.

    Attributes
    ----------
    winner : EffectScore or None
        The cause's own single-candidate score (None for none/linear/cannot_tell).
    """

    cause: str
    reason: str
    gap_before: float
    noise_floor: float
    gap_train: float
    noise_floor_method: str
    per_record: tuple[RecordGap, ...]
    per_level: tuple[LevelGap, ...]
    effects: tuple[EffectScore, ...]
    linear_refit: EffectScore | None
    where: Where
    tests: ResidualTests
    decomposition: Mapping[str, float]
    data: RecordsUsed
    model: ModelDiagnosed
    causes: tuple[str, ...] = ()
    selected: tuple[SelectedEffect, ...] = ()
    final: FinalFit | None = None
    findings: tuple[Finding, ...] = ()
    best_partial: PartialExplanation | None = None
    skipped: Mapping[str, str] = field(default_factory=dict)
    seconds: float = 0.0
    output_offset: EffectScore | None = None
    not_causes: tuple[NotCause, ...] = ()
    alternatives: tuple[Alternative, ...] = ()
    screen: tuple[ScreenGap, ...] = ()
    sensor: SensorReport | None = None
    ties: tuple[Tie, ...] = ()
    selection: tuple[str, ...] = ()
    traces: Traces | None = field(default=None, repr=False)

    @property
    def winner(self) -> EffectScore | None:
        """The cause's own single-candidate score (None for none/linear/cannot_tell)."""
        return next((e for e in self.effects if e.name == self.cause), None)

    def gap_after(self) -> float | None:
        """Held-out gap of the answer (selected effects, or the linear re-fit).

        Returns
        -------
        float or None
            ``None`` for ``none`` and ``cannot_tell``.
        """
        if self.cause == "linear":
            return self.linear_refit.gap_after
        f = self.final
        return f.gap_after if f and self.cause not in ("none", "cannot_tell") else None

    def as_dict(self) -> dict:
        """The JSON of ``robrst diagnose --json`` (fields are only added; no inf or NaN).

        Returns
        -------
        dict
        """
        g = {"metric": "nrmse", "before": self.gap_before, "noise_floor": self.noise_floor,
             "after": self.gap_after(), "before_train": self.gap_train,
             "noise_floor_method": self.noise_floor_method, "per_record": self.per_record,
             "per_level": self.per_level}
        d = {"cause": self.cause, "reason": self.reason, "gap": g, "effects": self.effects,
             "linear_refit": self.linear_refit, "where": self.where, "tests": self.tests,
             "decomposition": self.decomposition, "data": self.data, "model": self.model,
             "causes": self.causes, "selected": self.selected, "final": self.final,
             "findings": self.findings, "best_partial": self.best_partial,
             "skipped": self.skipped, "seconds": self.seconds,
             "output_offset": self.output_offset, "not_causes": self.not_causes,
             "alternatives": self.alternatives, "screen": self.screen, "sensor": self.sensor,
             "ties": self.ties, "selection": self.selection}
        return finite(_plain(d))


def finite(x: Any) -> Any:
    """Non-finite floats become None (JSON has no inf/nan); numpy scalars become Python.

    Parameters
    ----------
    x : object
        Dicts, lists and tuples are converted recursively.

    Returns
    -------
    object

    Examples
    --------
    >>> import math
    >>> from robrst.diagnose.result import finite
    >>> finite({"a": [1.0, math.inf], "b": math.nan})
    {'a': [1.0, None], 'b': None}
    """
    if isinstance(x, dict):
        return {k: finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [finite(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x
