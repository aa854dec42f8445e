"""``robrst.analyze`` of a discrete python-control plant is the sampled loop's analysis
(fourth round: ``analyze(control.c2d(P, 1/25000), ctrl)`` gave the continuous loop's Ms
1.2976; the 25 kHz loop's is 1.81).

Truth by python-control alone: the plant through ``control.c2d`` (ZOH), the controller
``R/S`` through ``control.c2d(..., "tustin")``, ``|S|, |T|, |U|`` on a dense unit-circle grid
with local refinement (``pcloop``), the margins by ``control.stability_margins`` of the
discrete loop, the closed-loop poles of ``control.feedback``.
"""

import math

import control
import numpy as np
import pytest

import pcloop
import robrst
from robrst.controller.artefact import load_design
from robrst.core.plant import Plant

FS = 25000.0


@pytest.fixture(scope="module")
def ctrl(repro_dir):
    return load_design(repro_dir / "turn4" / "a_good.json").controller


def _stage(gain=0.05, f0=1300.0, zeta=0.015):
    w0 = 2 * math.pi * f0
    return control.tf([gain * w0 * w0], [1, 2 * zeta * w0, w0 * w0])


def _truth(P, ctrl, fs, delay=0):
    Pz = control.c2d(P, 1 / fs, "zoh")
    if delay:
        Pz = Pz * control.tf([1.0], [1.0] + [0.0] * delay, 1 / fs)
    Kz = control.c2d(control.tf(ctrl.R, ctrl.S), 1 / fs, "tustin")
    z = np.exp(1j * pcloop.GRID)
    L = lambda z: pcloop.resp(Pz, z) * pcloop.resp(Kz, z)       # noqa: E731
    gm, pm, sm, wpc, wgc, wms = control.stability_margins(Pz * Kz)
    return {"Ms": pcloop.unit_circle_max(lambda z: 1 / (1 + L(z))),
            "Mt": pcloop.unit_circle_max(lambda z: L(z) / (1 + L(z))),
            "Mu": pcloop.unit_circle_max(lambda z: pcloop.resp(Kz, z) / (1 + L(z))),
            "gm": gm, "pm": pm, "wgc": wgc, "wpc": wpc,
            "rho": float(np.max(np.abs(control.feedback(Pz * Kz).poles()))), "Pz": Pz}


@pytest.mark.parametrize("delay", [0, 1])
def test_a_discrete_plant_gives_the_sampled_loop(ctrl, delay):
    P = _stage()
    t = _truth(P, ctrl, FS, delay)
    Pz = t["Pz"]
    a = robrst.analyze(Pz, ctrl)
    assert a.sample_rate_hz == pytest.approx(FS) and a.delay_samples == delay
    assert a.stable == (t["rho"] < 1)
    for k in ("S", "T", "U"):
        assert a.peaks[k].value == pytest.approx(t[f"M{k.lower()}"], rel=1e-6), k
    if delay == 0:        # the numbers: 1.81 sampled, 1.2976 continuous
        assert round(a.peaks["S"].value, 2) == 1.81
        assert robrst.analyze(P, ctrl).peaks["S"].value == pytest.approx(1.2976, abs=1e-4)
    m = a.margins
    assert m.gain_margin == pytest.approx(t["gm"], rel=1e-6)
    assert m.phase_margin_deg == pytest.approx(t["pm"], abs=1e-5)
    assert any(w == pytest.approx(t["wgc"], rel=1e-6) for w in m.gain_crossover_rad_s)
    assert all(w <= math.pi * FS * (1 + 1e-12) for w in m.gain_crossover_rad_s)
    # poles mapped to s = fs ln z: the spectral abscissa is fs ln(spectral radius)
    assert a.spectral_abscissa == pytest.approx(FS * math.log(t["rho"]), rel=1e-6)
    # the same through a robrst Plant read from the discrete system
    b = robrst.analyze(Plant.from_control(Pz), ctrl)
    assert b.peaks["S"].value == pytest.approx(a.peaks["S"].value, rel=1e-12)


def test_a_continuous_plant_is_still_the_continuous_loop(ctrl):
    a = robrst.analyze(_stage(), ctrl)
    assert a.sample_rate_hz is None
    w = np.geomspace(1.0, 1e7, 200_001)
    P = _stage()
    L = P(1j * w) * np.polyval(ctrl.R, 1j * w) / np.polyval(ctrl.S, 1j * w)
    assert a.peaks["S"].value == pytest.approx(np.max(np.abs(1 / (1 + L))), rel=1e-6)
