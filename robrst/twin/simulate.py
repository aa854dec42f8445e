"""Simulation of the twin, open and closed loop, compiled and chunked.

The step function of :mod:`robrst.twin.model` (closed loop: with the discrete RST
controller inside) is unrolled ``CHUNK`` times with ``mapaccum``, compiled to C once
(:mod:`robrst.twin.compiled`) and called chunk after chunk.  Noise comes only from
``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from numpy.typing import ArrayLike

from robrst.base.errors import DataError, SpecError
from robrst.core.rst import DiscreteController
from robrst.twin.config import TwinConfig
from robrst.twin.compiled import compile_loop
from robrst.twin.model import build_model

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.twin.model import TwinModel

__all__ = ["SimResult", "simulate", "closed_loop_step", "Simulator", "rest_state"]

@dataclass(frozen=True, eq=False)
class SimResult:
    """Sampled signals: t [s], u_cmd/u_applied [V], y (measured) / y_true [µm], temp [°C].

    Parameters
    ----------
    t : numpy.ndarray
        Time [s].
    u_cmd : numpy.ndarray
        Commanded voltage [V].
    u_applied : numpy.ndarray
        Voltage reaching the stack (after delay, saturation, slew) [V].
    y : numpy.ndarray
        Measured displacement (noise, quantisation) [µm].
    y_true : numpy.ndarray
        True displacement [µm].
    temp : numpy.ndarray
        Temperature [°C].
    yr : numpy.ndarray, optional
        Reference (closed loop) [µm].
    meta : dict
        What was simulated (twin, compiled, seed).
    """

    t: np.ndarray
    u_cmd: np.ndarray
    u_applied: np.ndarray
    y: np.ndarray
    y_true: np.ndarray
    temp: np.ndarray
    yr: np.ndarray = None
    meta: dict = field(default_factory=dict)

    def to_dataset(self, comments: Iterable[str] = ()) -> Dataset:
        """The record as measured: ``t``, commanded ``u``, measured ``y``, ``temp``, ``yr``.

        Parameters
        ----------
        comments : iterable of str
            Comment lines of the record.

        Returns
        -------
        Dataset
        """
        from robrst.data.dataset import Dataset

        return Dataset(t=self.t, u=self.u_cmd, y=self.y, temp=self.temp, yr=self.yr,
                       comments=tuple(comments), source="twin")


def closed_loop_step(model: TwinModel, dctrl: DiscreteController) -> ca.Function:
    """Step of twin + discrete RST: ``(x, [yr, T, noise], theta) -> (x+, [y, y_true, u_a, u])``.

    Parameters
    ----------
    model : TwinModel
        The twin's model.
    dctrl : DiscreteController
        The controller at the twin's rate.

    Returns
    -------
    casadi.Function

    Raises
    ------
    SpecError
        For a plant with feedthrough (an algebraic loop).
    """
    if not model.strictly_proper:
        raise SpecError("closed-loop simulation needs a strictly proper plant (no feedthrough)")
    nk = dctrl.A.shape[0]
    x = ca.SX.sym("x", model.n_state + nk)
    p = ca.SX.sym("p", 3)
    th = ca.SX.sym("theta", len(model.theta0))
    xp, xc = x[:model.n_state], x[model.n_state:]
    y = model.output(xp, ca.vertcat(0, p[1], p[2]), th)
    e = ca.vertcat(p[0], y)
    u = ca.mtimes(ca.DM(dctrl.C), xc) + ca.mtimes(ca.DM(dctrl.D), e)
    xc_next = ca.mtimes(ca.DM(dctrl.A), xc) + ca.mtimes(ca.DM(dctrl.B), e)
    xp_next, out = model.step(xp, ca.vertcat(u, p[1], p[2]), th)
    return ca.Function("twin_cl_step", [x, p, th], [ca.vertcat(xp_next, xc_next),
                                                    ca.vertcat(out, u)])


def rest_state(model: TwinModel, u0: float, T0: float) -> np.ndarray:
    """Initial state at rest: linear part and effect memories empty, stack at ``T0``.

    The drive (delay line, slew memory) holds ``u0``; with hysteresis on, the
    Bouc–Wen memory starts at 0 V so a record starting at ``u0 != 0`` enters the loop.

    Parameters
    ----------
    model : TwinModel
        The twin's model.
    u0 : float
        The held voltage [V].
    T0 : float
        The temperature [°C].

    Returns
    -------
    numpy.ndarray
    """
    x0 = np.zeros(model.n_state)
    x0[model.slices["T_s"]] = T0
    x0[model.slices["delay"]] = u0
    x0[model.slices["u_prev"]] = 0.0 if model.config.enabled("hysteresis") else u0
    return x0


class Simulator:
    """A compiled loop for one model (and controller); reusable across runs.

    Parameters
    ----------
    model : TwinModel
        The twin's model.
    dctrl : DiscreteController, optional
        The controller of a closed-loop simulation.

    Attributes
    ----------
    loop : Loop
        The compiled loop.
    is_compiled : bool
        It runs compiled C (else CasADi's VM, with the same numbers).
    n_x : int
        Size of the state (twin and controller).
    """

    def __init__(self, model: TwinModel, dctrl: DiscreteController | None = None) -> None:
        self.model, self.dctrl = model, dctrl
        step = model.step if dctrl is None else closed_loop_step(model, dctrl)
        self.loop = compile_loop(step)
        self.is_compiled = self.loop.is_compiled
        self.n_x = model.n_state + (0 if dctrl is None else dctrl.A.shape[0])

    def run(self, P: ArrayLike, x0: np.ndarray,
            theta: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Advance over the columns of ``P`` (3 x N); return (outputs (k x N), final state).

        Parameters
        ----------
        P : array_like
            Per sample ``[u or yr, T, noise]``.
        x0 : numpy.ndarray
            The initial state.
        theta : array_like, optional
            The model's parameters (default ``model.theta0``).

        Returns
        -------
        outputs : numpy.ndarray
        state : numpy.ndarray
        """
        P = np.asarray(P, float)
        if theta is None:
            self.model.check_temperatures(P[1])
        theta = self.model.theta0 if theta is None else np.asarray(theta, float)
        return self.loop(P, x0, theta)


def simulate(config: TwinConfig, temp: ArrayLike, u: ArrayLike | None = None,
             yr: ArrayLike | None = None, dctrl: DiscreteController | None = None,
             seed: int = 0, t0: float = 0.0, theta: ArrayLike | None = None,
             simulator: Simulator | None = None) -> SimResult:
    """Simulate the twin on uniformly sampled profiles (one value per sample).

    Parameters
    ----------
    config : TwinConfig
        The twin.
    temp : array_like
        Ambient temperature per sample [°C].
    u : array_like, optional
        Commanded voltage per sample [V] (open loop).
    yr : array_like, optional
        Reference displacement per sample [µm] (closed loop; needs ``dctrl``).
    dctrl : DiscreteController, optional
        The RST controller discretised at ``config.sample_rate_hz``.
    seed : int
        Seed of the sensor-noise generator.
    t0 : float
        Time of the first sample [s].
    theta : array_like, optional
        The model's parameter vector (default: the config's values).
    simulator : Simulator, optional
        A compiled loop to reuse across runs (same config and controller).

    Returns
    -------
    SimResult

    Raises
    ------
    SpecError
        Neither or both of ``u`` and ``yr``, ``yr`` without ``dctrl``, or a controller
        sampled at another rate than the twin.
    DataError
        Profiles of different or zero length, or with NaN or inf.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst import default_twin, simulate
    >>> twin = default_twin().with_effects(only=[])
    >>> r = simulate(twin, np.full(2000, 28.0), u=np.full(2000, 10.0))
    >>> abs(float(r.y_true[-1]) - 6.68) < 0.3     # 10 V x 0.668 um/V, ringing at 616 Hz
    True
    """
    temp = np.asarray(temp, float)
    N = temp.size
    if (u is None) == (yr is None):
        raise SpecError("give exactly one of u (open loop) or yr (closed loop)")
    sig = np.asarray(u if u is not None else yr, float)
    if sig.shape != temp.shape or N == 0:
        raise DataError(f"profiles must have the same non-zero length (got {sig.size}, {N})")
    if not (np.all(np.isfinite(sig)) and np.all(np.isfinite(temp))):
        raise DataError("profiles contain NaN or inf")
    if yr is not None and dctrl is None:
        raise SpecError("closed-loop simulation needs a discretised controller (dctrl)")
    if dctrl is not None and abs(dctrl.sample_rate_hz - config.sample_rate_hz) > 1e-9 * config.sample_rate_hz:
        raise SpecError(f"controller sampled at {dctrl.sample_rate_hz} Hz, twin runs at {config.sample_rate_hz} Hz")
    sim = simulator or Simulator(build_model(config), dctrl if yr is not None else None)
    model = sim.model
    noise = np.random.default_rng(seed).standard_normal(N)
    P = np.vstack([sig, temp, noise])
    x0 = np.zeros(sim.n_x)
    x0[:model.n_state] = rest_state(model, sig[0] if u is not None else 0.0, temp[0])
    Y, _ = sim.run(P, x0, theta)
    t = t0 + np.arange(N) / config.sample_rate_hz
    u_cmd = sig if u is not None else Y[3]
    meta = {"twin": config.name, "sample_rate_hz": config.sample_rate_hz, "seed": int(seed),
            "effects_on": [k for k in config.effects if config.enabled(k)],
            "compiled": sim.is_compiled}
    return SimResult(t=t, u_cmd=u_cmd, u_applied=Y[2], y=Y[0], y_true=Y[1], temp=temp,
                     yr=None if yr is None else sig, meta=meta)
