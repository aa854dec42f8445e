"""The curves a design report draws, computed once from a design result.

:func:`design_curves` evaluates, for every family model, ``S``, ``T`` and ``U`` on the
report's frequency grid and the loop ``L = B R / (A S)`` on the Nyquist grid, the
reference and input-disturbance step responses at the extreme temperatures over a
horizon of three slowest settling times, and (optionally) the digital twin's reference
steps.  The report (:mod:`robrst.report.design`) draws the :class:`DesignCurves` it
receives and computes nothing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.core.analysis import sensitivity, step_response
from robrst.core.rst import closed_loop

if TYPE_CHECKING:
    from robrst.design import DesignResult

__all__ = ["ModelCurves", "StepCurves", "DesignCurves", "design_curves", "step_horizon",
           "FREQ_HZ", "NYQUIST_RAD_S"]

FREQ_HZ = np.logspace(0, 4.7, 1500)                   # the Bode grid, 1 Hz .. 50 kHz
NYQUIST_RAD_S = 2 * np.pi * np.logspace(-1, 5, 6000)  # the Nyquist grid


@dataclass(frozen=True, eq=False)
class ModelCurves:
    """One family model's frequency responses.

    Parameters
    ----------
    label : str
        The model.
    temperature_C : float
        Its temperature [°C].
    S, T, U : numpy.ndarray
        Complex responses on :data:`FREQ_HZ`.
    L : numpy.ndarray
        The loop ``B R / (A S)`` on :data:`NYQUIST_RAD_S`.
    """

    label: str
    temperature_C: float
    S: np.ndarray
    T: np.ndarray
    U: np.ndarray
    L: np.ndarray


@dataclass(frozen=True, eq=False)
class StepCurves:
    """Step responses of one model.

    Parameters
    ----------
    label : str
        The model.
    temperature_C : float
        Its temperature [°C].
    t_s : numpy.ndarray
        Times [s].
    reference_um : numpy.ndarray
        Response to a 1 µm reference step [µm].
    disturbance_um : numpy.ndarray
        Response to a 1 V input-disturbance step [µm].
    """

    label: str
    temperature_C: float
    t_s: np.ndarray
    reference_um: np.ndarray
    disturbance_um: np.ndarray


@dataclass(frozen=True, eq=False)
class DesignCurves:
    """Everything a design report draws besides the result's own records.

    Parameters
    ----------
    freq_hz : ndarray
        The Bode grid [Hz].
    models : tuple of ModelCurves
        One per family model, in the family's order.
    step_horizon_s : float
    steps : tuple of StepCurves
        At the extreme temperatures of the family.
    twin : dict
        ``label -> (t [s], y / step)`` of the digital twin's reference steps (empty: none).
    """

    freq_hz: np.ndarray
    models: tuple
    step_horizon_s: float
    steps: tuple
    twin: dict = field(default_factory=dict)


def step_horizon(result: DesignResult, t_max: float = 1.0) -> float:
    """Three times the slowest 2 % settling time of the reference step [s], 5 ms..1 s.

    (The spectral abscissa would be misleading: a slow pole nearly cancelled by a
    zero of T hardly shows in the response.)

    Parameters
    ----------
    result : DesignResult
    t_max : float

    Returns
    -------
    float
    """
    t = np.linspace(0, t_max, 20001)
    ts = 0.0
    for m in result.problem.family.models:
        cl = closed_loop(m, result.controller)
        y = step_response(cl.nums["Tr"], cl.Delta, t)
        final = y[-1] if abs(y[-1]) > 1e-12 else 1.0
        out = np.flatnonzero(np.abs(y - final) > 0.02 * abs(final))
        ts = max(ts, t[out[-1]] if out.size else 0.0)
    return float(np.clip(3 * ts, 5e-3, t_max))


def design_curves(result: DesignResult, twin: bool = False) -> DesignCurves:
    """The curves of ``result``'s report.

    Parameters
    ----------
    result : DesignResult
    twin : bool
        Also simulate the digital twin (the paper's plant only): reference steps of
        10 µm at the extreme temperatures, the controller Tustin-discretised at the
        twin's rate.

    Returns
    -------
    DesignCurves
    """
    fam = result.problem.family.models
    ctrl = result.controller
    w = 2 * np.pi * FREQ_HZ
    models = tuple(ModelCurves(
        label=m.label, temperature_C=m.temperature_C,
        S=sensitivity(m, ctrl, "S", w), T=sensitivity(m, ctrl, "T", w),
        U=sensitivity(m, ctrl, "U", w),
        L=(poly.eval_jw(poly.pmul(m.B, ctrl.R), NYQUIST_RAD_S)
           / poly.eval_jw(poly.pmul(m.A, ctrl.S), NYQUIST_RAD_S))) for m in fam)
    horizon = step_horizon(result)
    t = np.linspace(0, horizon, 2000)
    steps = []
    for m in ([fam[0], fam[-1]] if len(fam) > 1 else [fam[0]]):
        cl = closed_loop(m, ctrl)
        steps.append(StepCurves(label=m.label, temperature_C=m.temperature_C, t_s=t,
                                reference_um=step_response(cl.nums["Tr"], cl.Delta, t),
                                disturbance_um=step_response(cl.nums["Sd"], cl.Delta, t)))
    tw = {}
    if twin:
        from robrst.studies.scenarios import twin_step_responses
        from robrst.twin.config import default_twin

        tw = twin_step_responses(default_twin(), ctrl, (fam[0].temperature_C,
                                                        fam[-1].temperature_C), horizon)
    return DesignCurves(freq_hz=FREQ_HZ, models=models, step_horizon_s=horizon,
                        steps=tuple(steps), twin=tw)
