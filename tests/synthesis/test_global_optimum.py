"""The robust program's answer against an independent global search on a small problem.

A 1 kHz stage (damping 0.02) over 15-45 °C, continuous loop, ``extra_degree = 0`` and every
coefficient free: ``S = s (s + a)``, ``R`` of degree 2, four free coefficients.  The
independent search is ``scipy.optimize.differential_evolution`` over ``(ki, a, wz, zeta_z)``
(``R = ki a (s^2/wz^2 + 2 zeta_z s/wz + 1)``), feasibility judged on a dense frequency grid
of the unscaled polynomials (|S|, |T|, |U| at 7 temperatures) and the roots of ``A S + B R``
(stability and the default damping floor); its best point is then certified by robrst's
certificate (the feasibility test of record).  robrst's answer (the default design with its
global phase, as a user runs it) must reach that certified optimum to 1 %.
"""

import numpy as np
import pytest
from scipy.optimize import differential_evolution

from robrst.certificate.proof import certify_problem
from robrst.core.rst import RSTController
from robrst.design import run_problem
from robrst.problem.files import parse_problem

W = 2 * np.pi * 1000.0
DOC = {"problem": {"name": "small"},
       "plant": {"B": [0.5 * W * W], "A": [1.0, 2 * 0.02 * W, W * W], "temperature_C": 25.0},
       "family": {"temperatures_C": [15.0, 30.0, 45.0],
                  "parametric": {"resonance_per_K": -0.001}},
       "poles": {"wn": 600.0, "zeta": 1.0},
       "specs": {"Ms_max": 2.0, "Mt_max": 1.3, "Mu_max": 150.0,
                 # the default step and disturbance specs off: this search judges |S|, |T|,
                 # |U| and the damping floor (tests/synthesis/test_monotone.py
                 # compares with the defaults on)
                 "overshoot_max_pct": False, "Msd_rel_max": False},
       "solver": {"method": "nlp", "placement": "free"}}
GRID = np.geomspace(1.0, 1e6, 4000)


def _controller(v):
    ki, a, wz, zz = 10 ** v[0], 10 ** v[1], 10 ** v[2], v[3]
    R = ki * a * np.array([1.0 / wz ** 2, 2 * zz / wz, 1.0])
    return R, np.array([1.0, a, 0.0])


def _violation(v, models, floor):
    R, S = _controller(v)
    worst = 0.0
    for A, B in models:
        D = np.polyadd(np.polymul(A, S), np.polymul(B, R))
        r = np.roots(D)
        if np.max(r.real) >= 0:
            return 10.0 + np.max(r.real)
        zeta = np.min(np.where(np.abs(r) > 0, -r.real / np.abs(r), 1.0))
        worst = max(worst, floor / zeta - 1.0)
        d = np.polyval(D, 1j * GRID)
        for N, b in ((np.polymul(A, S), 2.0), (np.polymul(B, R), 1.3), (np.polymul(A, R), 150.0)):
            worst = max(worst, np.max(np.abs(np.polyval(N, 1j * GRID) / d)) / b - 1.0)
    return worst


@pytest.fixture(scope="module")
def searched():
    """robrst's answer (default design) and the global search's certified optimum."""
    p = parse_problem(DOC, "<small>")
    models = [(m.A, m.B) for m in (p.family.at(T) for T in np.linspace(15, 45, 7))]
    floor, _ = p.specs.damping_floor(p.family)

    def cost(v):
        viol = _violation(v, models, floor)
        return -v[0] + (1e3 * viol if viol > 0 else 0.0)

    de = differential_evolution(cost, [(0.0, 6.0), (1.0, 7.0), (2.0, 6.0), (-1.0, 3.0)],
                                seed=20261126, popsize=20, maxiter=200, tol=1e-10,
                                polish=False)
    v = de.x.copy()     # the best point certified by the certificate; ki shrunk until it is
    for _ in range(40):
        R, S = _controller(v)
        if certify_problem(p, RSTController(R=R, S=S, T=np.array([R[-1]]))).certified:
            break
        v[0] -= 0.002
    else:
        pytest.fail("the global search found no certified point")
    res = run_problem(p)
    print(f"\nrobrst {res.integral_gain:.6g}  differential evolution {10 ** v[0]:.6g}  starts"
          f" {[round(o['objective'] or 0, 1) for o in res.as_dict()['starts']['starts']]}")
    return res, 10 ** v[0]


@pytest.mark.slow
def test_robust_program_is_within_reach_of_the_global_search(searched):
    """The default design (its global phase) is certified and reaches at least 95 % of the
    global search's certified optimum (the process-pool multi-start before it: 118,440
    against 194,573, 61 %)."""
    res, ki_de = searched
    assert res.certified
    assert res.integral_gain >= 0.95 * ki_de


@pytest.mark.slow
def test_robust_program_reaches_the_global_search_optimum(searched):
    """Within 1 % of it (measured: 194,216 against 194,711, 99.7 %)."""
    res, ki_de = searched
    assert res.integral_gain >= 0.99 * ki_de
