"""Constraint exchange: same optimum as the full-grid NLP, every grid point satisfied."""

import tomllib

import numpy as np
import pytest

from robrst.design import analytic_design
from robrst.base.resources import problems_dir
from robrst.core.rst import closed_loop
from robrst.problem.files import parse_problem
from robrst.synthesis.context import BOUND_MARGIN, Context
from robrst.synthesis.exchange import local_maxima, solve_exchange, solve_program
from robrst.synthesis.parametrize import integral_gain

IPOPT = {"max_iter": 500, "tol": 1e-10, "print_level": 0, "sb": "yes",
         "mu_strategy": "monotone", "nlp_scaling_method": "none"}


def _setup(n_freq):
    """The continuous-only robust problem (free dominant poles) and its analytic start."""
    path = problems_dir() / "paper_robust_continuous.toml"
    data = tomllib.loads(path.read_text())
    data["solver"]["n_freq"] = n_freq
    problem = parse_problem(data, str(path))
    start = analytic_design(problem)
    ctx = Context.of(problem, start)
    setup = ctx.setup(list(problem.family.models), ctx.nu, "dominant")
    x0 = ctx.full(ctx.param.vector(start.controller), setup)
    return problem, ctx, setup, x0


@pytest.fixture(scope="module")
def full_and_exchange():
    problem, ctx, setup, x0 = _setup(60)
    templates = {}
    full = solve_program(setup, x0, IPOPT, templates=templates)
    exch = {c: solve_exchange(setup, x0, IPOPT, coarse_points=c, templates=templates)
            for c in (2, 16)}
    return problem, ctx, setup, full, exch


def test_local_maxima_matches_brute_force():
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 7, 50):
        r = rng.integers(0, 4, n).astype(float)   # plateaus on purpose
        got = local_maxima(r)
        for i in range(n):
            left_ok = i == 0 or r[i] > r[i - 1]
            right_ok = i == n - 1 or r[i] >= r[i + 1]
            assert (i in got) == (left_ok and right_ok or n <= 2)
        # the global maximum is always found
        assert r[got].max() == r.max()


@pytest.mark.parametrize("coarse", [2, 16])
def test_exchange_reaches_the_full_grid_optimum(full_and_exchange, coarse):
    problem, ctx, setup, full, exch = full_and_exchange
    x_full, x_ex, info = full.x, exch[coarse].x, exch[coarse].exchange
    assert full.status == "Solve_Succeeded"
    assert exch[coarse].status == "Solve_Succeeded"
    assert info.active_points < info.grid_points / 3
    k_full = integral_gain(ctx.controller(x_full))
    k_ex = integral_gain(ctx.controller(x_ex))
    np.testing.assert_allclose(k_ex, k_full, rtol=1e-7)
    np.testing.assert_allclose(x_ex[-3:-1], x_full[-3:-1], rtol=1e-5)   # wn, zeta


def test_few_starting_points_need_more_rounds(full_and_exchange):
    *_, exch = full_and_exchange
    assert exch[2].exchange.rounds >= 2
    assert exch[16].exchange.active_points > exch[2].exchange.active_points


def test_every_grid_point_holds_recomputed_from_the_controller(full_and_exchange):
    """|S|, |T|, |U| on every (unscaled) grid frequency of every model, via np.polyval."""
    problem, ctx, setup, _, exch = full_and_exchange
    x = exch[2].x
    nu = setup.nu * setup.w0
    ctrl = ctx.controller(x)
    sp = problem.specs
    band = 2 * np.pi * np.geomspace(*sp.resonance_band_hz, 25)
    worst = 0.0
    for m in problem.family.models:
        cl = closed_loop(m, ctrl)
        for name, bound, w in (("S", sp.Ms_max, nu), ("T", sp.Mt_max, nu),
                               ("U", sp.Mu_max, nu), ("T", sp.T_resonance_max, band)):
            N, D = cl.tf(name)
            mag = np.abs(np.polyval(N, 1j * w) / np.polyval(D, 1j * w))
            worst = max(worst, float(np.max(mag / (bound * BOUND_MARGIN))))
    assert worst <= 1.0 + 1e-6
    assert worst == pytest.approx(exch[2].exchange.max_grid_ratio, rel=1e-6)


def test_a_repeated_program_is_solved_once(monkeypatch):
    """The homotopy can pose the very same program twice (same data, start, options): the
    synthesis reuses the first result, and any change of data or start is a new solve."""
    import robrst.synthesis.attempts as attempts
    from robrst.synthesis.exchange import Phase

    problem, ctx, setup, x0 = _setup(30)
    calls = []
    real = attempts.solve_exchange

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(attempts, "solve_exchange", counted)
    run = attempts.Run(problem, lambda m: None, {})
    first = run.solve(ctx, setup, x0.copy(), Phase("hard"), "analytic")
    n = len(calls)
    again = run.solve(ctx, ctx.setup(list(problem.family.models), ctx.nu, "dominant"),
                      x0.copy(), Phase("hard"), "analytic")       # rebuilt, equal data
    assert len(calls) == n and again is first and len(run.rounds) == 2
    x1 = x0.copy()
    x1[0] = np.nextafter(x1[0], np.inf)                               # one ulp: a new start
    run.solve(ctx, setup, x1, Phase("hard"), "analytic")
    assert len(calls) > n
    m = len(calls)
    run.solve(ctx, setup, x0.copy(), Phase("soft", 0.97), "analytic")  # another program
    assert len(calls) > m


def test_peaks_near_their_bound_start_with_their_neighbours():
    """The first active set: coarse points, every local maximum, and the two neighbours of
    a maximum above NEIGHBOURS_NEAR of its bound (one that binds moves by a grid point or
    so on the way to the optimum), not of one below; none with freely placed poles."""
    from robrst.synthesis.exchange import NEIGHBOURS_NEAR, _initial_active

    r = 0.1 + 0.001 * np.arange(41.0)             # rising: the last point a maximum
    r[10], r[30] = NEIGHBOURS_NEAR + 0.05, NEIGHBOURS_NEAR - 0.05
    active = _initial_active([r], 3)[0]
    assert set(active) == {0, 20, 40, 9, 10, 11, 30}
    # freely placed poles (the trust-region search): the maxima alone
    assert set(_initial_active([r], 3, neighbours=False)[0]) == {0, 20, 40, 10, 30}


def test_a_point_that_meets_every_row_at_the_iteration_limit_is_kept():
    """IPOPT stopped by its iteration limit: the solve is a success (its point used, then
    certified like any other) exactly when the point meets every row of its program within
    ``FEASIBLE_TOL`` (violations recomputed here from the rows and their bounds); else it stays
    IPOPT's failure.  Both happen on the way from the analytic start (free poles)."""
    from robrst.synthesis.outcome import FEASIBLE_TOL, LIMIT_FEASIBLE

    problem, ctx, _, _ = _setup(60)
    start = analytic_design(problem)
    setup = ctx.setup(list(problem.family.models), ctx.nu, "free")
    x0 = ctx.full(ctx.param.vector(start.controller), setup)
    seen = set()
    for k in range(1, 25):
        res = solve_program(setup, x0, {**IPOPT, "max_iter": k})
        if res.status == "Solve_Succeeded":
            break
        lbg, ubg, g = (np.asarray(a, float) for a in (res.lbg, res.ubg, res.g))
        worst = float(np.max(np.maximum(lbg - g, g - ubg)))
        assert res.status in (LIMIT_FEASIBLE, "Maximum_Iterations_Exceeded"), res.status
        assert (res.status == LIMIT_FEASIBLE) == (worst <= FEASIBLE_TOL), (k, worst)
        assert res.success == (res.status == LIMIT_FEASIBLE)
        seen.add(res.status)
    assert seen == {LIMIT_FEASIBLE, "Maximum_Iterations_Exceeded"}, seen


def test_a_round_that_fails_from_the_previous_optimum_is_solved_from_the_start(
        monkeypatch, full_and_exchange):
    """A later round starts at the previous round's optimum, outside the rows it adds;
    where IPOPT fails from there (emulated: every solve that does not start at the
    exchange's start reports ``Infeasible_Problem_Detected``), the round is solved again
    from the start and the exchange still reaches the full-grid optimum."""
    from dataclasses import replace

    import robrst.synthesis.exchange as exchange

    problem, ctx, setup, full, _ = full_and_exchange
    _, _, _, x0 = _setup(60)
    real = exchange.solve_program
    starts = []

    def failing_away_from_the_start(setup, x, *args, **kwargs):
        res = real(setup, x, *args, **kwargs)
        at_start = bool(np.array_equal(x, x0))
        starts.append(at_start)
        return res if at_start else replace(res, status="Infeasible_Problem_Detected")

    monkeypatch.setattr(exchange, "solve_program", failing_away_from_the_start)
    res = solve_exchange(setup, x0, IPOPT, coarse_points=2)
    assert res.status == "Solve_Succeeded" and res.exchange.rounds >= 2
    assert sum(starts) >= 2 and not all(starts)     # later rounds were solved from x0
    k_full = integral_gain(ctx.controller(full.x))
    np.testing.assert_allclose(integral_gain(ctx.controller(res.x)), k_full, rtol=1e-7)


@pytest.mark.slow
def test_a_polish_keeps_its_exchange_rounds_within_the_free_cap(monkeypatch):
    """Every exchange with freely placed poles (the trust regions, the solves over the
    poles and the linearised rounds of the reference-step samples and damping floors)
    stops after ``RunOptions.free_exchange_rounds``.  On the 4th-order stage 37 (default
    specs: the plant's damping as a floor) one linearised round of a polish ran to the
    exchange's safety cap of 50 rounds (4,207 IPOPT iterations, 13 s of the design's
    48 s CPU, measured 2026-12-05); capped, the design answers 1,145,611 (uncapped
    1,145,815) in 38 s."""
    import robrst.synthesis.attempts as attempts
    from robrst.design import run_problem
    from stages_global import stage_doc

    real, seen = attempts.solve_exchange, []

    def counted(setup, *args, **kwargs):
        res = real(setup, *args, **kwargs)
        if setup.placement == "free":
            seen.append(res.exchange.rounds)
        return res

    monkeypatch.setattr(attempts, "solve_exchange", counted)
    r = run_problem(parse_problem(stage_doc(37, order=4), "<stage 37>"), analyses=False)
    assert r.certified and r.integral_gain >= 0.99 * 1_145_815
    assert seen and max(seen) <= attempts.RUN.free_exchange_rounds, max(seen)
