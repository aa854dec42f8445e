"""The thermal law on plants nobody here wrote: repeated real poles stay real poles (np.roots
splits them into a pair with damping ~1, which the law used to turn into a resonance), and
the law is checked against the family built by hand with numpy."""

import numpy as np
import pytest

from robrst.core.family import parametric_family
from robrst.core.plant import Plant
from robrst.core.thermal import ThermalCoefficients


@pytest.mark.parametrize("mult", [2, 3, 4])
def test_repeated_real_poles_stay_and_the_resonance_moves(mult):
    w, z = 2 * np.pi * 1500.0, 0.02
    pair = [1.0, 2 * z * w, w * w]
    A = np.polymul(np.poly([-1000.0] * mult), pair)
    nominal = Plant([A[-1]], A, temperature_C=20.0)
    law = ThermalCoefficients(reference_C=20.0, gain_per_K=0.002, resonance_per_K=-0.005,
                              damping_per_K=-0.02)
    fam = parametric_family(nominal, [20.0, 30.0, 40.0], law)
    for m in fam.models:
        dT = m.temperature_C - 20.0
        wt, zt = w * (1 - 0.005 * dT), z * (1 - 0.02 * dT)
        expect = np.polymul(np.poly([-1000.0] * mult), [1.0, 2 * zt * wt, wt * wt])
        np.testing.assert_allclose(m.A, expect, rtol=1e-12, atol=0)
        np.testing.assert_allclose(m.B, [A[-1] * (1 + 0.002 * dT)], rtol=1e-14)
        assert np.sum(np.abs(np.roots(m.A).imag) > 1.0) == 2     # one resonant pair only
