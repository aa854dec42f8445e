"""``stiffness_nonlinearity``: a Duffing-type cubic stiffness of the structure.

The structure's restoring force ``k (y + c y^3)`` (``y`` the displacement from rest,
``c`` per µm²) is an output feedback around the linear part: the input is reduced by
``c y^3 / D(0)`` inside the integration, so the resonance stiffens with amplitude and the
static gain falls.  Like ``thermal_dynamics`` it changes the linear part itself, so it
runs on the twin's full step (:mod:`robrst.twin.model`, one input and one output) with
the linear model as ``D(s)`` and the exact sensitivity of ``c``; a relative input gain is
fitted with it (the linear re-fit's gain absorbs part of a stiffness).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from robrst.diagnose.linear import parameter_std
from robrst.diagnose.options import OPTIONS
from robrst.diagnose._stages import SensitivityStage, cached_stage

if TYPE_CHECKING:
    from robrst.core.plant import Plant
    from robrst.diagnose.fit import Prepared

__all__ = ["StiffnessFit", "fit_stiffness", "NAMES"]

NAMES = ("cubic_per_um2", "gain")
FD_GAIN = 1e-6


@dataclass(frozen=True, eq=False)
class StiffnessFit:
    """Fitted cubic stiffness and input gain, and a predictor (interface of a joint fit).

    Parameters
    ----------
    name : str
        ``"stiffness_nonlinearity"``.
    stage : SensitivityStage
        The twin's full step with the plant.
    x : numpy.ndarray
        ``(c [1/µm²], relative input gain)``.
    std : numpy.ndarray
        Their 1-sigma.
    n_eval : int
        Model evaluations.
    train_cost : float
        The final least-squares cost.
    effects : tuple of str
        ``("stiffness_nonlinearity",)``.
    form : str
        ``"input"``.
    plant : Plant, optional
        The linear model ``D(s)`` of the step (the user's or the re-fitted one).
    """

    name: str
    stage: SensitivityStage
    x: np.ndarray            # (c [1/µm²], relative input gain)
    std: np.ndarray
    n_eval: int
    train_cost: float
    effects: tuple = ("stiffness_nonlinearity",)
    form: str = "input"
    plant: Plant | None = None     # D(s) of the step

    def linear_plant(self) -> Plant:
        """The fitted model at small amplitude: ``D(s)`` times the fitted input gain.

        The stiffness acts inside the loop as ``v = (1 + g) u - c y^3 / D(0)``; with the
        gain in the plant, ``(1 + g) D(s)`` and ``c y^3 / ((1 + g) D(0))`` give the same
        ``v``: the twin with this plant and the fitted ``c`` is the fit.

        Returns
        -------
        Plant
        """
        g = 1.0 + float(self.x[1])
        return replace(self.plant, B=self.plant.B * g, label=f"{self.plant.label}_stiffness")

    def twin_tables(self) -> dict:
        """The twin file's tables that switch the fitted effect on.

        Returns
        -------
        dict
            ``{"stiffness_nonlinearity": {"enabled": True, "cubic_per_um2": c}}``.
        """
        return {"stiffness_nonlinearity": {"enabled": True,
                                           "cubic_per_um2": float(self.x[0])}}

    def run(self, p: Prepared, x: np.ndarray | None = None,
            jac: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """Output of a prepared record and, if ``jac``, its derivatives ``(N, 2)``.

        Parameters
        ----------
        p : Prepared
            The record.
        x : numpy.ndarray, optional
            ``(c, gain)`` (default the fitted ones).
        jac : bool
            Also the derivatives (exact in ``c``, a forward difference in the gain).

        Returns
        -------
        y : numpy.ndarray
        J : numpy.ndarray or None
        """
        x = self.x if x is None else x
        U, T = p.U[:, 0], p.temp
        if p.warm:
            U, T = np.concatenate([U[-p.warm:], U]), np.concatenate([T[-p.warm:], T])
        y, dy = self.stage.run(U * (1.0 + x[1]), T, x[:1])
        if not jac:
            return y[p.warm:], None
        yg, _ = self.stage.run(U * (1.0 + x[1] + FD_GAIN), T, x[:1])
        J = np.column_stack([dy[:, 0], (yg - y) / FD_GAIN])
        return y[p.warm:], J[p.warm:]

    def predict_prepared(self, p: Prepared, x: np.ndarray | None = None) -> np.ndarray:
        """Simulated outputs ``(N, 1)`` of a prepared record.

        Parameters
        ----------
        p : Prepared
            The record.
        x : numpy.ndarray, optional
            ``(c, gain)`` (default the fitted ones).

        Returns
        -------
        numpy.ndarray
        """
        return self.run(p, x)[0][:, None]

    def params(self) -> dict:
        """``{"stiffness_nonlinearity": (values, sigmas)}`` by parameter name.

        Returns
        -------
        dict
        """
        return {"stiffness_nonlinearity": (dict(zip(NAMES, map(float, self.x))),
                                           dict(zip(NAMES, map(float, self.std))))}

    def linear_change(self) -> tuple[dict, dict]:
        """No linear corrections (the plant is fixed).

        Returns
        -------
        values, sigmas : dict
            Empty.
        """
        return {}, {}


def fit_stiffness(train: Sequence[Prepared], plant: Plant, fs: float, reference_C: float,
                  max_nfev: int = OPTIONS.fit.standalone_nfev, start: Sequence[float] = (0.0, 0.0),
                  cache: dict | None = None) -> StiffnessFit:
    """Fit the cubic stiffness and an input gain on prepared SISO training records.

    Parameters
    ----------
    train : list of Prepared
        One input and one output.
    plant : Plant
        The linear model (``D(s)`` of the twin's step; a re-fitted model is best).
    fs, reference_C : float
        Sampling rate [Hz] and the model's temperature [°C].
    max_nfev : int
        Evaluations of the least-squares solver.
    start : (float, float)
        Starting cubic stiffness [1/µm²] and relative gain.
    cache : dict, optional
        Compiled stages of this diagnosis (the step is built once per plant).

    Returns
    -------
    StiffnessFit
    """
    st = cached_stage(cache, "stiffness_nonlinearity", fs, reference_C, plant=plant)
    y_max = max(float(np.max(np.abs(p.Y))) for p in train) or 1.0
    c_max = OPTIONS.fit.max_stiffening / y_max ** 2
    lo, hi = np.array([-c_max, -0.5]), np.array([c_max, 1.0])
    scale = np.sqrt(sum(p.weight ** 2 * float(np.sum((p.Y - p.Y.mean(0)) ** 2))
                        for p in train)) or 1.0
    proto = StiffnessFit("stiffness_nonlinearity", st, np.zeros(2), np.zeros(2), 0, 0.0)
    cache = {}

    def runs(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = [(p,) + proto.run(p, x, jac=True) for p in train]
        return cache[key]

    def fun(x):
        out = np.concatenate([(y - p.Y[:, 0]) * (p.weight / scale) for p, y, _ in runs(x)])
        return np.where(np.isfinite(out), out, 1e3)

    def jac(x):
        J = np.vstack([J * (p.weight / scale) for p, _, J in runs(x)])
        return np.where(np.isfinite(J), J, 0.0)

    x0 = np.clip(np.asarray(start, float), lo, hi)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        res = optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf",
                                     x_scale="jac", ftol=1e-8, xtol=1e-10, gtol=1e-10,
                                     max_nfev=max_nfev)
    std = parameter_std(res.jac, res.cost, res.fun.size, rtol=1e-6)
    return StiffnessFit("stiffness_nonlinearity", st, res.x, std, int(res.nfev),
                        2 * float(res.cost), plant=plant)
