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
records).
"""

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["EffectScore", "Diagnosis", "finite"]


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
    form: str = "input"
    overfit: bool = False
    method: str = "fit"       # "fit" (its own nonlinear model) or "screen" (linear columns)

    def as_dict(self):
        return {"name": self.name, "gap_before": self.gap_before, "gap_after": self.gap_after,
                "shrink": self.shrink, "train_gap": self.train_gap, "params": self.params,
                "params_std": self.params_std, "n_eval": self.n_eval, "fit_s": self.fit_s,
                "form": self.form, "overfit": self.overfit, "method": self.method}


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Result of :func:`~robrst.diagnose.diagnosis.diagnose`; :meth:`as_dict` is the contract."""

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

    def gap_after(self):
        """Held-out gap of the answer (selected effects, or the linear re-fit)."""
        if self.cause == "linear":
            return self.linear_refit.gap_after
        f = self.final
        return f["gap_after"] if f and self.cause not in ("none", "cannot_tell") else None

    def as_dict(self):
        g = {"metric": "nrmse", "before": self.gap_before, "noise_floor": self.noise_floor,
             "after": self.gap_after(), "before_train": self.gap_train}
        g.update(self.extra.get("gap", {}))
        d = {"cause": self.cause, "reason": self.reason, "gap": g,
             "effects": [e.as_dict() for e in self.effects],
             "linear_refit": self.linear_refit.as_dict() if self.linear_refit else None,
             "where": self.where, "tests": self.tests, "decomposition": self.decomposition,
             "data": self.data, "model": self.model}
        for k in ("causes", "selected", "final", "findings", "best_partial", "skipped",
                  "seconds", "output_offset", "not_causes", "alternatives", "screen", "sensor"):
            d[k] = self.extra.get(k)
        return finite(d)


def finite(x):
    """Non-finite floats become None (JSON has no inf/nan); numpy scalars become Python."""
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
