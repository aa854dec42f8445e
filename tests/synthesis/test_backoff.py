"""A polish that ends just outside the specs keeps the exchange's points when backed off.

A stage with two resonances (600 Hz, damping 0.02; 2.1 kHz, damping 0.01; 0.1 µm/V, 20 kHz
loop, 20-40 °C) and ``damping_min = 0.1``.  The polish of the global phase's best
candidate spends its iteration budget with the sampled loop's |S| peak 0.7 % above its
bound, between the exchange's frequencies.  Its back-off was solved again on the
program's first grid, missed the same peak again (1.7 %), and certified only with every
peak bound 4.8 % inside: integral gain 335,704 with Ms 1.95, Mt 1.24 and Mu 190 against
2, 1.3 and 200.  The back-off now starts from the grid the polish's rounds reached (the
certificate's offending frequencies and temperatures included) and certifies at the first
back-off (404,178 when this test was written, every peak within 1.5 % of its bound).

The figures are checked independently with python-control (:mod:`loopcheck`, :mod:`pcloop`)
on the unscaled loop at 21 temperatures, both loops, at the certificate's tolerance
(``[solver] cert_tol``: the answer polished again reaches |S| 2.00036 in the sampled loop at
20 °C, within 1e-3 of its bound 2).
"""

import numpy as np
import pytest

import loopcheck
from robrst.design import run_problem
from robrst.problem.files import parse_problem

pytestmark = pytest.mark.slow

DOC = {"problem": {"name": "two_resonances"},
       # (s^2 + 2 0.02 w1 s + w1^2)(s^2 + 2 0.01 w2 s + w2^2), w1 = 2 pi 600, w2 = 2 pi 2100,
       # to eight digits as a user writes it (the design's path, and its answer, move with
       # the last digit: the coefficients rounded otherwise reach 297,675 by another path)
       "plant": {"B": [2.4743468e14],
                 "A": [1.0, 414.69023, 1.8835185e8, 3.0004154e10, 2.4743468e15],
                 "temperature_C": 25.0},
       "family": {"temperatures_C": [20.0, 30.0, 40.0],
                  "parametric": {"resonance_per_K": -0.0002}},
       "controller": {"extra_degree": 1},
       "poles": {"wn": 750.0, "zeta": 1.0},
       "specs": {"Ms_max": 2.0, "Mt_max": 1.3, "Mu_max": 200.0, "damping_min": 0.1,
                 "sample_rate_hz": 20000.0},
       "solver": {"method": "nlp", "objective": "max_integral_gain"}}
BEFORE = 335_704.0      # the answer when the back-off re-solved on the first grid


@pytest.fixture(scope="module")
def designed():
    problem = parse_problem(DOC, "<two resonances>")
    return problem, run_problem(problem, analyses=False)


def test_the_backed_off_polish_is_not_far_inside_its_bounds(designed):
    _, res = designed
    assert res.certified
    assert res.integral_gain >= 1.1 * BEFORE, res.integral_gain


def test_its_figures_hold_on_python_controls_loops(designed):
    problem, res = designed
    ctrl, sp = res.controller, problem.specs
    for T in np.linspace(20.0, 40.0, 21):
        m = problem.family.at(T)
        c = loopcheck.continuous(m, ctrl)
        s = loopcheck.sampled(m, ctrl, sp.sample_rate_hz, sp.delay_samples)
        # within the certificate's stated tolerance (relative, ``[solver] cert_tol``)
        tol = problem.solver.cert_tol
        assert c.damping >= 0.1 * (1 - tol) and s.damping >= 0.1 * (1 - tol), (T, c, s)
        assert max(c.Ms, s.Ms) <= 2.0 * (1 + tol), (T, c.Ms, s.Ms)
