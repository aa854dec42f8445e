"""Estimate named effects from records: the fitting step of a diagnosis, on its own.

:func:`fit_effects` answers "my actuator has hysteresis and creep: what are their
parameters?" without a held-out comparison.  It uses the diagnosis's own fits: the
whole-sample delay by exact search (:func:`~robrst.diagnose._thermal.search_delay`),
saturation limits started by a quantile search, the input-side effects by bounded
least squares with the exact Jacobian (:func:`~robrst.diagnose.fit.fit_model`),
``thermal_dynamics`` by :func:`~robrst.diagnose._thermal.fit_thermal_dynamics`.
Standard deviations are the delta-method 1-sigma of the fit; a parameter the records
do not determine (e.g. the split of the drift's ``B`` and ``Gamma`` on a one-way
temperature ramp) gets ``inf``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

import robrst.diagnose._signals as signals
from robrst.diagnose._diagnosis import check_records
from robrst.diagnose._effects import EFFECTS, FORMS, INPUT_EFFECTS, Chain, summary
from robrst.diagnose._findings import noise_levels
from robrst.diagnose.fit import fit_model, prepare
from robrst.diagnose.linear import LinearPart, as_modal
from robrst.diagnose._stiffness import fit_stiffness
from robrst.diagnose._thermal import (fit_thermal_dynamics, max_delay, search_delay,
                                     search_saturation)
from robrst.base.errors import DataError
from robrst.core.plant import paper_plant

if TYPE_CHECKING:
    from robrst.core.plant import Plant
    from robrst.data.dataset import Dataset
    from robrst.identify.modal import ModalModel

__all__ = ["EffectEstimate", "fit_effects"]


@dataclass(frozen=True)
class EffectEstimate:
    """Fitted effect parameters with their 1-sigma, and how well the fit explains the data.

    Attributes
    ----------
    effects : tuple of str
        The effects fitted (in the chain's order).
    params, std : dict
        ``{name: value}`` and ``{name: 1-sigma}`` over all effects (names as in
        :meth:`params_of`; ``_uJ`` suffixes for input J of a MIMO model).
    by_effect : dict
        ``{effect: {name: value}}``.
    linear_change : dict
        Linear corrections fitted jointly (empty unless ``joint``).
    gap : float
        NRMSE of the fitted model on the records (training gap).
    gap_linear : float
        NRMSE of the user's linear model alone on the same records.
    n_eval : int
        Model evaluations of the least-squares fit.
    """

    effects: tuple
    params: dict
    std: dict
    by_effect: dict
    linear_change: dict
    gap: float
    gap_linear: float
    n_eval: int

    def params_of(self, effect: str) -> dict[str, float]:
        """``{name: value}`` of one effect.

        Parameters
        ----------
        effect : str
            An effect fitted.

        Returns
        -------
        dict

        Raises
        ------
        KeyError
            For an effect not fitted.
        """
        return dict(self.by_effect[effect])


def fit_effects(records: Sequence[Dataset], effects: Sequence[str],
                plant: Plant | ModalModel | None = None, reference_C: float | None = None,
                joint: bool = False, max_nfev: int = 200) -> EffectEstimate:
    """Fit the parameters of ``effects`` on measured records.

    Parameters
    ----------
    records : list of Dataset
        Records of the actuator (one sampling rate; the model's channel counts).
    effects : sequence of str
        Effects from :data:`~robrst.diagnose._effects.EFFECTS` (``hysteresis`` is
        Bouc–Wen; ``pi_hysteresis`` its Prandtl–Ishlinskii form) and ``output_offset``.
        ``thermal_dynamics`` and ``stiffness_nonlinearity`` are fitted alone (they change
        the linear part; one input and one output); ``amplitude_dependent_dynamics`` is
        the diagnosis's own (not estimated here).
    plant : Plant or ModalModel, optional
        The linear model (default: the paper's D(s)).
    reference_C : float, optional
        Temperature at which the model holds (default its own or 28 °C).
    joint : bool
        Also re-fit the linear part's corrections (regularised toward ``plant``).
    max_nfev : int
        Evaluations allowed to the least-squares solver (a converged fit stops earlier; a
        joint fit of creep and a gain change on minutes of steps takes about 150).

    Returns
    -------
    EffectEstimate

    Raises
    ------
    DataError
        Unknown effects, ``thermal_dynamics`` or ``stiffness_nonlinearity`` combined with
        others or on a MIMO model, bad records (named).
    """
    effects = tuple(effects)
    known = [e for e in EFFECTS if e != "amplitude_dependent_dynamics"] + list(FORMS) + [
        "output_offset"]
    unknown = [e for e in effects if e not in known]
    if unknown or not effects:
        raise DataError(f"unknown effect(s) {unknown or '(none given)'}; expected one or more"
                        f" of {known}")
    plant = plant or paper_plant()
    model = as_modal(plant)
    records = list(records)
    fs = check_records(records, records, model.n_in, model.n_out)
    ref = float(reference_C if reference_C is not None else (model.temperature_C or 28.0))
    lin = LinearPart(model, fs)
    full = [prepare(d, ref, for_fit=False) for d in records]
    base = [p.Y - lin.simulate(np.zeros(lin.size), p.U, p.periodic) for p in full]
    gap_linear = signals.nrmse(records, base)
    train = [prepare(d, ref) for d in records]
    alone = [e for e in effects if e in ("thermal_dynamics", "stiffness_nonlinearity")]
    if alone:
        if len(effects) > 1 or (model.n_in, model.n_out) != (1, 1):
            raise DataError(f"{alone[0]} is fitted alone, on a model with one input and"
                            f" one output (got effects {list(effects)}, {model.n_in} input(s),"
                            f" {model.n_out} output(s))")
        if alone[0] == "thermal_dynamics":
            fit = fit_thermal_dynamics(train, plant, fs, ref, max_nfev=max_nfev)
        else:
            siso = plant if not hasattr(plant, "residues") else model.channel(0, 0)
            fit = fit_stiffness(train, siso, fs, ref, max_nfev=max_nfev)
    elif "cross_coupling" in effects and (model.n_in, model.n_out) == (1, 1):
        raise DataError("cross_coupling needs a model with several inputs or outputs")
    else:
        fit = _fit_input_effects(effects, records, train, base, lin, fs, ref, joint, max_nfev)
    res = [p.Y - fit.predict_prepared(p) for p in full]
    by, sd = fit.params(), {}
    flat = {}
    for e, (vals, sds) in by.items():
        flat.update(vals)
        sd.update(sds)
    return EffectEstimate(effects=tuple(by), params=flat, std=sd,
                          by_effect={e: dict(v) for e, (v, _) in by.items()},
                          linear_change=fit.linear_change()[0],
                          gap=signals.nrmse(records, res), gap_linear=gap_linear,
                          n_eval=int(fit.n_eval))


def _fit_input_effects(effects, records, train, base, lin, fs, ref, joint, max_nfev):
    stats = summary(records)
    sig, _ = noise_levels(records, base, fs)
    sigma = float(np.sqrt(np.mean(np.asarray(sig) ** 2))) or 1e-9
    delays = None
    if "delay" in effects:
        delays = search_delay(train, lin, max_delay(fs))
    chain = Chain(tuple(e for e in effects if e in INPUT_EFFECTS), lin.model.n_in, fs, ref,
                  stats, delays)
    if "saturation" in chain.effects:
        chain.start_saturation(search_saturation(train, lin, stats))
    curvature = "output_nonlinearity" in effects
    return fit_model("+".join(effects), chain.effects, train, lin, chain, sigma,
                     joint=joint, max_nfev=max_nfev,
                     offset="output_offset" in effects or curvature, curvature=curvature,
                     mixing="cross_coupling" in effects)
