"""The controller-pole strip of ``max_integral_gain`` holds for every answer.

The robust program keeps every controller pole but the integrators at ``Re p <= -edge``
(``edge`` = 0.1 x the slowest dominant pole, or the slowest the free-pole bounds allow):
without it a slow lag ``(s + a)/(s + b)`` multiplies the integral gain ``lim s K(s)`` by
``a/b`` without limit.  A solve that ends outside the strip (IPOPT's acceptable level: a
Hurwitz row of the shifted controller polynomial violated within its tolerance, the pole
at half the edge) once won a design on a blind 4th-order stage at ``Ms_max`` 2.25 with
298 k against 231 k at 2.5 (every answer inside the strip reaches 224 k there): its
integral gain must never count.
"""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from robrst.core.rst import RSTController
from robrst.problem.files import load_problem
from robrst.synthesis.attempts import Outcome, objective_value
from robrst.synthesis.context import controller_strip, strip_note
from robrst.synthesis.multistart import multistart_record


def _edge(problem):
    """The strip's edge from the problem record (its poles and free-pole bounds)."""
    roots = np.asarray(problem.poles.dominant())
    slow = float(np.min(np.abs(roots)))
    so = problem.solver
    if so.free_poles:
        slow = min(slow, so.wn_bounds[0] * min(1.0, so.zeta_bounds[0]))
    return 0.1 * slow


def _outcome(ctrl):
    """A certified outcome of ``ctrl`` (the strip is judged on the controller alone)."""
    return Outcome(ctrl=ctrl, cert=SimpleNamespace(certified=True), res=None, phase="hard",
                   placement="free", x=np.zeros(1), setup=None)


@pytest.fixture(scope="module")
def problem():
    return load_problem("paper_robust")


def test_the_strip_edge_is_the_programs(problem):
    assert controller_strip(problem) == pytest.approx(_edge(problem), rel=1e-12)


@pytest.mark.parametrize("share", [0.5, 0.9, 0.97])
def test_a_lag_outside_the_strip_never_counts(problem, share):
    """S = s (s + b) with b below the edge: no objective, a note with the pole's place."""
    edge = _edge(problem)
    b = share * edge
    ctrl = RSTController(R=[2.0, 3.0], S=[1.0, b, 0.0], T=[3.0])
    assert objective_value(problem, _outcome(ctrl)) == -np.inf
    note = strip_note(problem, ctrl)
    assert note is not None and f"Re p = -{b:.4g} rad/s" in note and f"{edge:.4g}" in note


@pytest.mark.parametrize("share", [1.0, 0.985, 3.0])
def test_a_pole_on_or_inside_the_strip_counts(problem, share):
    """On the edge within IPOPT's slack (2 %) or inside: the integral gain R(0)/S'(0)."""
    b = share * _edge(problem)
    ctrl = RSTController(R=[2.0, 3.0], S=[1.0, b, 0.0], T=[3.0])
    assert strip_note(problem, ctrl) is None
    assert objective_value(problem, _outcome(ctrl)) == pytest.approx(3.0 / b, rel=1e-12)


def test_other_objectives_have_no_strip(problem):
    p = replace(problem, solver=replace(problem.solver, objective="feasibility"))
    ctrl = RSTController(R=[2.0, 3.0], S=[1.0, 0.01, 0.0], T=[3.0])
    assert strip_note(p, ctrl) is None
    assert objective_value(p, _outcome(ctrl)) == 0.0


def test_a_start_outside_the_strip_is_reported_without_objective():
    """The starts record: certified, no objective, the note; the winner is inside."""
    stage = SimpleNamespace(
        tried=(("lag", "certified", None, 3e5, 0.0, "free", "a controller pole at 28 rad/s"),
               ("inside", "certified", 2.2e5, 2.2e5, 0.0, "free", None)),
        objective="max_integral_gain", search=None)
    rec = multistart_record(stage, 1.0)
    assert rec.winner == "inside"
    lag = rec.outcomes[0].as_dict()
    assert lag["status"] == "certified" and lag["objective"] is None
    assert "28 rad/s" in lag["note"]
