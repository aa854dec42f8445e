"""The closed-loop stability rows of the robust program, exchanged like its grid points.

The program's first round carries the Routh rows of a few models per closed-loop degree
(those nearest to instability at the start); a model whose rows the round's result
violates joins, and the program is solved again.  The result must be the one of the
program with every model's rows, and stable on every model (checked here with
``numpy.roots``, not with the Routh rows the code uses).
"""

import tomllib

import casadi as ca
import numpy as np
import pytest

from robrst.design import analytic_design
from robrst.base.resources import problems_dir
from robrst.problem.files import parse_problem
from robrst.synthesis import exchange, stability
from robrst.synthesis.context import Context
from robrst.synthesis._nlp import routh_column

IPOPT = {"max_iter": 500, "tol": 1e-10, "print_level": 0, "sb": "yes",
         "mu_strategy": "monotone", "nlp_scaling_method": "none"}


def test_numeric_routh_column_is_the_symbolic_one_and_decides_like_the_roots():
    rng = np.random.default_rng(11)
    decided = 0
    for _ in range(300):
        n = int(rng.integers(2, 10))
        roots = -10 ** rng.uniform(-1, 1, n) + 1j * 0
        if rng.uniform() < 0.5:            # a pair moved a random way (maybe unstable)
            roots[:2] = rng.uniform(-0.5, 0.5) + np.array([1j, -1j]) * rng.uniform(0.1, 3)
        c = np.real(np.poly(roots)) * rng.uniform(0.5, 2)
        num = routh_column(c / c[0])
        x = ca.SX.sym("c", n + 1)
        sym = ca.Function("r", [x], [routh_column(x / x[0])])(c)
        np.testing.assert_allclose(num, np.array(sym).ravel(), rtol=1e-12, atol=1e-300)
        sa = np.max(np.roots(c).real)
        if abs(sa) > 1e-6:                 # clear of the boundary: the roots decide
            assert (np.min(num) > 0) == (sa < 0), (c, num, sa)
            decided += 1
    assert decided > 250


def _paper_robust(n_freq=60):
    """paper_robust's program: 14 models, 12 of them of closed-loop degree 9."""
    path = problems_dir() / "paper_robust.toml"
    data = tomllib.loads(path.read_text())
    data["solver"]["n_freq"] = n_freq
    data["solver"].pop("compare_with", None)
    problem = parse_problem(data, str(path))
    start = analytic_design(problem)
    ctx = Context.of(problem, start)
    setup = ctx.setup(list(problem.family.models), ctx.nu, "dominant")
    return setup, ctx.full(ctx.param.vector(start.controller), setup)


def _stable_everywhere(setup, x):
    rows = stability.stability_rows(setup)
    xc = x[:rows[0][1].shape[1]]
    return max(np.max(np.roots(Dm @ xc + Dc).real) for _, Dm, Dc in rows)


@pytest.fixture(scope="module")
def solved():
    setup, x0 = _paper_robust()
    templates = {}
    part = exchange.solve_exchange(setup, x0, IPOPT, templates=templates)
    rows = stability.stability_rows(setup)
    every = tuple(range(len(rows)))
    full = exchange.solve_exchange(setup, x0, IPOPT, templates=templates, stability=every)
    none = exchange.solve_exchange(setup, x0, IPOPT, templates=templates, stability=())
    return setup, x0, rows, part, full, none


def test_the_first_round_carries_the_models_nearest_to_instability(solved):
    setup, x0, rows, part, full, _ = solved
    first = stability.initial_stability(rows, x0)
    degs = [r[0] for r in rows]
    margins = stability.routh_margins(rows, x0)
    for deg in set(degs):
        mine = [j for j, d in enumerate(degs) if d == deg]
        kept = [j for j in first if degs[j] == deg]
        if len(mine) <= 2 * stability.ROUTH_FIRST:
            assert kept == mine
        else:
            assert len(kept) == stability.ROUTH_FIRST
            assert max(margins[kept]) <= min(margins[[j for j in mine if j not in kept]])
    assert part.exchange.stability_models < len(rows) == full.exchange.stability_models


@pytest.mark.parametrize("which", ["part", "none"])
def test_fewer_stability_rows_reach_the_optimum_of_all_of_them(solved, which):
    """From the nearest models, or from none at all (every model must then join by the
    exchange if the path leaves it unstable): the optimum of the program with every
    model's rows, stable on every model by numpy.roots."""
    setup, x0, rows, part, full, none = solved
    res = part if which == "part" else none
    assert res.success and full.success
    assert res.objective == pytest.approx(full.objective, rel=1e-7, abs=1e-9)
    scale = np.max(np.abs(full.x))
    assert np.max(np.abs(res.x - full.x)) <= 1e-5 * scale
    assert _stable_everywhere(setup, res.x) < 0
    assert np.min(stability.routh_margins(rows, res.x)) >= stability.ROUTH_MIN


def test_a_model_whose_rows_a_round_violates_joins(solved, monkeypatch):
    """The first round's result reported unstable on a model left out: it joins, the
    program is solved again from there, and the optimum is still that of every row."""
    setup, x0, rows, _, full, _ = solved
    real, calls = stability.routh_margins, []

    def margins(rows_, x):
        out = real(rows_, x)
        calls.append(x)
        if len(calls) == 1:
            out[5] = -1.0               # as if the first round had left model 5 unstable
        return out

    monkeypatch.setattr(stability, "routh_margins", margins)   # as joined() sees it
    res = exchange.solve_exchange(setup, x0, IPOPT, templates={}, stability=(0,))
    assert res.success and res.exchange.rounds >= 2
    assert res.exchange.stability_models >= 2 and len(calls) >= 2
    assert res.objective == pytest.approx(full.objective, rel=1e-7, abs=1e-9)
    assert _stable_everywhere(setup, res.x) < 0
