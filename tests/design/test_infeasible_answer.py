"""An answer returned because no linear controller meets the specs says what its figure is."""

import tomllib
from dataclasses import replace

from robrst.design import run_problem
from robrst.problem.files import parse_problem

# a stable 2nd-order plant with a right-half-plane zero, |D(0)| = 4.64 µm/V: integral
# action makes T(0) = 1, so |U(0)| = 1/|D(0)| = 0.216 V/µm > Mu_max = 0.2154 — no linear
# controller meets the specs, whatever its order
TEXT = """
[plant]
B = [3253.7991286485735, -526073163.383761]
A = [1.0, 29639.093214042394, 113497175.7179922]
temperature_C = 30.41
[poles]
wn = 2441.708385342704
zeta = 0.9469905863725541
aux_factor = 20.823323621341874
[controller]
extra_degree = 1
T_mode = "static"
[specs]
Mt_max = 1.2216769393095035
Mu_max = 0.21538498956727303
[solver]
method = "nlp"
objective = "min_Ms"
"""


def test_the_analytic_start_returned_on_a_proof_is_named_as_such():
    res = run_problem(parse_problem(tomllib.loads(TEXT), "infeasible.toml"))
    assert not res.certified
    assert res.feasibility.status == "infeasible"
    assert "Mu_max" in res.feasibility.proofs[0].reason
    line = res.best_achievable
    # the contract's form (the worst violation of the controller returned) ...
    assert line.startswith("best achievable: model T30.41C")
    # ... said to be the analytic start's, not what binds: the start violates |U| at
    # 10 kHz, the proof is at 0 Hz
    assert line.endswith("(the analytic start, returned because no linear controller meets"
                         " the specs)")
    # without the proof, the plain worst violation
    plain = replace(res, feasibility=None).best_achievable
    assert line.startswith(plain) and "analytic start" not in plain
