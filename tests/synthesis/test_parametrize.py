"""The decision vector of a controller whose S has a fixed factor, at large coefficients.

A polish of the global phase rescales the program at its candidate and maps the
candidate's controller to the decision vector of that scaling
(:meth:`robrst.synthesis.parametrize.Parametrization.vector`), which divides ``S`` by its
fixed factor.  The remainder of that division was held to ``1e-8`` absolutely: on the
seeded random problem 770064 (5th order, a right-half-plane zero, ``S_fixed = s (0.0058 s
+ 1)``) the normalised ``S`` of a polished controller has coefficients up to 1.4e6, its
remainder was 1.8e-8 (1e-14 of them, rounding), and the design stopped with "initial
controller does not contain the fixed factors" instead of an answer.  The remainder is
now judged relative to the coefficients divided, as R's was.

The controllers here are built with numpy's own polynomial product, not robrst's.
"""

from dataclasses import fields, replace

import numpy as np
import pytest

from random_problems import check, random_case
from robrst.base.errors import SolverError
from robrst.core.plant import Plant
from robrst.core.poly import Scaling
from robrst.core.rst import RSTController
from robrst.design import run_problem
from robrst.problem.files import parse_problem
from robrst.problem.records import ControllerStructure
from robrst.synthesis.context import Context
from robrst.synthesis.parametrize import Parametrization, TrackingRule
from stages_global import stage_doc

# the reproducer's nominal model (770064, 3.63 °C) and fixed factor of S
PLANT = Plant(B=np.array([2.14654625e+00, -4.54866671e+02, -6.99206465e+04, -2.28446004e+05]),
              A=np.array([1.0, 5.32948409e+01, 3.09122920e+03, 1.12210111e+05,
                          1.01079825e+06, 2.20637873e+06]))
S_FIXED = (0.005838784449878155, 1.0, 0.0)


def _param(w0):
    structure = ControllerStructure(S_fixed=S_FIXED, R_fixed=(1.0,))
    return Parametrization.of(structure, PLANT, Scaling(w0))


def _controller(par, rng, spread):
    """A controller of ``par``'s degrees: ``S = S_fixed S'`` with ``S'`` monic, its roots
    spread over ``spread`` decades (rad/s), and R random of its degree."""
    roots = -np.logspace(0.5, 0.5 + spread, par.ks) * rng.uniform(0.8, 1.2, par.ks)
    S = np.polymul(np.array(S_FIXED) / S_FIXED[0], np.poly(roots))
    zeros = -np.logspace(0.5, 0.5 + spread, par.kr) * rng.uniform(0.8, 1.2, par.kr)
    R = rng.uniform(0.1, 10.0) * np.poly(zeros)
    return RSTController(R=R, S=S, T=np.array([R[-1]]))


@pytest.mark.parametrize("w0", [1.0, 13.26, 400.0])
@pytest.mark.parametrize("spread", [2.0, 4.0])
def test_vector_of_a_controller_with_large_coefficients_round_trips(w0, spread):
    par = _param(w0)
    rng = np.random.default_rng(770064)
    for _ in range(20):
        ctrl = _controller(par, rng, spread)
        x = par.vector(ctrl)
        back = par.controller(x, TrackingRule("static", (), PLANT.B))
        for got, want in ((back.S, ctrl.S), (back.R, ctrl.R)):
            want = np.concatenate([np.zeros(len(got) - len(want)), want])
            assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))


def test_vector_still_refuses_a_controller_without_the_fixed_factor():
    par = _param(13.26)
    ctrl = _controller(par, np.random.default_rng(1), 2.0)
    S = np.array(ctrl.S, float)
    S[-2] *= 1.5           # the root at -1/0.0058 rad/s is no longer a root of S
    with pytest.raises(SolverError, match="fixed factors"):
        par.vector(RSTController(R=ctrl.R, S=S, T=ctrl.T))


@pytest.mark.slow
def test_random_problem_770064_gets_a_certified_answer():
    case = random_case(770064)
    res = run_problem(case.problem(), analyses=False)
    assert res.certified
    assert check(case.data, res) == []


class _Refusing(Parametrization):
    """A parametrisation whose :meth:`vector` refuses every controller."""

    def vector(self, ctrl):
        raise SolverError("initial controller does not contain the fixed factors")


@pytest.mark.slow
def test_a_polish_that_cannot_start_leaves_the_other_outcomes_to_answer(monkeypatch):
    """Every polish's rescaled program refuses its candidate: the design still answers
    with the search's candidates as screened, and says why nothing was polished."""
    around = Context.around

    def refusing(self, ctrl):
        near = around(self, ctrl)
        par = _Refusing(**{f.name: getattr(near.param, f.name) for f in fields(near.param)})
        return replace(near, param=par)

    monkeypatch.setattr(Context, "around", refusing)
    res = run_problem(parse_problem(stage_doc(13, order=2, ms=1.75), "<stage 13>"),
                      analyses=False)
    assert res.certified
    assert not any(", polished" in row[0] for row in res.synthesis.tried)
    assert any("not polished" in n and "does not map" in n for n in res.synthesis.notes)
