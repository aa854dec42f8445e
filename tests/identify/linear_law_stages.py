"""Seeded random stages whose resonance, damping and gain change *exactly* linearly with
temperature (robrst's thermal law, :mod:`robrst.core.thermal`, written out here), and their
lab records simulated by python-control (exact ZOH, ``forced_response``): the population
on which the thermal law's test must hold (its false-rejection rate is measured on them).

A stage: one resonance (300 Hz .. 3 kHz, damping 0.005 .. 0.05, static gain 0.02 .. 0.2
µm/V), per kelvin a resonance change in +-5e-4, a damping change in +-5e-3 and a gain
change in +-2e-3 around 25 °C; three or four temperatures in 10 .. 60 °C; per temperature
two records (training, validation) of a white +-10 V input held one sample at 25 kHz,
0.2 s, with white (or, for a quarter of the stages, first-order coloured) measurement noise
of 0.5 .. 5 nm.
"""

import control
import numpy as np

from robrst.data.dataset import Dataset

FS = 25000.0
N = 5000
REF_C = 25.0


def law(seed):
    """The stage of ``seed``: ``(wn0, zeta0, gain0, r, z, g, temperatures, noise, colour)``."""
    rng = np.random.default_rng(seed)
    wn0 = 2 * np.pi * np.exp(rng.uniform(np.log(300.0), np.log(3000.0)))
    zeta0 = np.exp(rng.uniform(np.log(0.005), np.log(0.05)))
    gain0 = np.exp(rng.uniform(np.log(0.02), np.log(0.2)))
    r, z, g = rng.uniform(-5e-4, 5e-4), rng.uniform(-5e-3, 5e-3), rng.uniform(-2e-3, 2e-3)
    temps = np.sort(rng.choice(np.arange(10.0, 61.0, 2.5), size=int(rng.integers(3, 5)),
                               replace=False))
    noise = np.exp(rng.uniform(np.log(5e-4), np.log(5e-3)))      # µm
    colour = float(rng.uniform(0.3, 0.8)) if rng.uniform() < 0.25 else 0.0
    return wn0, zeta0, gain0, r, z, g, temps, noise, colour


def model(seed, T):
    """The stage's continuous model at ``T`` °C: ``B / A`` as python-control ``tf`` (the
    law: ``wn (1 + r dT)``, ``zeta (1 + z dT)``, ``B = gain wn0**2 (1 + g dT)``)."""
    wn0, zeta0, gain0, r, z, g, *_ = law(seed)
    dT = T - REF_C
    wn, zeta = wn0 * (1 + r * dT), zeta0 * (1 + z * dT)
    return control.tf([gain0 * wn0 ** 2 * (1 + g * dT)], [1.0, 2 * zeta * wn, wn * wn])


def records(seed):
    """``(train, validate)``: one record each per temperature of the stage of ``seed``."""
    *_, temps, noise, colour = law(seed)
    rng = np.random.default_rng(10_000 + seed)
    t = np.arange(N) / FS
    out = ([], [])
    for T in temps:
        Pz = control.c2d(model(seed, T), 1 / FS, "zoh")
        for part in out:
            u = rng.uniform(-10.0, 10.0, N)
            u[:50] = 0.0                                       # from rest
            y = np.asarray(control.forced_response(Pz, t, u).outputs)
            e = rng.normal(0.0, noise, N)
            if colour:                                         # AR(1) coloured noise
                e = np.asarray(control.forced_response(
                    control.tf([np.sqrt(1 - colour ** 2)], [1.0, -colour], 1 / FS), t, e).outputs)
            part.append(Dataset(t=t, u=u, y=y + e, temp=np.full(N, float(T)),
                                source=f"stage{seed}_T{T:g}"))
    return out
