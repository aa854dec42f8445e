"""Design for the fleet: the yield measured on fresh actuators, independently of the design.

A small resonant stage (continuous loop, two temperatures) is designed for its spread over
a few drawn actuators.  The yield is then measured on *fresh* actuators (another seed)
without robrst's kernels: each actuator's models are built by hand from its drawn factors
and the per-kelvin law, the loop closed in python-control (state space: the closed-loop
poles are the eigenvalues of its A matrix), and |S| and |T| taken on a dense frequency
grid, every 2 K over the interval.  The nominal design (the spread dropped) on the
same actuators collapses: that is the test that fails when the spread is not designed for.
"""

from dataclasses import replace

import control
import numpy as np
import pytest

from robrst.design import run_problem
from robrst.problem.files import parse_problem
from robrst.problem.spread import draw_rows

DOC = {
    "problem": {"name": "tiny_fleet"},
    "plant": {"B": [10000.0], "A": [1.0, 60.0, 10000.0], "temperature_C": 20.0},
    "family": {"temperatures_C": [20.0, 40.0], "parametric": {"gain_per_K": 0.002}},
    "poles": {"wn": 30.0, "zeta": 1.0},
    "specs": {"Ms_max": 1.6, "Mt_max": 1.3},
    "solver": {"method": "nlp", "objective": "max_integral_gain", "n_freq": 60,
               "cert_temperatures": 5},
    "spread": {"yield": 0.9, "confidence": 0.9, "seed": 7, "scenarios": 12, "param": [
        {"name": "gain", "dist": "normal", "mean": 1.0, "std": 0.1, "lo": 0.7, "hi": 1.3},
        {"name": "resonance", "dist": "normal", "mean": 1.0, "std": 0.03},
        {"name": "damping", "dist": "lognormal", "median": 1.0, "sigma": 0.3}]},
}
FRESH_SEED = 123_457      # not the design's seed (7)
W = np.geomspace(1e-2, 1e5, 8_000)


def _plant(gain, resonance, damping, T):
    """The drawn actuator at ``T`` by hand: B = 1e4 g (1 + 0.002 dT), the pair's wn and
    zeta scaled (wn = 100, zeta = 0.3 nominal)."""
    wn, zeta = 100.0 * resonance, 0.3 * damping
    b = 10000.0 * gain * (1 + 0.002 * (T - 20.0))
    return control.tf([b], [1.0, 2 * zeta * wn, wn * wn])


def _certifies(ctrl, row, rtol=1e-3):
    """Stable and |S| <= 1.6, |T| <= 1.3 (within rtol) every 2 K over 20..40 °C."""
    K = control.tf(ctrl.R, ctrl.S)
    for T in np.arange(20.0, 40.5, 2.0):
        L = _plant(*row, T) * K
        cl = control.ss(control.feedback(L, 1))
        if np.max(np.linalg.eigvals(cl.A).real) >= 0:
            return False
        l = np.asarray(L(1j * W)).ravel()
        if np.max(np.abs(1 / (1 + l))) > 1.6 * (1 + rtol) or \
                np.max(np.abs(l / (1 + l))) > 1.3 * (1 + rtol):
            return False
    return True


@pytest.fixture(scope="module")
def designs():
    problem = parse_problem(DOC, "tiny_fleet.toml")
    fleet = run_problem(problem)
    nominal = run_problem(replace(problem, spread=None))
    return problem, fleet, nominal


def test_fleet_design_certifies_on_every_drawn_actuator(designs):
    problem, fleet, nominal = designs
    f = fleet.fleet
    assert f.n_scenarios == 12 and f.seed == 7
    assert not f.violated and fleet.certified
    # the drawn actuators are the spread's own draws of seed 7, checked independently
    rows = draw_rows(problem.spread.params, 12, 7)
    np.testing.assert_array_equal(f.values, rows)
    assert all(_certifies(fleet.controller, r) for r in rows)
    # the guarantee is the published a-posteriori bound at the compression size found
    from robrst.synthesis.scenario import nonconvex_epsilon

    assert f.epsilon == nonconvex_epsilon(len(f.compression), 12, 0.1)
    d = fleet.as_dict()["fleet"]
    assert d["compression_size"] == len(f.compression) and d["guaranteed_yield"] == 1 - f.epsilon


def test_yield_on_fresh_actuators_and_its_collapse_without_the_spread(designs):
    """python-control on 40 fresh actuators: the fleet design certifies on >= 90 % of them,
    the nominal design (spread dropped) on fewer than half."""
    problem, fleet, nominal = designs
    rows = draw_rows(problem.spread.params, 40, FRESH_SEED)
    fleet_yield = np.mean([_certifies(fleet.controller, r) for r in rows])
    nominal_yield = np.mean([_certifies(nominal.controller, r) for r in rows])
    assert fleet_yield >= 0.9, fleet_yield
    assert nominal_yield < 0.5, nominal_yield
