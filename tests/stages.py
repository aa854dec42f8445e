"""A user's stage that is not the paper's (test helper): a textbook second-order piezo
stage and its records, simulated by python-control (``control.c2d`` ZOH, ``forced_response``),
independently of robrst's simulators.

``G_T(s) = k_T w_T^2 / (s^2 + 2 z_T w_T s + w_T^2)``: 0.2 µm/V, 800 Hz, damping 0.03 at
20 °C; per kelvin the resonance moves -0.05 %, the damping +0.5 %, the gain +0.1 %.
"""

import control
import numpy as np

from robrst.data.dataset import Dataset, save_dataset

FS = 10000.0          # the records' rate (the controller's too)
NOISE_UM = 0.005      # 5 nm sensor noise
REFERENCE_C = 20.0


def stage_params(T):
    """``(gain µm/V, natural frequency rad/s, damping)`` at ``T`` °C."""
    dT = T - REFERENCE_C
    return (0.2 * (1 + 0.001 * dT), 2 * np.pi * 800.0 * (1 - 0.0005 * dT),
            0.03 * (1 + 0.005 * dT))


def stage_tf(T=REFERENCE_C):
    """The stage at ``T`` as a continuous ``control.TransferFunction`` [µm/V]."""
    k, w, z = stage_params(T)
    return control.tf([k * w * w], [1.0, 2 * z * w, w * w])


def white_record(T, seed, n=10000, std_V=10.0, name=None):
    """A white-noise voltage record at ``T`` °C with 5 nm noise (python-control's ZOH)."""
    rng = np.random.default_rng(seed)
    u = rng.normal(0.0, std_V, n)
    t = np.arange(n) / FS
    Pd = control.c2d(control.ss(stage_tf(T)), 1.0 / FS)
    y = np.ravel(control.forced_response(Pd, t, u).outputs) + rng.normal(0.0, NOISE_UM, n)
    return Dataset(t=t, u=u, y=y, temp=np.full(n, float(T)),
                   source=name or f"white_T{T:g}_{seed}")


def write_records(folder, temps=(20.0, 40.0), seeds=(1, 2)):
    """Records at every temperature and seed written as CSV; returns the paths per seed."""
    out = {s: [] for s in seeds}
    for T in temps:
        for s in seeds:
            d = white_record(T, s + int(T))
            path = folder / f"{d.source}.csv"
            save_dataset(d, path)
            out[s].append(path)
    return out
