"""The multi-axis twin in closed loop: an amplitude-dependent plant and the digital controller.

The plant is the family's models over the excitation level (one identified model per
level: the effect a diagnosis names *amplitude-dependent dynamics*, as it is): every
model is simulated from the same input through its exact zero-order hold
(:func:`robrst.core.lti.zoh_matrices`), and the output is their convex combination at
the running level, ``y = (1 - lam) y_a + lam y_b`` between the neighbouring levels ``a, b``
(the family's :meth:`~robrst.core.mimo.MimoFamily.at`, here varying with time).  The level
is the running RMS of the actuator voltages (over ``level_window_s``) in the family's unit
(``level_per_volt`` of them per volt RMS: 1000 for levels in mV), clipped to the family's
range.  The controller is the exported one (:meth:`robrst.controller.mimo_export.MimoExported.stepper`:
sections, decoupler, saturation), its command applied ``delay_samples`` later.

:func:`step_tests` steps each axis's reference in turn and reports, per axis, the
tracking (overshoot, 2 % settling time, final error) and the crosstalk (the largest
excursion of every other axis, relative to the step).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti

if TYPE_CHECKING:
    from robrst.controller.mimo_export import MimoExported
    from robrst.core.mimo import MimoFamily

__all__ = ["TwinRun", "run_twin", "step_tests"]


@dataclass(frozen=True, eq=False)
class TwinRun:
    """One closed-loop run of the twin.

    Parameters
    ----------
    t : numpy.ndarray
        ``(N,)`` [s].
    r, y : numpy.ndarray
        ``(N, m)`` references and outputs [µm].
    u : numpy.ndarray
        ``(N, k)`` commands [V].
    level : numpy.ndarray
        ``(N,)`` the running level.
    """

    t: np.ndarray
    r: np.ndarray
    y: np.ndarray
    u: np.ndarray
    level: np.ndarray


def _discrete(family: MimoFamily, fs: float):
    out = []
    for mdl in family.models:
        n = mdl.n_states
        if not n:
            out.append((np.zeros((0, 0)), np.zeros((0, mdl.n_in)), mdl.C, mdl.D))
            continue
        w0 = mdl.w0
        Ad, _, Bd = lti.zoh_matrices(mdl.A / w0, mdl.B / w0, w0 / fs, gamma=False)
        out.append((Ad, Bd, mdl.C, mdl.D))
    return out


def run_twin(family: MimoFamily, ctrl: MimoExported, r: np.ndarray,
             level_per_volt: float = 1000.0, level_window_s: float = 0.02,
             level: float | None = None) -> TwinRun:
    """Run the twin in closed loop on the references ``r`` (module docstring).

    Parameters
    ----------
    family : MimoFamily
        The models over the level (a single model: a linear twin).
    ctrl : MimoExported
        The digital controller (its rate and delay).
    r : numpy.ndarray
        ``(N, m)`` references [µm], one row per sample.
    level_per_volt : float
        Family units per volt RMS.
    level_window_s : float
        The running RMS's window [s].
    level : float, optional
        A fixed level instead of the running one.

    Returns
    -------
    TwinRun
    """
    fs = ctrl.sample_rate_hz
    models = _discrete(family, fs)
    vals = np.array([m.value if m.value is not None else 0.0 for m in family.models])
    r = np.atleast_2d(np.asarray(r, float))
    N, m = r.shape
    k = ctrl.n_inputs
    step = ctrl.stepper()
    xs = [np.zeros(A.shape[0]) for A, *_ in models]
    y = np.zeros((N, m))
    U = np.zeros((N, k))
    L = np.zeros(N)
    d = int(ctrl.delay_samples)
    queue = [np.zeros(k)] * d
    win = max(1, int(round(level_window_s * fs)))
    sq = np.zeros(k)
    hist = np.zeros((win, k))
    lo, hi = float(vals.min()), float(vals.max())
    lev = lo if level is None else float(level)
    for n in range(N):
        ys = [C @ x for (A, B, C, D), x in zip(models, xs)]
        lam_lev = lev
        if len(models) == 1:
            yn = ys[0]
        else:
            i = int(np.clip(np.searchsorted(vals, lam_lev) - 1, 0, len(vals) - 2))
            lam = (lam_lev - vals[i]) / (vals[i + 1] - vals[i])
            yn = (1 - lam) * ys[i] + lam * ys[i + 1]
        u_now = step(r[n], yn)
        queue.append(u_now)
        ua = queue.pop(0)
        for j, ((A, B, C, D), x) in enumerate(zip(models, xs)):
            ys[j] = ys[j] + D @ ua
            xs[j] = A @ x + B @ ua
        if len(models) > 1:
            yn = (1 - lam) * ys[i] + lam * ys[i + 1]
        else:
            yn = ys[0]
        y[n], U[n], L[n] = yn, ua, lam_lev
        if level is None:
            sq += ua ** 2 - hist[n % win]
            hist[n % win] = ua ** 2
            rms = float(np.sqrt(max(np.mean(sq) / win, 0.0)))
            lev = float(np.clip(rms * level_per_volt, lo, hi))
    return TwinRun(np.arange(N) / fs, r, y, U, L)


def step_tests(family: MimoFamily, ctrl: MimoExported, step_um: float = 1.0,
               duration_s: float = 0.15, **kw: float) -> dict:
    """Step each axis's reference in turn (the others held at 0); tracking and crosstalk.

    Parameters
    ----------
    family : MimoFamily
    ctrl : MimoExported
    step_um : float
        The step [µm].
    duration_s : float
        Each test's length [s] (the step at a tenth of it).
    **kw
        Passed to :func:`run_twin`.

    Returns
    -------
    dict
        ``axes``: per axis ``overshoot_pct``, ``settling_time_s`` (2 %; ``None`` when it
        never settles), ``final_error_pct``, ``crosstalk_pct`` (the largest excursion of
        another axis, % of the step), ``u_peak_V``, ``level_max``; ``stable`` (every output
        bounded by 100 steps).
    """
    fs = ctrl.sample_rate_hz
    N = int(round(duration_s * fs))
    t0 = N // 10
    out, stable = [], True
    m = len(ctrl.axes)
    for j in range(m):
        r = np.zeros((N, m))
        r[t0:, j] = step_um
        run = run_twin(family, ctrl, r, **kw)
        y = run.y
        if not np.all(np.isfinite(y)) or np.max(np.abs(y)) > 100 * abs(step_um):
            stable = False
            out.append({"axis": ctrl.names[j], "stable": False})
            continue
        yj = y[t0:, j] / step_um
        err = np.abs(yj - 1.0)
        outside = np.flatnonzero(err > 0.02)
        settle = None if outside.size and outside[-1] == len(yj) - 1 else (
            float((outside[-1] + 1) / fs) if outside.size else 0.0)
        others = [i for i in range(m) if i != j]
        out.append({"axis": ctrl.names[j], "stable": True,
                    "overshoot_pct": float(max(0.0, 100 * (np.max(yj) - 1.0))),
                    "settling_time_s": settle,
                    "final_error_pct": float(100 * abs(yj[-1] - 1.0)),
                    "crosstalk_pct": float(100 * np.max(np.abs(y[t0:, others])) / step_um)
                    if others else 0.0,
                    "u_peak_V": float(np.max(np.abs(run.u))),
                    "level_max": float(np.max(run.level))})
    return {"axes": out, "stable": stable, "step_um": step_um, "duration_s": duration_s}
