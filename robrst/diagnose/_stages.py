"""The twin's own effect steps with exact parameter sensitivities, compiled once.

A diagnosis fits the twin's parametrisation (:mod:`robrst.twin.model`), so an effect
found in data can be put straight back into the twin.  For the sequential effects
(``slew``, ``hysteresis``, ``pi_hysteresis``, ``thermal_drift``; and
``thermal_dynamics``, which changes the linear part itself) the twin's symbolic step is augmented with its forward
sensitivities ``S = dx/dtheta`` (``S+ = f_x S + f_theta``): one compiled pass returns
the output and its exact derivative with respect to every free parameter, instead of
one simulation per parameter and iteration.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from robrst.twin.config import default_twin
from robrst.twin.model import TwinModel, build_model
from robrst.twin.simulate import Simulator, rest_state

if TYPE_CHECKING:
    from robrst.core.plant import Plant

__all__ = ["SensitivityStage", "stage", "cached_stage", "FREE"]

# free twin parameters (theta names) per effect
FREE = {
    "slew": ("slew_V_per_s", "slew_down_V_per_s"),
    "pi_hysteresis": (),     # its weights pi_w1.. (as many as thresholds)
    "hysteresis": ("bw_A", "bw_B", "bw_Gamma", "bw_gain"),
    "thermal_drift": ("drift_lag_s", "drift_B", "drift_Gamma", "drift_V_per_K"),
    "thermal_dynamics": ("gain_per_K", "resonance_per_K", "damping_per_K"),
    "stiffness_nonlinearity": ("stiff_cubic",),
}
LINEAR_STAGES = ("thermal_dynamics", "stiffness_nonlinearity")   # their step holds D(s)


def _augmented(model, free):
    """``(x; vec S), p, theta -> (x+; vec S+), (y; dy/dtheta_free)`` for ``out[1]``."""
    nx, nt, nf = model.n_state, len(model.theta0), len(free)
    x = ca.SX.sym("x", nx)
    S = ca.SX.sym("S", nx, nf)
    p = ca.SX.sym("p", 3)
    th = ca.SX.sym("theta", nt)
    xn, out = model.step(x, p, th)
    y = out[1]
    Jx = ca.jacobian(xn, x)
    Jt = ca.horzcat(*[ca.jacobian(xn, th[i]) for i in free]) if nf else ca.SX(nx, 0)
    Sn = ca.mtimes(Jx, S) + Jt
    gy = ca.jacobian(y, x)
    dy = ca.mtimes(gy, S) + (ca.horzcat(*[ca.jacobian(y, th[i]) for i in free]) if nf
                             else ca.SX(1, 0))
    xa = ca.vertcat(x, ca.vec(S))
    xan = ca.vertcat(xn, ca.vec(Sn))
    # dense outputs: the compiled driver copies whole vectors (structural zeros included)
    return ca.Function(f"{model.config.name}_sens", [xa, p, th],
                       [ca.densify(xan), ca.densify(ca.vertcat(y, dy.T))],
                       ["x", "p", "theta"], ["x_next", "y"])


@dataclass(frozen=True, eq=False)
class SensitivityStage:
    """One effect's compiled twin step with sensitivities (``run``: output, d output).

    Parameters
    ----------
    name : str
        The effect.
    model : TwinModel
        The twin's model with only that effect on.
    sim : Simulator
        The compiled loop of the step with its sensitivities.
    free : tuple of int
        Indices into theta of the fitted parameters.
    """

    name: str
    model: TwinModel
    sim: Simulator
    free: tuple          # indices into theta

    def theta(self, values: Sequence[float]) -> np.ndarray:
        """The twin's theta vector with the free parameters set to ``values``.

        Parameters
        ----------
        values : sequence of float
            The free parameters.

        Returns
        -------
        numpy.ndarray
        """
        th = self.model.theta0.copy()
        th[list(self.free)] = values
        return th

    def run(self, u: np.ndarray, temp: np.ndarray, values: Sequence[float],
            u0_rest: float | None = None,
            memory_V: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Output ``(N,)`` and its derivative ``(N, n_free)`` on input ``u`` and ``temp``.

        Starts at the twin's rest state (stack at ``temp[0]``), the hysteresis memory
        (Bouc–Wen and the plays) at rest at ``memory_V`` (the twin's: 0 V).

        Parameters
        ----------
        u : numpy.ndarray
            Input [V].
        temp : numpy.ndarray
            Temperature [°C].
        values : sequence of float
            The free parameters.
        u0_rest : float, optional
            The voltage held before the record (default ``u[0]``).
        memory_V : float
            The input [V] the hysteresis memory rests at before the record (its loop
            variable and the plays at 0 there).

        Returns
        -------
        y, dy : numpy.ndarray
        """
        n = u.size
        P = np.vstack([u, temp, np.zeros(n)])
        x0 = rest_state(self.model, u[0] if u0_rest is None else u0_rest, temp[0])
        if memory_V:
            sl = self.model.slices
            if self.model.config.enabled("hysteresis"):
                x0[sl["u_prev"]] = memory_V
            x0[sl["plays"]] = memory_V
        nf = len(self.free)
        xa = np.concatenate([x0, np.zeros(self.model.n_state * nf)])
        Y, _ = self.sim.loop(P, xa, self.theta(values))
        return Y[0], Y[1:1 + nf].T


def stage(name: str, fs: float, reference_C: float = 28.0, plant: Plant | None = None,
          **settings: tuple) -> SensitivityStage:
    """The :class:`SensitivityStage` of effect ``name`` at ``fs`` [Hz].

    ``plant`` (a SISO Plant) is needed only for ``thermal_dynamics`` and
    ``stiffness_nonlinearity``, whose step contains the linear dynamics; the other effects
    stop at the effective input.  The compiled library is cached on disk
    (:mod:`robrst.twin.compiled`).

    Parameters
    ----------
    name : str
        The effect.
    fs : float
        Sampling rate [Hz].
    reference_C : float
        The model's temperature [°C].
    plant : Plant, optional
        The user's SISO model (``thermal_dynamics``, ``stiffness_nonlinearity``).
    **settings : tuple
        The twin's structural settings of the effect (the play thresholds of
        ``pi_hysteresis``: ``thresholds_V``).

    Returns
    -------
    SensitivityStage
    """
    over = dict(settings)
    if name == "pi_hysteresis" and "thresholds_V" in over:
        over["weights"] = (0.0,) * len(over["thresholds_V"])
    cfg = replace(default_twin().with_effects(only=[name], **({name: over} if over else {})),
                  sample_rate_hz=float(fs), reference_C=float(reference_C),
                  name=f"diagnose_{name}")
    model = build_model(cfg, plant=plant, linear=name in LINEAR_STAGES)
    index = {k: i for i, k in enumerate(model.theta_names)}
    names = FREE[name] or tuple(k for k in model.theta_names if k.startswith("pi_w"))
    free = tuple(index[k] for k in names)
    return SensitivityStage(name=name, model=model,
                            sim=Simulator(replace(model, step=_augmented(model, free),
                                                  n_state=model.n_state * (1 + len(free)))),
                            free=free)


def cached_stage(cache: dict | None, name: str, fs: float, reference_C: float = 28.0,
                 plant: Plant | None = None, **settings: tuple) -> SensitivityStage:
    """``stage(name, ...)`` built once per ``cache`` (a dict owned by one diagnosis).

    Parameters
    ----------
    cache : dict or None
        The diagnosis's stages (``None``: build a new stage).
    name, fs, reference_C, plant, **settings
        As :func:`stage` (``plant`` keyed by its coefficients).

    Returns
    -------
    SensitivityStage
    """
    if cache is None:
        return stage(name, fs, reference_C, plant=plant, **settings)
    pk = None if plant is None else (tuple(np.ravel(plant.B)), tuple(np.ravel(plant.A)))
    key = (name, float(fs), float(reference_C), pk,
           tuple(sorted((k, tuple(v) if isinstance(v, (list, tuple)) else v)
                        for k, v in settings.items())))
    if key not in cache:
        cache[key] = stage(name, fs, reference_C, plant=plant, **settings)
    return cache[key]
