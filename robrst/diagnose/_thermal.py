"""``thermal_dynamics`` (gain, resonance and damping linear in temperature), and the
searches that start the non-smooth effects (whole-sample delay, saturation limits).

``thermal_dynamics`` changes the linear part with temperature, so it runs on the twin's
full step (one input, one output) with the user's model as ``D(s)`` and exact
parameter sensitivities; it is scored alone (not combined with other effects).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from robrst.core.minimize import golden_section
from robrst.diagnose.linear import parameter_std
from robrst.diagnose.options import OPTIONS
from robrst.diagnose._stages import SensitivityStage, stage

if TYPE_CHECKING:
    from robrst.core.plant import Plant
    from robrst.diagnose.fit import Prepared
    from robrst.diagnose.linear import LinearPart

__all__ = ["ThermalFit", "fit_thermal_dynamics", "search_delay", "search_saturation",
           "max_delay"]

BOUNDS = (np.array([-0.05, -0.01, -0.2]), np.array([0.05, 0.01, 0.2]))
NAMES = ("gain_per_K", "resonance_per_K", "damping_per_K")


@dataclass(frozen=True, eq=False)
class ThermalFit:
    """Fitted thermal coefficients and a predictor (same interface as a joint fit).

    Parameters
    ----------
    name : str
        ``"thermal_dynamics"``.
    stage : SensitivityStage
        The compiled step.
    x : numpy.ndarray
        The fitted coefficients (gain, resonance, damping per K).
    std : numpy.ndarray
        Their 1-sigma.
    n_eval : int
        Model evaluations.
    train_cost : float
        The final least-squares cost.
    effects : tuple of str
        ``("thermal_dynamics",)``.
    form : str
        ``"input"``.
    """

    name: str
    stage: SensitivityStage
    x: np.ndarray
    std: np.ndarray
    n_eval: int
    train_cost: float
    effects: tuple = ("thermal_dynamics",)
    form: str = "input"

    def predict_prepared(self, p: Prepared, x: np.ndarray | None = None) -> np.ndarray:
        """Simulated output ``(N, 1)`` of a prepared record.

        Parameters
        ----------
        p : Prepared
            The record.
        x : numpy.ndarray, optional
            The coefficients (default the fitted ones).

        Returns
        -------
        numpy.ndarray
        """
        x = self.x if x is None else x
        U, T = p.U[:, 0], p.temp
        if p.warm:
            U, T = np.concatenate([U[-p.warm:], U]), np.concatenate([T[-p.warm:], T])
        y, _ = self.stage.run(U, T, x)
        return y[p.warm:, None]

    def params(self) -> dict:
        """``{"thermal_dynamics": (values, sigmas)}`` keyed by coefficient name.

        Returns
        -------
        dict
        """
        return {"thermal_dynamics": (dict(zip(NAMES, map(float, self.x))),
                                     dict(zip(NAMES, map(float, self.std))))}

    def linear_change(self) -> tuple[dict, dict]:
        """No linear corrections: ``({}, {})``.

        Returns
        -------
        values, sigmas : dict
        """
        return {}, {}


def fit_thermal_dynamics(train: Sequence[Prepared], plant: Plant, fs: float, reference_C: float,
                         max_nfev: int = OPTIONS.fit.standalone_nfev) -> ThermalFit:
    """Fit the three thermal coefficients on prepared SISO training records.

    Parameters
    ----------
    train : sequence of Prepared
        The training records (one input and output).
    plant : Plant
        The user's model.
    fs : float
        Sampling rate [Hz].
    reference_C : float
        The model's temperature [°C].
    max_nfev : int
        Evaluations allowed to the least-squares solver.

    Returns
    -------
    ThermalFit
    """
    st = stage("thermal_dynamics", fs, reference_C, plant=plant)
    scale = np.sqrt(sum(p.weight ** 2 * float(np.sum((p.Y - p.Y.mean(0)) ** 2))
                        for p in train)) or 1.0
    def runs(x):
        out = []
        for p in train:
            U, T = p.U[:, 0], p.temp
            if p.warm:
                U, T = np.concatenate([U[-p.warm:], U]), np.concatenate([T[-p.warm:], T])
            y, dy = st.run(U, T, x)
            out.append((p, y[p.warm:], dy[p.warm:]))
        return out

    def fun(x):
        return np.concatenate([(y - p.Y[:, 0]) * (p.weight / scale) for p, y, _ in runs(x)])

    def jac(x):
        return np.vstack([dy * (p.weight / scale) for p, _, dy in runs(x)])

    # trial points may overflow (an effect driven far out): the optimiser
    # rejects them; their floating-point warnings only reach the user
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        res = optimize.least_squares(fun, np.zeros(3), jac=jac, bounds=BOUNDS, method="trf",
                                     x_scale="jac", ftol=1e-8, xtol=1e-10, gtol=1e-10,
                                     max_nfev=max_nfev)
    std = parameter_std(res.jac, res.cost, res.fun.size, rtol=1e-6)
    return ThermalFit("thermal_dynamics", st, res.x, std, int(res.nfev), 2 * float(res.cost))




def max_delay(fs: float) -> int:
    """Largest whole-sample delay searched at ``fs`` [Hz] (at least one sample).

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].

    Returns
    -------
    int
    """
    return int(max(1, min(round(OPTIONS.fit.max_delay_s * fs), OPTIONS.fit.max_delay_samples)))


def search_delay(train: Sequence[Prepared], lin: LinearPart, max_delay: int) -> tuple[int, ...]:
    """Whole-sample delay per input minimising the training error of the linear model.

    Exact and cheap: a delayed input's response is the delayed response (plus the
    held initial value's step response for records from rest; a circular shift for
    periodic ones), so each input needs two simulations, not one per candidate delay.

    Parameters
    ----------
    train : sequence of Prepared
        The training records.
    lin : LinearPart
        The linear model.
    max_delay : int
        The largest delay tried [samples].

    Returns
    -------
    tuple of int
        One per input.
    """
    th = np.zeros(lin.size)
    k = train[0].U.shape[1]
    best = []
    for j in range(k):
        costs = np.zeros(max_delay + 1)
        for p in train:
            if k > 1:               # the other inputs' response (none with one input)
                others = p.U.copy()
                others[:, j] = 0.0
                rest = p.Y - lin.simulate(th, others, p.periodic)
            else:
                rest = p.Y
            yj = lin.simulate_input(th, p.U[:, j], j, p.periodic)
            step = None if p.periodic else lin.simulate_input(th, np.ones(len(p.U)), j)
            u0 = p.U[0, j]
            for d in range(max_delay + 1):
                if p.periodic:
                    yd = np.roll(yj, d, axis=0)
                elif d:
                    yd = np.empty_like(yj)
                    yd[d:] = yj[:-d] + u0 * (step[d:] - step[:-d])
                    yd[:d] = u0 * step[:d]
                else:
                    yd = yj
                costs[d] += p.weight ** 2 * float(np.sum((yd - rest) ** 2))
        best.append(int(np.argmin(costs)))
    return tuple(best)


def search_saturation(train: Sequence[Prepared], lin: LinearPart,
                      stats: dict) -> list[tuple[float, float]]:
    """Starting limits (u_min, u_max) per input: a quantile search on the linear model.

    Parameters
    ----------
    train : sequence of Prepared
        The training records.
    lin : LinearPart
        The linear model.
    stats : dict
        Scales of the training data.

    Returns
    -------
    list of (float, float)
        [V].
    """
    th = np.zeros(lin.size)
    out = []
    for j in range(train[0].U.shape[1]):
        u_all = np.concatenate([p.U[:, j] for p in train])
        lo, hi = float(u_all.min()), float(u_all.max())
        span = max(hi - lo, 1e-9)

        def cost(a, b):
            c = 0.0
            for p in train:
                U = p.U.copy()
                U[:, j] = np.clip(U[:, j], a, b)
                c += p.weight ** 2 * float(np.sum((lin.simulate(th, U, p.periodic) - p.Y) ** 2))
            return c

        # a limit the training records never reach is not a limit at their edge: it
        # starts (and, clipping nothing, stays) out of their way, a span beyond them
        best_lo, best_hi = lo - span, hi + span
        for which in ("hi", "lo"):
            qs = np.linspace(0.5, 1.0, 17) if which == "hi" else np.linspace(0.5, 0.0, 17)
            cands = np.quantile(u_all, qs)
            f = (lambda c: cost(best_lo, c)) if which == "hi" else (lambda c: cost(c, best_hi))
            vals = [f(c) for c in cands]
            i = int(np.argmin(vals))
            # refined between the neighbouring quantiles: a limit that clips only the last
            # few % of the samples lies between the extreme and the next quantile
            a, b = cands[max(i - 1, 0)], cands[min(i + 1, len(cands) - 1)]
            pick, val = golden_section(f, min(a, b), max(a, b), OPTIONS.fit.refine_evals)
            pick = pick if val < vals[i] else float(cands[i])
            if which == "hi":
                best_hi = pick if pick < hi else best_hi
            else:
                best_lo = pick if pick > lo else best_lo
        out.append((best_lo, best_hi))
    return out
