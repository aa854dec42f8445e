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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["EffectScore", "Diagnosis", "finite"]


@dataclass(frozen=True)
class EffectScore:
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
    params: dict
    params_std: dict
    n_eval: int
    fit_s: float
    form: str = "input"
    overfit: bool = False
    method: str = "fit"       # "fit" (its own nonlinear model) or "screen" (linear columns)

    def as_dict(self) -> dict:
        """The ``effects`` entry of the diagnosis JSON.

        Returns
        -------
        dict
        """
        return {"name": self.name, "gap_before": self.gap_before, "gap_after": self.gap_after,
                "shrink": self.shrink, "train_gap": self.train_gap, "params": self.params,
                "params_std": self.params_std, "n_eval": self.n_eval, "fit_s": self.fit_s,
                "form": self.form, "overfit": self.overfit, "method": self.method}


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
    effects : tuple of EffectScore
        Every candidate, best first.
    linear_refit : EffectScore
        The linear re-fit alone.
    where : dict
        Time windows, frequency band, FRF departure, regime.
    tests : dict
        Whiteness and residual-input cross-correlation tests.
    decomposition : dict
        Shares of the residual's mean square.
    data : dict
        The records used.
    model : dict
        The model diagnosed.
    extra : dict
        ``causes``, ``selected``, ``final``, ``findings``, ...
    traces : dict
        Arrays for the report.

    Attributes
    ----------
    winner : EffectScore or None
        The cause's own single-candidate score (None for none/linear/cannot_tell).
    causes : tuple of str
        Every selected effect.
    findings : tuple of dict
        ``amplitude_dependent``, ``unmodelled_dynamics``, ``output_offset``,
        ``train_only``.
    final : dict or None
        The final joint fit of the selected effects.
    """

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
    extra: dict = field(default_factory=dict)     # causes, selected, final, findings, ...
    traces: dict = field(default_factory=dict, repr=False)   # arrays for reports

    @property
    def winner(self):
        """The cause's own single-candidate score (None for none/linear/cannot_tell)."""
        return next((e for e in self.effects if e.name == self.cause), None)

    @property
    def causes(self):
        return tuple(self.extra.get("causes", ()))

    @property
    def findings(self):
        return tuple(self.extra.get("findings", ()))

    @property
    def final(self):
        return self.extra.get("final")

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
        return f["gap_after"] if f and self.cause not in ("none", "cannot_tell") else None

    def as_dict(self) -> dict:
        """The JSON of ``robrst diagnose --json`` (fields are only added; no inf or NaN).

        Returns
        -------
        dict
        """
        g = {"metric": "nrmse", "before": self.gap_before, "noise_floor": self.noise_floor,
             "after": self.gap_after(), "before_train": self.gap_train}
        g.update(self.extra.get("gap", {}))
        d = {"cause": self.cause, "reason": self.reason, "gap": g,
             "effects": [e.as_dict() for e in self.effects],
             "linear_refit": self.linear_refit.as_dict() if self.linear_refit else None,
             "where": self.where, "tests": self.tests, "decomposition": self.decomposition,
             "data": self.data, "model": self.model}
        for k in ("causes", "selected", "final", "findings", "best_partial", "skipped",
                  "seconds", "output_offset", "not_causes", "alternatives", "screen", "sensor",
                  "ties", "selection"):
            d[k] = self.extra.get(k)
        return finite(d)


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
