"""The reference path's static gain is one on the loop that runs.

With integral action (``S(0) = 0``) a reference step must settle at the reference:
``y/yr`` has unit static gain.  The 2-DOF path is designed on the sampled loop's w-plane
plant, whose denominator is not monic; the closed-loop polynomial used to be normalised
before the static gain was set, which left a steady-state error of ``1 / Delta[0]``
(0.2-0.9 % on identified stages).  Checked here independently of robrst's own loop code:
python-control's ZOH of the continuous plant in state space, the controller's Tustin
state space, and the DC gain of the closed loop from ``yr`` to ``y``.
"""

import control
import numpy as np
import pytest

from robrst.core.rst import RSTController
from robrst.design import analytic_design
from robrst.problem.files import parse_problem
from robrst.synthesis.tracking import design_tracking


def _stage(f_hz, zeta, gain, fs, delay):
    w = 2 * np.pi * f_hz
    return parse_problem({
        "problem": {"name": "stage"},
        "plant": {"B": [gain * w * w], "A": [1.0, 2 * zeta * w, w * w]},
        "controller": {"extra_degree": 1, "T_mode": "reference_model",
                       "reference_wn": w / 3},
        "poles": {"wn": w / 3, "zeta": 1.0},
        "specs": {"sample_rate_hz": fs, "delay_samples": delay},
        "solver": {"method": "analytic"}}, "<stage>")


@pytest.mark.parametrize("scale", [1.0, 3.7e-4])       # R/S is the same controller at any scale
@pytest.mark.parametrize("f_hz, zeta, gain, fs, delay", [
    (800.0, 0.03, 0.2, 20000.0, 0), (800.0, 0.02, 0.2, 20000.0, 1),
    (150.0, 0.05, 1.5, 5000.0, 0)])
def test_reference_step_settles_at_the_reference(f_hz, zeta, gain, fs, delay, scale):
    pr = _stage(f_hz, zeta, gain, fs, delay)
    fb = analytic_design(pr).controller
    fb = RSTController(R=scale * fb.R, S=scale * fb.S, T=scale * fb.T)   # S not monic
    assert fb.S[-1] == 0.0                                  # integral action
    ctrl, _ = design_tracking(pr, fb)
    assert ctrl.T[-1] / ctrl.R[-1] == pytest.approx(1.0, abs=1e-12)
    plant = pr.family.reference_model
    Pd = control.c2d(control.ss(plant.to_tf()), 1 / fs)
    if delay:
        Pd = Pd * control.tf(
            [1.0], [1.0] + [0.0] * delay, 1 / fs)
    K = ctrl.to_ss(fs)                       # inputs (yr, y), output u
    Ap, Bp, Cp, Dp = (np.asarray(m, float) for m in (Pd.A, Pd.B, Pd.C, Pd.D))
    assert np.all(Dp == 0.0)                 # ZOH of a strictly proper plant
    Ak, Bk, Ck, Dk = (np.asarray(m, float) for m in (K.A, K.B, K.C, K.D))
    A = np.block([[Ap + Bp @ Dk[:, 1:] @ Cp, Bp @ Ck], [Bk[:, 1:] @ Cp, Ak]])
    B = np.vstack([Bp @ Dk[:, :1], Bk[:, :1]])
    C = np.hstack([Cp, np.zeros((1, Ak.shape[0]))])
    assert np.max(np.abs(np.linalg.eigvals(A))) < 1.0
    dc = (C @ np.linalg.solve(np.eye(A.shape[0]) - A, B)).item()
    assert dc == pytest.approx(1.0, abs=1e-9)
