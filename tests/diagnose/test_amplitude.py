"""Amplitude-dependent dynamics (``amplitude_dependent_dynamics``): the level slopes of the
poles and of the residues, fitted on two excitation levels, predict a third.

The truth is a 2-input 2-output modal system whose resonance softens and whose mode
shapes (residues) change linearly with the excitation level; records are simulated with
python-control (ZOH of each level's model, steady state of periodic multisines), not
with robrst's simulation.  The fitted slopes are linear in the level while the truth's
damping ratio is not, and the pole slopes are fitted before the residue slopes (not
jointly), so the third level is predicted to 2 % of its signal, not to the noise.
"""

import control
import numpy as np
import pytest

from robrst.data.dataset import Dataset
from robrst.diagnose import diagnose
from robrst.identify.modal import ModalModel

FS, P = 5000.0, 1024
W0, W1 = 2 * np.pi * 400.0, 2 * np.pi * 900.0


def _truth(f):
    """The system at level factor f = (a - a_ref) / a_ref."""
    poles = np.array([-15.0 + 1j * W0 * (1 - 0.01 * f), -40.0 + 1j * W1 * (1 - 0.004 * f)])
    R = np.array([[[300.0, 120.0], [80.0, 250.0]],
                  [[-150.0, 400.0], [200.0, -90.0]]], complex)
    R = R * (1 + 0.06 * f * np.array([[[1, -1], [0.5, 2]], [[-1, 0.3], [1, 1]]]))
    return ModalModel(poles, R, np.zeros((2, 2)))


def _record(level, seed, noise=2e-4):
    rng = np.random.default_rng(seed)
    U = rng.standard_normal((P, 2))
    U *= level / np.sqrt(np.mean(U ** 2))
    sysd = control.c2d(_truth(level / 0.1 - 1.0).to_control(), 1.0 / FS, method="zoh")
    Y = np.asarray(control.forced_response(sysd, U=np.tile(U, (6, 1)).T).outputs).T[-2 * P:]
    Y = Y + noise * rng.standard_normal(Y.shape)
    return Dataset(t=np.arange(2 * P) / FS, u=np.tile(U, (2, 1)), y=Y, period=P,
                   source=f"a{level:g}_{seed}")


@pytest.mark.slow
def test_level_slopes_fitted_on_two_levels_predict_a_third():
    train = [_record(a, s) for a, s in ((0.1, 1), (0.1, 2), (0.2, 3), (0.2, 4))]
    test = [_record(0.3, 5)]
    d = diagnose(train, test, plant=_truth(0.0),
                 effects=("hysteresis", "creep", "amplitude_dependent_dynamics"))
    assert d.gap_before > 20 * d.noise_floor              # the level matters
    # the level-dependent linear form has its own name (it was called hysteresis)
    assert d.cause == "amplitude_dependent_dynamics", d.reason
    after = d.final.gap_after
    # the pole slopes alone leave 0.086 of the held-out gap (1.17); with the residue
    # slopes it is 0.024: the polish is what brings the third level within 2 %
    assert after < 0.03 and after < 0.03 * d.gap_before, (after, d.gap_before)
    assert any(f.kind == "amplitude_dependent" for f in d.findings)
