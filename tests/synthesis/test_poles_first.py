"""A polish's later solves start over the poles once an earlier solve of the same polish
needed them (``robrst.synthesis.attempts.Run.boxed``): the trust region over the
coefficients, which failed there, runs only when the poles fail too.

The solvers are replaced by recorders here (the order of the calls is the property); the
designs that depend on it are checked end to end by ``test_monotone.py`` and
``test_pole_polish.py``."""

from dataclasses import dataclass, replace
from types import SimpleNamespace

import numpy as np
import pytest

import robrst.synthesis.attempts as attempts
from robrst.synthesis.attempts import Run
from robrst.synthesis.exchange import Phase


@dataclass(frozen=True)
class _Result:
    success: bool
    objective: float
    x: np.ndarray
    iterations: int = 10


def _run(monkeypatch, coefficients_ok, poles_ok):
    calls = []

    def coefficients(setup, x, *args, **kwargs):
        calls.append("coefficients")
        return _Result(coefficients_ok, -1.0, np.asarray(x, float))

    def poles(self, ctx, setup, x0, *args, **kwargs):
        calls.append("poles")
        return _Result(poles_ok, -2.0, np.asarray(x0, float))

    monkeypatch.setattr(attempts, "solve_exchange", coefficients)
    monkeypatch.setattr(Run, "in_pole_space", poles)
    monkeypatch.setattr(attempts, "RUN", replace(attempts.RUN, pole_polish=True))
    problem = SimpleNamespace()
    run = Run(problem, lambda s: None, {}, None, 500, lambda: False)
    run.pole_space = object()
    ctx = SimpleNamespace(ipopt={"max_iter": 300}, param=SimpleNamespace(n_x=3))
    return run, ctx, calls


@pytest.mark.parametrize("poles_ok", [True, False])
def test_a_run_that_needed_the_poles_starts_there(monkeypatch, poles_ok):
    run, ctx, calls = _run(monkeypatch, coefficients_ok=True, poles_ok=poles_ok)
    run.poles_first = True
    res = run.boxed(ctx, None, np.ones(4), Phase("hard"), exact=False)
    if poles_ok:           # the poles' answer, no coefficient solve
        assert calls == ["poles"] and res.objective == -2.0 and run.over_poles
    else:                  # the poles failed: the coefficients' trust region, not the poles again
        assert calls[0] == "poles" and calls.count("poles") == 1
        assert "coefficients" in calls and res.objective == -1.0 and not run.over_poles
        assert res.iterations == 10 * len(calls)


def test_a_fresh_polish_tries_the_coefficients_first(monkeypatch):
    run, ctx, calls = _run(monkeypatch, coefficients_ok=False, poles_ok=True)
    res = run.boxed(ctx, None, np.ones(4), Phase("hard"), exact=False)
    assert calls == ["coefficients", "poles"] and res.objective == -2.0
    assert run.over_poles             # the run's next solve starts over the poles
    calls.clear()
    run.boxed(ctx, None, np.ones(4), Phase("hard"), exact=False)
    assert calls == ["poles"]


def test_coefficients_that_succeed_keep_the_run_on_them(monkeypatch):
    run, ctx, calls = _run(monkeypatch, coefficients_ok=True, poles_ok=True)
    run.boxed(ctx, None, np.ones(4), Phase("hard"), exact=False)
    assert "poles" not in calls and not run.over_poles
